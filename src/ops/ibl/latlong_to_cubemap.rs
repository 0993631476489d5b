//! `LatLongToCubemap(image, size, frame: Standard)`: a lat-long map as a cube map of face size
//! `size`, faces +X, -X, +Y, -Y, +Z, -Z in hdrflow's axes (`geometry::cubemap`), written for the
//! lookup `frame` names (`geometry::cube_frame`): `Standard` as hdrflow and OpenGL read it,
//! `MirrorZ` for Bevy, which samples with z negated (an exact permutation of the texels of the
//! `Standard` cube; tested where Bevy's lookup of a known direction lands).
//!
//! Energy-preserving: each cube texel is the solid-angle-weighted average of the lat-long map
//! (read as piecewise constant) over the texel's footprint, gathered from whole map texels and
//! straddling ones clipped by the texel's edges with a bounded error, split where the bound asks
//! (`maths::resample::latlong_cube`). A constant map gives the same constant to rounding; the
//! sphere integral is kept to 1e-3 relative on the built-in sky (2-degree sun), and texels on
//! both sides of a face edge agree as neighbours inside a face do (tests).

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::geometry::cube_frame::CubeFrame;
use crate::maths::resample::latlong_cube::latlong_to_cube;
use crate::maths::resample::layouts::LatLongSource;
use crate::ops::latlong_input::warn_unless_latlong;
use crate::values::ty::*;
use crate::values::{Cubemap, Image};

crate::params! {
    pub struct LatLongToCubemapParams {
        /// the lat-long map (RGB; one channel is read as grey)
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// face size in texels (the cube has 6 size^2 texels)
        #[range(1, 16384)]
        pub size: usize,
        /// the lookup the cube is written for: Standard (world direction, OpenGL / Vulkan: Filament, Khronos, three.js) or MirrorZ (z negated: Bevy)
        pub frame: CubeFrame = CubeFrame::Standard,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "LatLongToCubemap",
        2,
        "Lat-long map to cube map (+X -X +Y -Y +Z -Z), each texel the solid-angle-weighted mean of its footprint",
        eval,
    )
    .output("cubemap", CUBEMAP_T, "the cube map")
    .size(|_, p| Some((6 * p.size as u64, p.size as u64)))
    .into()
}

fn eval(ctx: &mut OpContext, p: LatLongToCubemapParams) -> Result<Value, OpError> {
    warn_unless_latlong(ctx, &p.image);
    let img = &*p.image;
    crate::ops::latlong_input::check_finite(img)?;
    Ok(Value::new(in_frame(&latlong_to_cube(&LatLongSource::new(img), p.size), p.frame)))
}

/// `cube` written for an engine that samples it in `frame` (`geometry::cube_frame`): each texel
/// copied from the texel the engine's lookup means, an exact permutation (the bits are kept).
pub fn in_frame(cube: &Cubemap, frame: CubeFrame) -> Cubemap {
    if frame == CubeFrame::Standard {
        return cube.clone();
    }
    let mut out = Cubemap::new(cube.size);
    for (i, j) in frame.source_texels(cube.size).into_iter().enumerate() {
        out.data[3 * i..3 * i + 3].copy_from_slice(&cube.data[3 * j..3 * j + 3]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::cubemap as geo;
    use glam::DVec3;

    /// A lat-long map black but for one texel: in the `MirrorZ` cube that texel's light sits where
    /// Bevy's lookup of its direction (z negated) reads, and the cube holds the same values.
    #[test]
    fn a_marked_texel_lands_where_bevy_samples_its_direction() {
        let (w, h, size) = (128, 64, 4);
        // A lat-long texel well inside texel (1, 1) of the -Z face (forward, up and to the left).
        let target = geo::texel_direction(5, 1, 1, size);
        let (mx, my) = crate::geometry::latlong::texel_of_direction(target.to_array(), w, h);
        let mut img = Image::new(w, h, 3);
        img.pixel_mut(mx, my).copy_from_slice(&[1000.0, 0.0, 0.0]);
        let d = DVec3::from(crate::geometry::latlong::texel_direction(mx, my, w, h));
        let std_cube = latlong_to_cube(&LatLongSource::new(&img), size);
        let bevy = in_frame(&std_cube, CubeFrame::MirrorZ);
        let brightest = |c: &Cubemap| (0..c.texel_count()).max_by(|&a, &b| c.texel(a)[0].total_cmp(&c.texel(b)[0]));
        assert_eq!(brightest(&std_cube), Some(geo::texel_index_of_direction(d, size)));
        let bevy_lookup = DVec3::new(d.x, d.y, -d.z);
        assert_eq!(geo::texel_of_direction(bevy_lookup, size).0, 4, "Bevy looks forward up on the +Z face");
        assert_eq!(brightest(&bevy), Some(geo::texel_index_of_direction(bevy_lookup, size)));
        let mut a = std_cube.data.clone();
        let mut b = bevy.data.clone();
        a.sort_by(f32::total_cmp);
        b.sort_by(f32::total_cmp);
        assert_eq!(a, b);
        assert_eq!(in_frame(&bevy, CubeFrame::MirrorZ), std_cube);
    }
}
