//! The one check every operator that reads its input as a lat-long map shares: a map that is
//! not 2:1 is most likely another layout (a square angular probe or mirror ball, a cube cross)
//! that would be read as if it were lat-long, silently giving a wrong result.

use crate::engine::op::OpContext;

/// Warns once per node when `field`'s `width` x `height` map is not 2:1 (the lat-long shape),
/// naming the operators that convert the layouts hdrflow reads.
pub fn warn_unless_latlong(ctx: &mut OpContext, field: &str, width: usize, height: usize) {
    if width != 2 * height {
        ctx.warn(format!(
            "field {field:?} is {width} x {height}, not 2:1, but is read as a lat-long map \
             (convert an angular probe with AngularToLatLong first, a chrome ball with \
             MirrorBallToLatLong, a cube cross with LayoutToCubemap and CubemapToLatLong)"
        ));
    }
}
