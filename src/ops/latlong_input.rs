//! The checks the operators that read an environment map share: a map that is not 2:1 is most
//! likely another layout (a square angular probe or mirror ball, a cube cross) that would be
//! read as if it were lat-long, silently giving a wrong result; a NaN or infinite texel would
//! poison every sum over the map.
//!
//! Shared helpers live in files like this one, not in an operator's file: an operator file's
//! hash goes into its own operator's cache keys only (see `build.rs`).

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError};
use crate::maths::render::reference::first_non_finite;
use crate::values::Image;

/// Warns once per node when the map wired to `input` is not 2:1 (the lat-long shape), naming
/// its field and the operators that convert the layouts hdrflow reads.
pub fn warn_unless_latlong(ctx: &mut OpContext, input: &Input<Image>) {
    warn_unless_latlong_size(ctx, input.field(), input.width, input.height);
}

/// [`warn_unless_latlong`] for a map derived from the input wired to `field` (`Input::field`).
pub fn warn_unless_latlong_size(ctx: &mut OpContext, field: &str, width: usize, height: usize) {
    if width != 2 * height {
        ctx.warn(format!(
            "field {field:?} is {width} x {height}, not 2:1, but is read as a lat-long map \
             (convert an angular probe with AngularToLatLong first, a chrome ball with \
             MirrorBallToLatLong, a cube cross with LayoutToCubemap and CubemapToLatLong)"
        ));
    }
}

/// An error naming the first NaN or infinite texel of `env`, if any (shared by the operators
/// that sum over the whole map).
pub(crate) fn check_finite(env: &Image) -> Result<(), OpError> {
    match first_non_finite(env) {
        Some((x, y, v)) => Err(OpError::Invalid(format!(
            "texel ({x}, {y}) of the environment is {v}: an exact sum needs finite radiance"
        ))),
        None => Ok(()),
    }
}
