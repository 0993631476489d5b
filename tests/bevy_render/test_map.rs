//! The asymmetric test map of the engine render tests (tests/bevy_render.rs,
//! tests/filament_render.rs): shared by `#[path]` so both engines see the same lights.

use hdrflow::values::Image;

/// The asymmetric test map, 512 x 256: a blue sky brighter towards the zenith, a brown ground, a
/// warm light up, right and in front (x, y, z > 0) and a green one low, left, in front; both
/// spherical Gaussians `a exp(lambda (mu.d - 1))`, smooth enough for a 64 cube.
pub fn test_map() -> Image {
    let warm = glam::DVec3::new(0.45, 0.55, 0.7).normalize();
    let green = glam::DVec3::new(-0.7, -0.1, 0.5).normalize();
    let (w, h) = (512, 256);
    Image::from_fn_rgb(w, h, |x, y| {
        let d = glam::DVec3::from(hdrflow::geometry::latlong::texel_direction(x, y, w, h));
        let base = if d.y > 0.0 { [0.3, 0.45, 0.8].map(|c| c * (0.4 + 0.6 * d.y)) } else { [0.12, 0.1, 0.07] };
        let sw = (100.0 * (warm.dot(d) - 1.0)).exp();
        let sg = (60.0 * (green.dot(d) - 1.0)).exp();
        [base[0] + 30.0 * sw + 2.0 * sg, base[1] + 12.0 * sw + 10.0 * sg, base[2] + 3.0 * sw + 3.0 * sg]
            .map(|c| c as f32)
    })
}
