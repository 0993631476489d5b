//! Layout conversions between lat-long maps and the layouts captures and datasets store: the
//! angular probe, the mirror ball, and the upper hemisphere alone (sky lat-long, sky angular).
//! The geometry is `geometry::azimuthal`, the resampling `maths::resample::disc_image`; the conventions
//! are in docs/src/guides/toolkit/map_layouts.md.

pub mod angular_to_latlong;
pub mod latlong_to_angular;
pub mod latlong_to_mirror_ball;
pub mod latlong_to_sky_angular;
pub mod latlong_to_sky_latlong;
pub mod mirror_ball_to_latlong;
pub mod sky_angular_to_latlong;
pub mod sky_latlong_to_latlong;

use glam::DVec3;

use crate::engine::fields::Shape;
use crate::engine::op::{CheckProblem, OpError};
use crate::engine::registry::{Registry, RegistryError};
use crate::geometry::azimuthal::DiscMap;
use crate::geometry::rotation::Rotation;
use crate::geometry::unit;
use crate::values::Image;

pub fn register(r: &mut Registry) -> Result<(), RegistryError> {
    r.register(angular_to_latlong::spec())?;
    r.register(latlong_to_angular::spec())?;
    r.register(mirror_ball_to_latlong::spec())?;
    r.register(latlong_to_mirror_ball::spec())?;
    r.register(latlong_to_sky_latlong::spec())?;
    r.register(sky_latlong_to_latlong::spec())?;
    r.register(latlong_to_sky_angular::spec())?;
    r.register(sky_angular_to_latlong::spec())?;
    Ok(())
}

/// Declares a mirror-ball operator's parameters: its inputs, then the camera's `yaw`, `pitch`,
/// `roll` and `look` (the same in both directions, so that they invert each other), then its
/// own fields: `ball_params! { MyParams { inputs } { own fields } }`.
macro_rules! ball_params {
    (
        $name:ident { $( $(#[$($iattr:tt)*])* $ivis:vis $input:ident : $ity:ty ),* $(,)? }
        { $($rest:tt)* }
    ) => {
        crate::params! {
            pub struct $name {
                $( $(#[$($iattr)*])* $ivis $input: $ity, )*
                /// camera yaw in degrees about +Y: the camera looks along R_y(yaw) R_x(pitch) (-Z), as Rotate
                #[range(-3600.0, 3600.0)]
                pub yaw: f64 = 0.0,
                /// camera pitch in degrees about +X; positive looks up
                #[range(-3600.0, 3600.0)]
                pub pitch: f64 = 0.0,
                /// camera roll in degrees about its viewing axis; positive turns the image's right towards its up
                #[range(-3600.0, 3600.0)]
                pub roll: f64 = 0.0,
                /// instead of yaw and pitch: the direction the camera looks along, world axes (need not be unit)
                pub look: Option<[f64; 3]>,
                $($rest)*
            }
        }
    };
}
pub(crate) use ball_params;

/// The mirror ball seen by a camera whose frame is `R = R_y(yaw) R_x(pitch) R_z(roll)` applied to
/// the default one (looking along -Z, right +X, up +Y): right `R X`, up `R Y`, towards the camera
/// `R Z`. `look` stands for yaw and pitch: `yaw = atan2(-l_x, -l_z)`, `pitch = asin(l_y)` of the
/// unit `l` (yaw 0 when looking straight up or down).
pub(crate) fn ball_map(
    yaw: f64,
    pitch: f64,
    roll: f64,
    look: Option<[f64; 3]>,
    look_field: &'static str,
) -> Result<DiscMap, CheckProblem> {
    let (yaw, pitch) = match look {
        None => (yaw, pitch),
        Some(_) if yaw != 0.0 || pitch != 0.0 => {
            return Err(CheckProblem::at(look_field, "give either yaw/pitch or look, not both"));
        }
        Some(l) => {
            let f = unit(DVec3::from(l))
                .ok_or_else(|| CheckProblem::at(look_field, "look must be a non-zero, finite direction"))?;
            let yaw = if f.x == 0.0 && f.z == 0.0 { 0.0 } else { (-f.x).atan2(-f.z).to_degrees() };
            (yaw, f.y.clamp(-1.0, 1.0).asin().to_degrees())
        }
    };
    let m = Rotation::from_yaw_pitch_roll(yaw, pitch, roll).0;
    Ok(DiscMap::mirror_ball(m.x_axis, m.y_axis, m.z_axis))
}

/// Refuses an input of known size that is not square (`what` names the layout).
pub(crate) fn check_square(field: &'static str, shape: Shape, what: &str) -> Result<(), CheckProblem> {
    match shape.size {
        Some((w, h)) if w != h => {
            Err(CheckProblem::at(field, format!("{field:?} is {w}x{h}, but {what} image must be square")))
        }
        _ => Ok(()),
    }
}

/// [`check_square`] at run time, for an input whose size was not known before.
pub(crate) fn require_square(img: &Image, field: &str, what: &str) -> Result<(), OpError> {
    if img.width != img.height {
        return Err(OpError::Invalid(format!(
            "{field:?} is {}x{}, but {what} image must be square",
            img.width, img.height
        )));
    }
    Ok(())
}

/// Refuses a lat-long input of known odd height (its rows do not split at the horizon).
pub(crate) fn check_even_height(field: &'static str, shape: Shape) -> Result<(), CheckProblem> {
    match shape.size {
        Some((w, h)) if h % 2 == 1 => Err(CheckProblem::at(
            field,
            format!("{field:?} is {w}x{h}: an odd height has no row boundary at the horizon"),
        )),
        _ => Ok(()),
    }
}

/// The per-channel fill values of `fill` for `channels` channels: none given is 0, one is every
/// channel's, else one per channel.
pub(crate) fn fill_values(fill: &[f64], channels: usize) -> Result<Vec<f32>, OpError> {
    match fill.len() {
        0 => Ok(vec![0.0; channels]),
        1 => Ok(vec![fill[0] as f32; channels]),
        n if n == channels => Ok(fill.iter().map(|&v| v as f32).collect()),
        n => Err(OpError::Invalid(format!(
            "fill has {n} values but the image has {channels} channels: give none (0), one for all, or one per channel"
        ))),
    }
}

/// Sets every pixel of `image` whose `mask` is 0 to `fill`.
pub(crate) fn fill_unseen(image: &mut Image, mask: &Image, fill: &[f32]) {
    for (px, &m) in image.data.chunks_exact_mut(image.channels).zip(&mask.data) {
        if m == 0.0 {
            px.copy_from_slice(fill);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).abs().max_element() < 1e-12
    }

    #[test]
    fn look_and_yaw_pitch_give_the_same_camera() {
        for (yaw, pitch) in [(0.0, 0.0), (90.0, 0.0), (-35.0, 20.0), (170.0, -60.0)] {
            let a = ball_map(yaw, pitch, 0.0, None, "look").unwrap();
            let f = Rotation::from_yaw_pitch_roll(yaw, pitch, 0.0).apply(DVec3::NEG_Z) * 3.0;
            let b = ball_map(0.0, 0.0, 0.0, Some(f.to_array()), "look").unwrap();
            assert!(close(a.right, b.right) && close(a.up, b.up) && close(a.axis, b.axis), "{yaw} {pitch}");
            assert!(close(-a.axis, f / 3.0));
        }
        let up = ball_map(0.0, 0.0, 0.0, Some([0.0, 2.0, 0.0]), "look").unwrap();
        assert!(close(up.axis, DVec3::NEG_Y) && close(up.up, DVec3::Z) && close(up.right, DVec3::X));
        let refused = |r: Result<DiscMap, CheckProblem>, why: &str| matches!(r, Err(CheckProblem { field: Some("look"), message }) if message.contains(why));
        assert!(refused(ball_map(0.0, 0.0, 0.0, Some([0.0; 3]), "look"), "non-zero, finite direction"));
        assert!(refused(ball_map(10.0, 0.0, 0.0, Some([0.0, 0.0, -1.0]), "look"), "either yaw/pitch or look"));
    }

    #[test]
    fn fill_values_follow_the_channels() {
        assert_eq!(fill_values(&[], 3).unwrap(), vec![0.0; 3]);
        assert_eq!(fill_values(&[0.5], 4).unwrap(), vec![0.5; 4]);
        assert_eq!(fill_values(&[1.0, 2.0, 3.0], 3).unwrap(), vec![1.0, 2.0, 3.0]);
        let e = fill_values(&[1.0, 2.0], 3).unwrap_err();
        assert!(
            matches!(&e, OpError::Invalid(m) if m.starts_with("fill has 2 values but the image has 3 channels")),
            "{e}"
        );
    }
}
