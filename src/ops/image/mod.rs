//! Per-image operations.

pub mod blur;
pub mod constant;
pub mod crop;
pub mod difference;
pub mod embed;
pub mod exposure;
pub mod flip_vertical;
pub mod image_error;
pub mod luminance;
pub mod math;
pub mod mean_light_vector;
pub mod merge_channels;
pub mod overlay;
pub mod project;
pub mod resize;
pub mod rotate;
pub mod sanitize;
pub mod solid_angle;
pub mod split_channels;
pub mod statistics;
pub mod tonemap;

use crate::engine::registry::{Registry, RegistryError};

pub fn register(r: &mut Registry) -> Result<(), RegistryError> {
    r.register(luminance::spec())?;
    r.register(flip_vertical::spec())?;
    r.register(resize::spec())?;
    r.register(exposure::spec())?;
    r.register(constant::spec())?;
    r.register(overlay::spec())?;
    r.register(image_error::spec())?;
    r.register(split_channels::spec())?;
    r.register(merge_channels::spec())?;
    r.register(math::spec())?;
    r.register(crop::spec())?;
    r.register(blur::spec())?;
    r.register(tonemap::spec())?;
    r.register(difference::spec())?;
    r.register(rotate::spec())?;
    r.register(statistics::spec())?;
    r.register(solid_angle::spec())?;
    r.register(mean_light_vector::spec())?;
    r.register(project::spec())?;
    r.register(embed::spec())?;
    r.register(sanitize::spec())?;
    Ok(())
}
