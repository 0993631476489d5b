//! `ShCoefficients` (`sh coefficients` in graphs): real spherical-harmonic coefficients of an
//! environment, per RGB channel, with their order and the frame their basis was evaluated in. The
//! basis, the frames and the projection are documented in `maths::ibl::sh`. Displayed as an
//! aligned table; its JSON object ([`to_json_value`]: frame, order, basis, coefficients) is what
//! `Save` writes as `.json` and a label's `sh`; `Save` also writes `.csv`
//! (`crate::formats::save::sh`, where both files are described).

use std::fmt::Write as _;

use super::json::num;
use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{TypeSpec, Value, ValueData, ValueType};

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
/// Plain data, its fields public: the projection writes them, the shading operators read them.
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

pub static SH_COEFFICIENTS: TypeSpec = TypeSpec {
    name: "sh coefficients",
    doc: "real spherical-harmonic coefficients L_lm per RGB channel, with their order and frame",
    decode,
};

/// The highest order a cache entry may claim (far above `ShIrradiance`'s 32; it only bounds
/// the arithmetic on a hostile entry before its length is checked).
const MAX_ORDER: usize = 1 << 12;

impl ValueData for ShCoefficients {
    fn value_type(&self) -> ValueType {
        ValueType(&SH_COEFFICIENTS)
    }
    fn approx_bytes(&self) -> usize {
        self.rgb.len() * 24
    }
    fn summary(&self) -> String {
        format!("{} SH coefficients (order {}, frame {})", self.rgb.len(), self.order, self.frame.name())
    }
    fn display(&self) -> Option<String> {
        Some(table(self))
    }
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = Writer(out);
        w.u64(self.order as u64);
        w.str(self.frame.name());
        w.u64(self.rgb.len() as u64);
        for c in &self.rgb {
            for v in c {
                w.f64(*v);
            }
        }
    }
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let order = r.usize()?;
    if order > MAX_ORDER {
        return Err(format!("SH order {order} is out of range"));
    }
    let name = r.str()?;
    let frame = ShFrame::from_name(&name).ok_or_else(|| format!("unknown SH frame {name:?}"))?;
    let n = r.usize()?;
    if n != (order + 1) * (order + 1) {
        return Err(format!("{n} SH coefficients for order {order}"));
    }
    r.need(n.saturating_mul(24))?;
    let mut rgb = Vec::with_capacity(n);
    for _ in 0..n {
        rgb.push([r.f64()?, r.f64()?, r.f64()?]);
    }
    r.finish()?;
    Ok(Value::new(ShCoefficients { order, frame, rgb }))
}

/// The JSON object: `frame`, `order`, `basis` (one line naming the convention and the axes) and
/// `coefficients`, `(order + 1)^2` rows `[r, g, b]` in `(l, m)` order (as in a label's `sh`).
pub fn to_json_value(c: &ShCoefficients) -> serde_json::Value {
    let mut map = serde_json::Map::new();
    map.insert("frame".into(), c.frame.name().into());
    map.insert("order".into(), c.order.into());
    map.insert("basis".into(), c.frame.basis().into());
    let rows = c.rgb.iter().map(|v| serde_json::Value::Array(v.iter().map(|&x| num(x)).collect())).collect();
    map.insert("coefficients".into(), serde_json::Value::Array(rows));
    serde_json::Value::Object(map)
}

/// A number for the table: fixed with 6 decimals in [1e-3, 1e7), else scientific.
fn cell(v: f64) -> String {
    if v == 0.0 || (1e-3..1e7).contains(&v.abs()) {
        format!("{v:.6}")
    } else {
        format!("{v:.5e}")
    }
}

/// The aligned table printed after a run: a title line, the basis, then `l m r g b`.
fn table(c: &ShCoefficients) -> String {
    let rows: Vec<(usize, isize, [String; 3])> = c.iter().map(|(l, m, v)| (l, m, v.map(cell))).collect();
    let width = rows.iter().flat_map(|r| r.2.iter().map(String::len)).max().unwrap_or(0).max(1);
    let mut out = format!("order {}, frame {}\n{}\n", c.order, c.frame.name(), c.frame.basis());
    let _ = write!(out, " l    m  {:>width$}  {:>width$}  {:>width$}", "r", "g", "b");
    for (l, m, [r, g, b]) in &rows {
        let _ = write!(out, "\n{l:>2} {m:>4}  {r:>width$}  {g:>width$}  {b:>width$}");
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> ShCoefficients {
        let rgb = (0..9).map(|i| [i as f64 * 0.5 - 1.0, 1e-9 * i as f64, 12345.678 / (i + 1) as f64]).collect();
        ShCoefficients { order: 2, frame: ShFrame::World, rgb }
    }

    #[test]
    fn cache_round_trip_and_hostile_entries() {
        for frame in ShFrame::ALL {
            let c = ShCoefficients { frame, ..sample() };
            let mut bytes = Vec::new();
            c.encode(&mut bytes);
            let back = decode(&bytes).unwrap();
            assert_eq!(back.get::<ShCoefficients>(), Some(&c));
            for cut in [0, 8, 20, bytes.len() - 1] {
                let e = decode(&bytes[..cut]).unwrap_err();
                assert!(e.starts_with("truncated: need"), "cut at {cut}: {e}");
            }
        }
        // A count that does not match the order, an unknown frame, a huge order.
        let mut bytes = Vec::new();
        let mut w = Writer(&mut bytes);
        w.u64(2);
        w.str("World");
        w.u64(8);
        assert!(decode(&bytes).unwrap_err().contains("8 SH coefficients for order 2"));
        let mut bytes = Vec::new();
        let mut w = Writer(&mut bytes);
        w.u64(0);
        w.str("Sideways");
        assert!(decode(&bytes).unwrap_err().contains("unknown SH frame"));
        let mut bytes = Vec::new();
        Writer(&mut bytes).u64(u64::MAX);
        let e = decode(&bytes).unwrap_err();
        assert!(e.contains("SH order") && e.ends_with("is out of range"), "{e}");
    }

    #[test]
    fn display_is_an_aligned_table() {
        let c = sample();
        let table = c.display().unwrap();
        let lines: Vec<&str> = table.lines().collect();
        assert_eq!(lines[0], "order 2, frame World");
        assert_eq!(lines.len(), 3 + 9);
        // Aligned: every row as long as the header, columns right-aligned.
        assert!(lines[2..].iter().all(|l| l.len() == lines[2].len()), "{table}");
        assert!(lines[4].starts_with(" 1   -1"), "{table}");
        assert!(table.contains("1.00000e-9"), "{table}");
    }
}
