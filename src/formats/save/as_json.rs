//! How `Save` writes the values saved only as their JSON object: a `light`, `lights`, `sg`, a
//! `camera`, a `label` and a photograph's `exif`, each as `.json`. The object is the type's own (`to_json_value` in its
//! module under `crate::values`, where its keys are documented), so that a label's parts are
//! key for key the files their own types save.

use crate::engine::registry::Registry;
use crate::engine::save::SaveOptions;
use crate::engine::value::Value;
use crate::values::{camera, exif, label, light, lights, sg};
use crate::values::{Camera, Exif, Label, Light, Lights, SphericalGaussians, CAMERA, EXIF, LABEL, LIGHT, LIGHTS, SG};

/// Registers the savers of lights, spherical Gaussians, cameras and labels.
pub fn register(r: &mut Registry) {
    r.register_saver(&LIGHT, &["json"], save_light);
    r.register_saver(&LIGHTS, &["json"], save_lights);
    r.register_saver(&SG, &["json"], save_sg);
    r.register_saver(&CAMERA, &["json"], save_camera);
    r.register_saver(&LABEL, &["json"], save_label);
    r.register_saver(&EXIF, &["json"], save_exif);
}

fn save_light(value: &Value, _: &SaveOptions) -> Result<Vec<u8>, String> {
    let l = value.get::<Light>().ok_or("not a light")?;
    Ok(light::to_json(l).into_bytes())
}

fn save_lights(value: &Value, _: &SaveOptions) -> Result<Vec<u8>, String> {
    let l = value.get::<Lights>().ok_or("not lights")?;
    Ok(lights::to_json(l).into_bytes())
}

fn save_sg(value: &Value, _: &SaveOptions) -> Result<Vec<u8>, String> {
    let sg = value.get::<SphericalGaussians>().ok_or("not spherical Gaussians")?;
    Ok(sg::to_json(sg).into_bytes())
}

fn save_camera(value: &Value, _: &SaveOptions) -> Result<Vec<u8>, String> {
    let c = value.get::<Camera>().ok_or("not a camera")?;
    Ok(crate::values::json::text(&camera::to_json_value(c)).into_bytes())
}

fn save_label(value: &Value, _: &SaveOptions) -> Result<Vec<u8>, String> {
    let l = value.get::<Label>().ok_or("not a label")?;
    Ok(label::to_json(l).into_bytes())
}

fn save_exif(value: &Value, _: &SaveOptions) -> Result<Vec<u8>, String> {
    let e = value.get::<Exif>().ok_or("not EXIF settings")?;
    Ok(exif::to_json(e).into_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::values::label::to_json;

    #[test]
    fn each_part_is_the_json_its_own_type_saves() {
        let l = crate::values::label::full_label_for_tests();
        let json: serde_json::Value = serde_json::from_str(&to_json(&l)).unwrap();
        let own = |text: &str| serde_json::from_str::<serde_json::Value>(text).unwrap();
        let opts = SaveOptions::new("json");
        let mut registry = Registry::empty();
        super::super::register_all(&mut registry);
        let saved = |v: Value| {
            let save = registry.saver(v.value_type()).expect("a saver").save;
            own(&String::from_utf8(save(&v, &opts).unwrap()).unwrap())
        };
        assert_eq!(json["camera"], saved(Value::new(l.camera)));
        assert_eq!(json["sh"], saved(Value::new(l.sh.clone().unwrap())));
        assert_eq!(json["spherical_gaussians"], saved(Value::new(l.sgs.clone().unwrap())));
        assert_eq!(json["lights"], saved(Value::new(l.lights.clone().unwrap())));
        assert_eq!(json["sh"]["coefficients"].as_array().map(Vec::len), Some(4));
    }
}
