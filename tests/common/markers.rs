//! The orientation check of the engine render tests (tests/filament_render.rs,
//! tests/three_render.rs): a map of coloured markers at known directions, what a perspective
//! camera at the origin must see of it, and where each marker is in a rendered frame. Included by
//! `#[path]`; the mirrored map is the classic mistake every engine test makes on purpose.

use glam::{DMat3, DVec3};
use hdrflow::values::Image;

/// A marker: its colour and direction (hdrflow's axes).
pub struct Marker {
    pub name: &'static str,
    pub colour: [f32; 3],
    pub direction: DVec3,
}

/// The markers of [`orientation_map`]: red at the map's centre (forward, -Z), green 30 degrees
/// to its left (towards -X, a twelfth of the width to the left in the image), blue 30 degrees to
/// its right (towards +X), white 30 degrees above.
pub fn markers() -> Vec<Marker> {
    let (s, c) = 30f64.to_radians().sin_cos();
    vec![
        Marker { name: "centre (red)", colour: [1.0, 0.0, 0.0], direction: DVec3::new(0.0, 0.0, -1.0) },
        Marker { name: "left (green)", colour: [0.0, 1.0, 0.0], direction: DVec3::new(-s, 0.0, -c) },
        Marker { name: "right (blue)", colour: [0.0, 0.0, 1.0], direction: DVec3::new(s, 0.0, -c) },
        Marker { name: "up (white)", colour: [1.0, 1.0, 1.0], direction: DVec3::new(0.0, s, -c) },
    ]
}

/// The grey of [`orientation_map`] between the markers.
pub const BACKGROUND: f32 = 0.05;

/// A dim grey 1024 x 512 map with the [`markers`] as spherical Gaussians of radiance 50 and
/// sharpness 3000 (about 1.5 degrees wide: several texels of a 256 cube face).
pub fn orientation_map() -> Image {
    let (w, h) = (1024, 512);
    let markers = markers();
    Image::from_fn_rgb(w, h, |x, y| {
        let d = DVec3::from(hdrflow::geometry::latlong::texel_direction(x, y, w, h));
        let mut px = [BACKGROUND; 3];
        for m in &markers {
            let g = 50.0 * (3000.0 * (m.direction.dot(d) - 1.0)).exp() as f32;
            for (p, c) in px.iter_mut().zip(m.colour) {
                *p += g * c;
            }
        }
        px
    })
}

/// The lat-long map mirrored left to right, `L'(x, y, z) = L(-x, y, z)`: phi -> 2 pi - phi, which
/// maps column x to column `W - 1 - x` exactly: what `cmgen --no-mirror` shows, a cube written
/// for a left-handed lookup, or a panorama read from outside the sphere.
pub fn mirror_x(env: &Image) -> Image {
    let (w, h, c) = (env.width, env.height, env.channels);
    let mut out = env.clone();
    for y in 0..h {
        for x in 0..w {
            let src = w - 1 - x;
            out.data[(y * w + x) * c..(y * w + x + 1) * c]
                .copy_from_slice(&env.data[(y * w + src) * c..(y * w + src + 1) * c]);
        }
    }
    out
}

/// A square view from the origin as a 360-degree viewer shows a panorama: looking along
/// `forward` (horizontal), +Y up, 90 degrees wide and high, `size` pixels a side.
pub struct SkyCamera {
    pub forward: DVec3,
    pub size: usize,
}

impl SkyCamera {
    /// The pixel (x right, y down, pixel centres at half-integers) where direction `d` is seen,
    /// or `None` outside the frame: right = forward x up, tan(45 degrees) = 1 at the edge.
    pub fn project(&self, d: DVec3) -> Option<(f64, f64)> {
        let f = self.forward.normalize();
        let right = f.cross(DVec3::Y).normalize();
        let up = right.cross(f);
        let depth = d.dot(f);
        let (u, v) = (d.dot(right) / depth, d.dot(up) / depth);
        let half = self.size as f64 / 2.0;
        (depth > 0.0 && u.abs() < 1.0 && v.abs() < 1.0).then_some((half + half * u, half - half * v))
    }
}

/// Centroid (x, y) of the pixels where `weight` is positive.
pub fn centroid(img: &Image, weight: impl Fn(&[f32]) -> f32) -> Option<(f64, f64)> {
    let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
    for y in 0..img.height {
        for x in 0..img.width {
            let i = (y * img.width + x) * img.channels;
            let w = weight(&img.data[i..i + 3]).max(0.0) as f64;
            sx += w * (x as f64 + 0.5);
            sy += w * (y as f64 + 0.5);
            sw += w;
        }
    }
    (sw > 0.0).then(|| (sx / sw, sy / sw))
}

/// One marker in a frame: where the camera must see it and where it is (centroid of the pixels
/// of its colour above the background), each `None` when outside the frame.
pub struct Seen {
    pub name: &'static str,
    pub expected: Option<(f64, f64)>,
    pub found: Option<(f64, f64)>,
}

impl Seen {
    /// The distance in pixels from where it must be to where it is (`None` if one is missing).
    pub fn offset(&self) -> Option<f64> {
        match (self.expected, self.found) {
            (Some(e), Some(f)) => Some((e.0 - f.0).hypot(e.1 - f.1)),
            _ => None,
        }
    }
}

/// Each marker of [`orientation_map`] in `img`, a frame of `camera` in the map's units, when the
/// bake turned the map by `yaw` degrees (hdrflow's `Rotate`: content seen along d moves to
/// `R_y(yaw) d`, a positive yaw turning forward towards the left).
pub fn find_markers(img: &Image, camera: &SkyCamera, yaw: f64) -> Vec<Seen> {
    let turn = DMat3::from_rotation_y(yaw.to_radians());
    let bg = BACKGROUND * 1.5;
    markers()
        .into_iter()
        .map(|m| {
            let [r, g, b] = m.colour;
            let found = centroid(img, |p| match (r > 0.0, g > 0.0, b > 0.0) {
                (true, false, false) => p[0] - p[1].max(p[2]) - bg,
                (false, true, false) => p[1] - p[0].max(p[2]) - bg,
                (false, false, true) => p[2] - p[0].max(p[1]) - bg,
                _ => p[0].min(p[1]).min(p[2]) - bg,
            });
            Seen { name: m.name, expected: camera.project(turn * m.direction), found }
        })
        .collect()
}

/// [`find_markers`], printed one line per marker; the lines of the markers not within
/// `tolerance` pixels of where they must be (or missing, or seen where none should be).
pub fn check_markers(label: &str, img: &Image, camera: &SkyCamera, yaw: f64, tolerance: f64) -> Vec<String> {
    let mut wrong = Vec::new();
    for s in find_markers(img, camera, yaw) {
        let ok = match s.offset() {
            Some(d) => d < tolerance,
            None => s.expected.is_none() && s.found.is_none(),
        };
        let at = |p: Option<(f64, f64)>| p.map_or("nowhere".to_string(), |(x, y)| format!("({x:.1}, {y:.1})"));
        let line = format!(
            "{label}: {:<13} expected at {}, found at {}, {}",
            s.name,
            at(s.expected),
            at(s.found),
            s.offset().map_or("-".to_string(), |d| format!("{d:.2} px off"))
        );
        eprintln!("  {line}{}", if ok { "" } else { "  WRONG" });
        if !ok {
            wrong.push(line);
        }
    }
    wrong
}

/// A sky view of the marker map an engine rendered, in the map's units.
pub struct View<'a> {
    pub name: &'a str,
    pub img: Image,
    pub forward: DVec3,
    /// the yaw whose markers it must show
    pub yaw: f64,
    /// a deliberate mistake: the view must not show every marker in place
    pub mistake: bool,
}

/// The orientation check of a set of views: each shows the map's grey between the markers and
/// its markers within `tolerance` pixels of where a 360-degree viewer puts them (a mistake must
/// not), and the view named `mirrored` (a mirrored map, looking along -Z, yaw 0) swaps left and
/// right and nothing else. Panics with every marker out of place.
pub fn assert_views(views: &[View], mirrored: &str, tolerance: f64) {
    let (mut wrong, mut missed) = (Vec::new(), Vec::new());
    for v in views {
        let corner = &v.img.data[..3];
        assert!(corner.iter().all(|c| (c - BACKGROUND).abs() < 0.002), "{}: background {corner:?}", v.name);
        let camera = SkyCamera { forward: v.forward, size: v.img.width };
        let off = check_markers(v.name, &v.img, &camera, v.yaw, tolerance);
        match (v.mistake, off.is_empty()) {
            (false, false) => wrong.extend(off),
            (true, true) => missed.push(format!("{}: every marker in place", v.name)),
            _ => {}
        }
    }
    let m = views.iter().find(|v| v.name == mirrored).expect("the mirrored view");
    let seen = find_markers(&m.img, &SkyCamera { forward: DVec3::NEG_Z, size: m.img.width }, 0.0);
    let near =
        |a: &Seen, b: &Seen| a.found.zip(b.expected).is_some_and(|(f, e)| (f.0 - e.0).hypot(f.1 - e.1) < tolerance);
    assert!(near(&seen[1], &seen[2]) && near(&seen[2], &seen[1]), "the mirrored map does not just swap left and right");
    assert!(wrong.is_empty(), "the markers are not where a 360-degree viewer puts them:\n{}", wrong.join("\n"));
    assert!(missed.is_empty(), "mistakes the check did not catch:\n{}", missed.join("\n"));
}

#[test]
fn the_markers_sit_where_hdrflow_puts_their_directions() {
    // The orientation map's own check: each marker is brightest at its direction's texel.
    let img = orientation_map();
    for m in markers() {
        let (x, y) = hdrflow::geometry::latlong::texel_of_direction(m.direction.to_array(), img.width, img.height);
        let i = (y * img.width + x) * 3;
        let peak: f32 = img.data[i..i + 3].iter().sum();
        assert!(peak > 40.0, "{}: {peak} at ({x}, {y})", m.name);
    }
    // Left of centre in the image is -X: the green marker is a twelfth of the width left of
    // the centre column.
    let (gx, _) = hdrflow::geometry::latlong::texel_of_direction(markers()[1].direction.to_array(), 1024, 512);
    assert!((gx as i64 - (512 - 1024 / 12)).abs() <= 1, "{gx}");
}

#[test]
fn the_sky_camera_puts_left_on_the_left_and_up_at_the_top() {
    let look = |forward: DVec3| SkyCamera { forward, size: 256 };
    let (s, c) = 30f64.to_radians().sin_cos();
    // Looking down -Z: -X is left, +Y is up; 30 degrees is 128 tan(30) = 73.9 pixels off centre.
    let front = look(DVec3::NEG_Z);
    assert_eq!(front.project(DVec3::NEG_Z), Some((128.0, 128.0)));
    let (x, y) = front.project(DVec3::new(-s, 0.0, -c)).unwrap();
    assert!((x - (128.0 - 128.0 * s / c)).abs() < 1e-9 && (y - 128.0).abs() < 1e-9, "{x} {y}");
    let (_, y) = front.project(DVec3::new(0.0, s, -c)).unwrap();
    assert!(y < 128.0);
    assert_eq!(front.project(DVec3::Z), None);
    // Looking along +X, -Z is on the left.
    let (x, _) = look(DVec3::X).project(DVec3::new(1.0, 0.0, -0.5)).unwrap();
    assert!(x < 128.0, "{x}");
}
