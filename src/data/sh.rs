//! `ShCoefficients`: real spherical-harmonic coefficients of an environment, per RGB channel,
//! with the frame their basis was evaluated in. The basis, the frames and the projection are
//! documented in `maths::sh`.

crate::choice! {
    /// The axes `(x, y, z)` the real SH basis is evaluated in, as functions of a unit direction
    /// `d = (d_x, d_y, d_z)` in hdrflow's world (+Y up, -Z forward, +X right: right-handed).
    /// The same map gives different coefficients in each frame: a shader must evaluate the basis
    /// in the frame the coefficients were computed in.
    pub enum ShFrame {
        /// `(x, y, z) = (d_x, d_y, d_z)`: hdrflow's own axes, as Y-up engines evaluate the basis
        /// (three.js `SphericalHarmonics3`, Filament's 3-band irradiance SH): `L_1,-1` goes with
        /// the up axis.
        World,
        /// `(x, y, z) = (d_x, d_y, -d_z)`: Ramamoorthi and Hanrahan's frame for a Debevec light
        /// probe (z towards the probe's centre, that is forward), in which their published Grace
        /// Cathedral coefficients are expressed. A mirror image of `World`:
        /// `L_lm(Paper) = (-1)^(l+m) L_lm(World)`.
        Paper,
        /// `(x, y, z) = (d_z, -d_x, d_y)`: z along the lat-long map's pole (+Y), azimuth = the map's
        /// `phi`. The frame of `ShIrradiance` version 1; hdrflow projects in it (one Fourier sum per
        /// row) and `ShSphere` uses it internally.
        LatLong,
    }
}

impl ShFrame {
    /// The frame's `(x, y, z)` for a unit direction `d` of hdrflow's world.
    #[inline]
    pub fn axes(self, d: [f64; 3]) -> [f64; 3] {
        match self {
            ShFrame::World => d,
            ShFrame::Paper => [d[0], d[1], -d[2]],
            ShFrame::LatLong => [d[2], -d[0], d[1]],
        }
    }

    /// One line naming the basis convention and the axes (written into saved files).
    pub fn basis(self) -> &'static str {
        match self {
            ShFrame::World => {
                "real SH, orthonormal, no Condon-Shortley phase, index l(l+1)+m; (x, y, z) = hdrflow world \
                 (X right, Y up, Z back: forward is -Z); Y_1-1 = 0.488603 y, Y_10 = 0.488603 z, \
                 Y_11 = 0.488603 x, as three.js SphericalHarmonics3"
            }
            ShFrame::Paper => {
                "real SH, orthonormal, no Condon-Shortley phase, index l(l+1)+m; (x, y, z) = (X, Y, -Z) of \
                 hdrflow world (x right, y up, z forward): Ramamoorthi-Hanrahan 2001 for a Debevec probe; \
                 Y_1-1 = 0.488603 y, Y_10 = 0.488603 z, Y_11 = 0.488603 x"
            }
            ShFrame::LatLong => {
                "real SH, orthonormal, no Condon-Shortley phase, index l(l+1)+m; (x, y, z) = (Z, -X, Y) of \
                 hdrflow world (z up, azimuth = lat-long phi); Y_1-1 = 0.488603 y, Y_10 = 0.488603 z, \
                 Y_11 = 0.488603 x"
            }
        }
    }
}

/// Real SH coefficients `L_lm` up to band `order`, in `(l, m)` order (l = 0..=order,
/// m = -l..=l: index `l (l + 1) + m`), one `[r, g, b]` per coefficient, `(order + 1)^2` of them.
#[derive(Clone, Debug, PartialEq)]
pub struct ShCoefficients {
    pub order: usize,
    pub frame: ShFrame,
    pub rgb: Vec<[f64; 3]>,
}

impl ShCoefficients {
    /// The coefficient `L_lm`, or `None` when `l > order` or `|m| > l`.
    pub fn get(&self, l: usize, m: isize) -> Option<[f64; 3]> {
        if l > self.order || m.unsigned_abs() > l {
            return None;
        }
        self.rgb.get(((l * (l + 1)) as isize + m) as usize).copied()
    }

    /// `(l, m, [r, g, b])` in storage order.
    pub fn iter(&self) -> impl Iterator<Item = (usize, isize, [f64; 3])> + '_ {
        (0..=self.order)
            .flat_map(|l| (-(l as isize)..=l as isize).map(move |m| (l, m)))
            .zip(&self.rgb)
            .map(|((l, m), c)| (l, m, *c))
    }
}
