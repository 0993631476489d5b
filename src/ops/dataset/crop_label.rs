//! `CropLabel(camera, sh, sgs, lights)`: one crop's label for a lighting-estimation dataset,
//! a `label` value saved as one JSON file per crop (`values::label`):
//!
//! - `camera` (required): a `Project` node's `camera` port (`"crop.camera"`), so the label
//!   holds the fields that cut the crop (model, fov, width, height, yaw, pitch, roll) and the
//!   world-to-camera matrix `R^T` of its rotation `R = R_y(yaw) R_x(pitch) R_z(roll)`: it maps
//!   the crop's centre ray to (0, 0, -1) and any world direction to the crop's camera space.
//! - `sh`, `sgs`, `lights` (each optional): `ShIrradiance`'s coefficients, `SphericalGaussians`'
//!   lobes and `ExtractLights`' lights, copied as they are: the label's parts are the JSON those
//!   types save, number for number, and a part not wired is left out.
//!
//! The lighting stays in the frame of the map the crop was cut from (hdrflow's world axes, as
//! the fitting operators give it): in a dataset that rotates each map before cropping, that is
//! the rotated map. A light's or lobe's direction `d` is `world_to_camera d` in camera space
//! (+X right, +Y up, looking down -Z).

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::values::ty::*;
use crate::values::{Camera, Label, Lights, ShCoefficients, SphericalGaussians};

crate::params! {
    pub struct CropLabelParams {
        /// the crop's camera: a Project node's camera port ("crop.camera")
        #[input(&[CAMERA_T])]
        pub camera: Input<Camera>,
        /// the map's SH coefficients (ShIrradiance), written under "sh"
        #[input(&[SH_COEFFICIENTS_T])]
        pub sh: Option<Input<ShCoefficients>>,
        /// the map's spherical Gaussian lobes (SphericalGaussians), written under "spherical_gaussians"
        #[input(&[SG_T])]
        pub sgs: Option<Input<SphericalGaussians>>,
        /// the map's parametric lights (ExtractLights), written under "lights"
        #[input(&[LIGHTS_T])]
        pub lights: Option<Input<Lights>>,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "CropLabel",
        1,
        "A crop's dataset label: its camera (with the world-to-camera matrix) and the map's SH, lobes and lights",
        eval,
    )
    .output("label", LABEL_T, "the label (Save it as .json)")
    .into()
}

fn eval(_: &mut OpContext, p: CropLabelParams) -> Result<Value, OpError> {
    Ok(Value::new(Label {
        camera: *p.camera,
        sh: p.sh.map(|s| (*s).clone()),
        sgs: p.sgs.map(|s| (*s).clone()),
        lights: p.lights.map(|l| (*l).clone()),
    }))
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use crate::geometry::latlong::{texel_direction, texel_of_direction};
    use crate::geometry::lens::{Lens, Model};
    use crate::maths::camera::view::{project, Filter};
    use crate::values::{Camera, Image};

    /// The crop Project cuts shows a texel where the label's matrix says the camera sees it.
    #[test]
    fn the_label_matrix_puts_a_bright_texel_where_project_shows_it() {
        let (w, h) = (256, 128);
        let views =
            [(20.0, -15.0, 0.0, [0.3, -0.2]), (-110.0, 35.0, 25.0, [-0.5, 0.4]), (160.0, -40.0, -70.0, [0.1, 0.6])];
        for (yaw, pitch, roll, [a, b]) in views {
            let cam = Camera { model: Model::Perspective, fov: 100.0, width: 201, height: 151, yaw, pitch, roll };
            // A texel the camera sees off-centre, at camera ray (a, b, -1) turned by the view.
            let aim = cam.rotation().apply(DVec3::new(a, b, -1.0).normalize());
            let (tx, ty) = texel_of_direction(aim.to_array(), w, h);
            let env = Image::from_fn_rgb(w, h, |x, y| if (x, y) == (tx, ty) { [1000.0; 3] } else { [0.0; 3] });
            // Where the matrix puts the texel's centre direction in camera space, and so in the crop.
            let d = DVec3::from_array(texel_direction(tx, ty, w, h));
            let m = cam.world_to_camera().map(DVec3::from_array);
            let c = DVec3::new(m[0].dot(d), m[1].dot(d), m[2].dot(d));
            let lens = Lens::new(cam.model, cam.fov, cam.width, cam.height).unwrap();
            let (x, y) = lens.plane_of(c).expect("in front of the camera");
            assert!(lens.in_frame(x, y), "texel ({tx}, {ty}) outside the crop: ({x}, {y})");
            // The matrix is R^T: the centre ray comes back to (0, 0, -1).
            let f = cam.forward();
            assert!((DVec3::new(m[0].dot(f), m[1].dot(f), m[2].dot(f)) - DVec3::NEG_Z).length() < 1e-12);
            let (px, py) = lens.pixel(x, y);
            let view = project(&env, &lens, cam.rotation(), Filter::Bilinear);
            let lum = |i: usize| view.rgb(i % cam.width, i / cam.width).iter().sum::<f32>();
            let brightest = (0..cam.width * cam.height).max_by(|&i, &j| lum(i).total_cmp(&lum(j))).unwrap();
            assert!(lum(brightest) > 0.0);
            let (bx, by) = ((brightest % cam.width) as f64 + 0.5, (brightest / cam.width) as f64 + 0.5);
            // Bilinear lookups peak at the texel centre (the texel spans 1.4 degrees, 2.8 crop pixels).
            assert!(
                (bx - px).abs() < 2.0 && (by - py).abs() < 2.0,
                "matrix says ({px}, {py}), Project shows ({bx}, {by})"
            );
        }
    }
}
