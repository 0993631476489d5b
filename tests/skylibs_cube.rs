//! `SkylibsCube` against skylibs itself (`bench/peers/skylibs_cube.py`: skylibs 0.7.7's
//! `EnvironmentMap(..., 'latlong').convertTo('cube')` and back, run with the peer Python of
//! `scripts/peer-venv.sh`; skips visibly without it or without skylibs in it, fails then under
//! `HDRFLOW_REQUIRE_PEERS=1`). Both ways: the cube hdrflow writes is the one skylibs writes from
//! the same lat-long map, face for face and turn for turn, and skylibs reads hdrflow's cube back
//! into the lat-long map it came from. Two maps: one whose texel is its own direction + 2 (a
//! face in the wrong cell or turned is off by about 1 everywhere in it) and the coloured
//! markers of `tests/common/markers.rs` (forward, 30 degrees left, right and up: a mirror swaps
//! green and blue, a half turn puts white below red).

mod common;
#[path = "common/markers.rs"]
#[allow(dead_code)]
mod markers;

use std::path::{Path, PathBuf};

use common::*;
use glam::DVec3;
use hdrflow::geometry::latlong;
use hdrflow::values::{Cubemap, Image};

/// The peer Python with skylibs (`import envmap`), else `None` after a visible skip.
fn skylibs_python() -> Option<PathBuf> {
    let python = peer_python()?;
    let probe = std::process::Command::new(&python).args(["-c", "import envmap"]).output();
    if probe.is_ok_and(|o| o.status.success()) {
        return Some(python);
    }
    skip(
        "HDRFLOW_REQUIRE_PEERS",
        &format!("the peer Python {} has no skylibs (bash scripts/peer-venv.sh installs it)", python.display()),
    );
    None
}

/// `skylibs_cube.py MODE SRC SIZE OUT`, then the image it wrote.
fn skylibs(python: &Path, sb: &Sandbox, mode: &str, src: &Path, size: usize, out: &str) -> Image {
    let mut cmd = std::process::Command::new(python);
    cmd.arg(Path::new(MANIFEST_DIR).join("bench/peers/skylibs_cube.py"));
    cmd.arg(mode).arg(src).arg(size.to_string()).arg(sb.join(out));
    run_command(cmd, std::time::Duration::from_secs(300)).assert_success();
    hdrflow::formats::pfm::decode(&read_file(&sb.join(out))).expect("a PFM")
}

fn write_pfm(sb: &Sandbox, name: &str, img: &Image) -> PathBuf {
    sb.write(name, hdrflow::formats::pfm::encode(img))
}

/// hdrflow's cube map of the lat-long file `latlong` at `size`, its `SkylibsCube` and
/// `VerticalCross` images, and the cube map `LayoutToCubemap(SkylibsCube)` reads from the file
/// `theirs` (skylibs' cube).
fn hdrflow_cubes(latlong: &Path, size: usize, theirs: &Path) -> (Cubemap, Image, Image, Cubemap) {
    let text = format!(
        r#"(nodes: {{
        "env":  LoadHdr(path: {}),
        "cube": LatLongToCubemap(image: "env", size: {size}),
        "sky":  CubemapToLayout(cubemap: "cube", layout: SkylibsCube),
        "vert": CubemapToLayout(cubemap: "cube", layout: VerticalCross),
        "in":   LoadHdr(path: {}),
        "read": LayoutToCubemap(image: "in", layout: SkylibsCube),
    }})"#,
        ron_path(latlong),
        ron_path(theirs)
    );
    let v = run_text(&text, &["cube", "sky", "vert", "read"]).expect("runs");
    let cube = |n: &str| v[n].get::<Cubemap>().expect("a cube map").clone();
    let image = |n: &str| v[n].get::<Image>().expect("an image").clone();
    (cube("cube"), image("sky"), image("vert"), cube("read"))
}

fn max_diff(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max)
}

/// Where skylibs' `world2cube` puts a direction of its forward face (-Z): image (x, y) in
/// texels of a 3 S x 4 S cube, `u = 1.5 - 0.5 x / z`, `v = 1.5 + 0.5 y / z` in faces.
fn skylibs_forward_texel(d: DVec3, s: usize) -> (f64, f64) {
    assert!(-d.z > d.x.abs().max(d.y.abs()), "{d} is not on the forward face");
    ((1.5 - 0.5 * d.x / d.z) * s as f64, (1.5 + 0.5 * d.y / d.z) * s as f64)
}

/// The centroid of each marker's colour in `img` (as `markers::find_markers` weighs them).
fn marker_centroids(img: &Image) -> Vec<(&'static str, (f64, f64))> {
    let bg = markers::BACKGROUND * 1.5;
    markers::markers()
        .into_iter()
        .map(|m| {
            let [r, g, b] = m.colour;
            let found = markers::centroid(img, |p| match (r > 0.0, g > 0.0, b > 0.0) {
                (true, false, false) => p[0] - p[1].max(p[2]) - bg,
                (false, true, false) => p[1] - p[0].max(p[2]) - bg,
                (false, false, true) => p[2] - p[0].max(p[1]) - bg,
                _ => p[0].min(p[1]).min(p[2]) - bg,
            });
            (m.name, found.unwrap_or_else(|| panic!("{} not found", m.name)))
        })
        .collect()
}

fn distance(a: (f64, f64), b: (f64, f64)) -> f64 {
    (a.0 - b.0).hypot(a.1 - b.1)
}

/// The map whose texel is its direction + 2: 128 x 64, cube faces of 16 texels. hdrflow's
/// `SkylibsCube` is skylibs' cube to within the two samplings' difference (skylibs: bilinear at
/// the texel centre, clamped at the lat-long's seam; hdrflow: the texel's footprint mean): 4.8e-3
/// measured, bound 0.02. Read as a `VerticalCross`, the same image is off by 1.99. skylibs
/// reads hdrflow's cube back into the map to 4.9e-3 (bound 0.02) wherever its
/// bilinear lookup stays inside one face (it blends a face's edge texels with the empty cells
/// and the neighbouring cells of the cross, so texels within 1.5 cube texels of a face edge are
/// left out).
#[test]
fn skylibs_writes_and_reads_the_cube_hdrflow_calls_skylibs_cube() {
    let Some(python) = skylibs_python() else { return };
    let sb = Sandbox::new();
    let (w, h, s) = (128, 64, 16);
    let map =
        Image::from_fn_rgb(w, h, |x, y| (DVec3::from(latlong::texel_direction(x, y, w, h)) + 2.0).as_vec3().to_array());
    let src = write_pfm(&sb, "directions.pfm", &map);
    let theirs = skylibs(&python, &sb, "to-cube", &src, s, "skylibs_cube.pfm");
    let (cube, ours, vertical, read) = hdrflow_cubes(&src, s, &sb.join("skylibs_cube.pfm"));
    assert_eq!((ours.width, ours.height, theirs.width, theirs.height), (3 * s, 4 * s, 3 * s, 4 * s));
    let written = max_diff(&ours.data, &theirs.data);
    let read_err = max_diff(&cube.data, &read.data);
    let as_vertical = max_diff(&vertical.data, &theirs.data);
    eprintln!("written {written:.2e}, read {read_err:.2e}, read as VerticalCross {as_vertical:.2}");
    assert!(written < 0.02 && read_err < 0.02, "written {written}, read {read_err}");
    assert!(as_vertical > 1.0, "a skylibs cube is no VerticalCross: {as_vertical}");

    // skylibs reads hdrflow's file back into the lat-long map.
    let file = write_pfm(&sb, "hdrflow_cube.pfm", &ours);
    let back = skylibs(&python, &sb, "to-latlong", &file, h, "skylibs_latlong.pfm");
    assert_eq!((back.width, back.height), (w, h));
    // On its face, more than 1.5 cube texels from the face's edges: the second largest of the
    // direction's |x|, |y|, |z| over the largest below 1 - 3 / S.
    let inside = |d: DVec3| {
        let mut a = d.abs().to_array();
        a.sort_by(f64::total_cmp);
        a[1] / a[2] < 1.0 - 3.0 / s as f64
    };
    let (mut worst, mut compared) = (0.0f32, 0);
    for y in 0..h {
        for x in 0..w {
            if inside(DVec3::from(latlong::texel_direction(x, y, w, h))) {
                worst = worst.max(max_diff(&back.rgb(x, y), &map.rgb(x, y)));
                compared += 1;
            }
        }
    }
    eprintln!("skylibs reading hdrflow's cube: {worst:.2e} over {compared} of {} texels", w * h);
    assert!(worst < 0.02 && compared > w * h / 2, "{worst} over {compared}");
}

/// The marker map (1024 x 512, faces of 128 texels): each marker's centroid in hdrflow's
/// `SkylibsCube` is within 0.05 texel of skylibs' own cube's (measured 0.006) and within 0.1
/// of where skylibs' `world2cube` puts its direction (0.065: the face's perspective stretches
/// the markers 30 degrees out away from the centre, moving their centroids outwards); read
/// back by skylibs into a lat-long map, within 0.2 texel of the marker in the map (0.005).
#[test]
fn the_markers_sit_where_skylibs_puts_them() {
    let Some(python) = skylibs_python() else { return };
    let sb = Sandbox::new();
    let s = 128;
    let map = markers::orientation_map();
    let src = write_pfm(&sb, "markers.pfm", &map);
    let theirs = skylibs(&python, &sb, "to-cube", &src, s, "skylibs_cube.pfm");
    let (_, ours, _, _) = hdrflow_cubes(&src, s, &sb.join("skylibs_cube.pfm"));
    let file = write_pfm(&sb, "hdrflow_cube.pfm", &ours);
    let back = skylibs(&python, &sb, "to-latlong", &file, map.height, "skylibs_latlong.pfm");
    let (mine, skylib, original, read_back) =
        (marker_centroids(&ours), marker_centroids(&theirs), marker_centroids(&map), marker_centroids(&back));
    for (k, m) in markers::markers().iter().enumerate() {
        let want = skylibs_forward_texel(m.direction, s);
        let (a, b) = (distance(mine[k].1, skylib[k].1), distance(mine[k].1, want));
        let c = distance(read_back[k].1, original[k].1);
        eprintln!(
            "{:<13} hdrflow {:?}, skylibs {:?}: {a:.3}, world2cube {b:.3}, read back {c:.3}",
            m.name, mine[k].1, skylib[k].1
        );
        assert!(a < 0.05 && b < 0.1 && c < 0.2, "{}: {a} {b} {c}", m.name);
    }
}
