//! Bevy, rendered for real (issue 24): `hdrflow bake MAP --for bevy --sun keep` writes the two
//! cube maps Bevy's `EnvironmentMapLight` loads (rgb9e5 + Zstandard, the files a user gets), Bevy
//! 0.19.1 renders six spheres with them (clients/bevy, headless on Mesa's lavapipe), and each
//! sphere is compared with what it should be under the same map (`bevy_render/reference.rs`):
//! relative RMSE over its inner pixels (centres within 0.9 of the radius, every other row and
//! column) against Bevy's shading formula fed exact values (asserted), and against the exact GGX
//! integral (reported: the split-sum approximation).
//!
//! On a small asymmetric map (two coloured lights at known directions) the test also makes each
//! classic mistake on purpose and shows that the comparison fails: the map not mirrored in z (Bevy
//! reads cube maps at (x, y, -z): `--set cube.frame=Standard`), two faces swapped and irradiance
//! not divided by pi (edits of the correct files, `bevy_render/mistakes.rs`), a chain made with
//! Filament's roughness map (`--set spec.roughness_map=Filament`). Then two real maps of
//! assets/maps, and the orientation: a map of coloured markers shown as Bevy's `Skybox` must
//! appear as a 360-degree viewer shows it, its centre where the preset says (-Z), not mirrored,
//! up up.
//!
//! The sun's lines (`bevy_render/sun.rs`, `common/sun_lines.rs`): the park map baked with `--sun
//! extract`, its README's Rust under "The sun:" read by the client's strict reader
//! (clients/bevy/src/sun_lines.rs, whose own tests run here too) and spawned as the
//! `DirectionalLight` it describes, under the loading code's intensity and the camera's default
//! exposure, against the `--sun keep` bake and the map's exact E / pi on the diffuse sphere; no
//! sun lines, the intensity times pi and the direction negated must fail.
//!
//! Needs the client (`scripts/bevy-client.sh` builds it and prints its path; pass that path in
//! `HDRFLOW_BEVY_RENDER`, default clients/bevy/target/debug/hdrflow-bevy-render) and a Vulkan
//! driver (Debian `mesa-vulkan-drivers`); without them the tests skip visibly, and fail under
//! `HDRFLOW_REQUIRE_BEVY=1`. Run: `cargo test --release --test bevy_render -- --nocapture`
//! (prints the table of errors). With `HDRFLOW_BEVY_PICTURES=DIR` the sphere tests also write
//! each frame and its exact reference as EXR into DIR (`scripts/bevy-readme-picture.sh` makes the
//! book's pictures from them, docs/src/guides/baking/bevy.md).

#[path = "../clients/bevy/src/sun_lines.rs"]
mod client_sun_lines;
mod common;
#[path = "bevy_render/mistakes.rs"]
mod mistakes;
#[path = "bevy_render/reference.rs"]
mod reference;
#[path = "bevy_render/scene.rs"]
mod scene;
#[path = "bevy_render/sun.rs"]
mod sun;
#[path = "common/sun_lines.rs"]
mod sun_lines;
#[path = "bevy_render/test_map.rs"]
mod test_map;
#[allow(dead_code)]
#[path = "common/web_page.rs"]
mod web_page;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use hdrflow::values::Image;
use reference::{relative_rmse, sphere_reference, Map, SphereReference};
use scene::{Geometry, SkyView};
use test_map::test_map;

const REQUIRE: &str = "HDRFLOW_REQUIRE_BEVY";
const WIDTH: usize = 768;
const HEIGHT: usize = 256;
/// Relative RMSE bounds per sphere (mirror, metals 0.25, 0.5, 0.75, 1, diffuse) on the test map:
/// about twice what the correct bake measures (docs/src/benchmarks/rendered.md, "Bevy, rendered for real"). The
/// roughness-1 sphere reads the chain's 1 x 1 level (lod = r (N - 1) = N - 1: six values for the
/// whole sphere), hence its larger bound.
const TEST_MAP_BOUNDS: [f64; 6] = [0.03, 0.02, 0.02, 0.04, 0.15, 0.005];
/// The same on the park map, whose sun (69120, 0.35 degree texels; rgb9e5 keeps 65408 of it)
/// the 1024-sample prefilter and the 1 x 1 level render far less accurately.
const PARK_BOUNDS: [f64; 6] = [0.05, 0.25, 0.2, 0.17, 0.7, 0.015];
/// The same on the studio map (assets/maps/studio_small_03_1k.hdr: small bright softboxes, no sun).
const STUDIO_BOUNDS: [f64; 6] = [0.04, 0.02, 0.065, 0.12, 0.42, 0.005];
/// Lavapipe is a CPU driver on a shared machine: minutes are possible, hours are a hang.
const RENDER_TIMEOUT: Duration = Duration::from_secs(900);
/// One bake (a 256 chain of 1024 samples: half a minute on 2 busy cores).
const BAKE_TIMEOUT: Duration = Duration::from_secs(900);

/// The client binary, or `None` after a visible skip.
fn client() -> Option<PathBuf> {
    let path = std::env::var_os("HDRFLOW_BEVY_RENDER")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(common::MANIFEST_DIR).join("clients/bevy/target/debug/hdrflow-bevy-render"));
    if !path.is_file() {
        common::skip(
            REQUIRE,
            &format!("no Bevy client at {}: build it with scripts/bevy-client.sh (about 20 min) and pass its path in HDRFLOW_BEVY_RENDER", path.display()),
        );
        return None;
    }
    let icds = ["/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d"];
    if !icds.iter().any(|d| std::fs::read_dir(d).is_ok_and(|mut e| e.next().is_some())) {
        common::skip(REQUIRE, "no Vulkan driver (apt-get install mesa-vulkan-drivers for lavapipe)");
        return None;
    }
    Some(path)
}

/// The two files of a bake.
struct Bake {
    diffuse: PathBuf,
    specular: PathBuf,
}

/// `hdrflow bake MAP --for bevy --sun keep --out DIR [--set S ...] [EXTRA ...]`, the command the
/// book gives (docs/src/guides/baking/bevy.md) (the sun stays in the map: the spheres are lit by the two cube maps alone), with
/// the sandbox's cache shared by every bake of a test.
fn bake(sandbox: &common::Sandbox, map: &Path, dir: &str, sets: &[&str], extra: &[&str]) -> Bake {
    let out = sandbox.join(dir);
    let mut cmd = common::hdrflow_command(["bake".as_ref(), map.as_os_str()]);
    cmd.args(["--for", "bevy", "--sun", "keep", "-q", "--out"]).arg(&out).arg("--cache-dir").arg(sandbox.cache());
    for s in sets {
        cmd.args(["--set", s]);
    }
    cmd.args(extra);
    let run = common::run_command(cmd, BAKE_TIMEOUT);
    run.assert_success();
    eprintln!("bake {dir}: {:.1} s", run.elapsed.as_secs_f64());
    let stem = map.file_stem().expect("a file name").to_string_lossy();
    Bake {
        diffuse: out.join(format!("{stem}_diffuse_rgb9e5_zstd.ktx2")),
        specular: out.join(format!("{stem}_specular_rgb9e5_zstd.ktx2")),
    }
}

/// Runs the client on `bake` at `EnvironmentMapLight` intensity `intensity` into `{name}.exr` and
/// `{name}.json`; `extra` selects the view.
fn run_client(
    client: &Path,
    sandbox: &common::Sandbox,
    bake: &Bake,
    name: &str,
    intensity: &str,
    extra: &[&str],
) -> (Image, PathBuf) {
    let (frame, geometry) = (sandbox.join(format!("{name}.exr")), sandbox.join(format!("{name}.json")));
    let runtime = sandbox.join("xdg-runtime");
    std::fs::create_dir_all(&runtime).expect("runtime folder");
    let mut cmd = Command::new(client);
    cmd.arg("--diffuse").arg(&bake.diffuse).arg("--specular").arg(&bake.specular).arg("--intensity").arg(intensity);
    cmd.arg("--out").arg(&frame).arg("--geometry").arg(&geometry);
    cmd.args(extra);
    cmd.env("XDG_RUNTIME_DIR", &runtime);
    if std::env::var_os("WGPU_BACKEND").is_none() {
        cmd.env("WGPU_BACKEND", "vulkan");
    }
    let out = common::run_command(cmd, RENDER_TIMEOUT);
    out.assert_success();
    eprintln!("{name}: rendered in {:.1} s", out.elapsed.as_secs_f64());
    (hdrflow::formats::exr::decode(&common::read_file(&frame)).expect("the client's EXR"), geometry)
}

/// Bevy's frame of the six spheres under `bake` and the scene it declares.
fn render(client: &Path, sandbox: &common::Sandbox, bake: &Bake, name: &str) -> (Image, Geometry) {
    let size = ["--width".to_string(), WIDTH.to_string(), "--height".to_string(), HEIGHT.to_string()];
    let (image, geometry) = run_client(client, sandbox, bake, name, "1", &size.each_ref().map(String::as_str));
    let geometry = Geometry::read(&geometry);
    assert_eq!((image.width, image.height), (geometry.width, geometry.height));
    (image, geometry)
}

/// The references of every sphere.
fn references(map: &Map, geometry: &Geometry) -> Vec<SphereReference> {
    (0..geometry.spheres.len())
        .map(|k| sphere_reference(map, &geometry.spheres[k], &geometry.pixels(k, 0.9, 2)))
        .collect()
}

/// Relative RMSE per sphere against the `engine` references (printed with the exact ones).
fn errors(label: &str, frame: &Image, geometry: &Geometry, refs: &[SphereReference]) -> Vec<f64> {
    let scale = geometry.intensity * geometry.exposure;
    eprintln!("{label}: relative RMSE per sphere (vs Bevy's formula on exact lookups | vs exact GGX + (1 - E_ss) E/pi | vs single-scatter GGX)");
    let mut out = Vec::new();
    for (s, r) in geometry.spheres.iter().zip(refs) {
        let e = relative_rmse(frame, scale, &r.pixels, &r.engine);
        let x = relative_rmse(frame, scale, &r.pixels, &r.exact);
        // The Lambertian sphere has no specular term: no single-scattering comparison.
        let ss = if s.metallic == 0.0 {
            "-".to_string()
        } else {
            format!("{:.4}", relative_rmse(frame, scale, &r.pixels, &r.single))
        };
        eprintln!("  {:<11} {:>8.4} | {:>8.4} | {:>8}   ({} pixels)", s.name, e, x, ss, r.pixels.len());
        out.push(e);
    }
    out
}

/// With `HDRFLOW_BEVY_PICTURES=DIR`: the frame (divided by Bevy's scale) and the exact reference
/// at every inner pixel of every sphere (0 elsewhere in both) as `DIR/{label}_bevy.exr` and
/// `DIR/{label}_exact.exr`, RGB f32.
fn write_pictures(label: &str, map: &Map, frame: &Image, geometry: &Geometry) {
    let Some(dir) = std::env::var_os("HDRFLOW_BEVY_PICTURES").map(PathBuf::from) else { return };
    let scale = geometry.intensity * geometry.exposure;
    let (w, h) = (geometry.width, geometry.height);
    let (mut bevy, mut exact) = (Image::new(w, h, 3), Image::new(w, h, 3));
    for k in 0..geometry.spheres.len() {
        let r = sphere_reference(map, &geometry.spheres[k], &geometry.pixels(k, 0.9, 1));
        for (&p, x) in r.pixels.iter().zip(&r.exact) {
            for (c, &v) in x.iter().enumerate() {
                bevy.data[p * 3 + c] = (frame.data[p * frame.channels + c] as f64 / scale) as f32;
                exact.data[p * 3 + c] = v as f32;
            }
        }
    }
    for (name, img) in [("bevy", &bevy), ("exact", &exact)] {
        let path = dir.join(format!("{label}_{name}.exr"));
        common::write_file(&path, hdrflow::formats::exr::encode(img).expect("an EXR"));
        eprintln!("wrote {}", path.display());
    }
}

/// Writes `img` as PFM (f32, exact) for `LoadHdr`.
fn write_map(sandbox: &common::Sandbox, name: &str, img: &Image) -> PathBuf {
    sandbox.write(name, hdrflow::formats::pfm::encode(img))
}

#[test]
fn bevy_shows_the_test_map_and_each_mistake_fails() {
    let Some(client) = client() else { return };
    let sandbox = common::Sandbox::new();
    let map = test_map();
    let path = write_map(&sandbox, "test_map.pfm", &map);
    let good = bake(&sandbox, &path, "good", &[], &[]);

    let (frame, geometry) = render(&client, &sandbox, &good, "good");
    let map = Map::new(map);
    let refs = references(&map, &geometry);
    let good_errors = errors("test map", &frame, &geometry, &refs);
    let good_failing = geometry.failing(&good_errors, &TEST_MAP_BOUNDS);
    write_pictures("test_map", &map, &frame, &geometry);

    let mut missed = Vec::new();
    let mut check_mistake = |name: &str, bake: Bake, must_fail: &[&str]| {
        let (frame, geometry) = render(&client, &sandbox, &bake, name);
        let errs = errors(name, &frame, &geometry, &refs);
        missed.extend(geometry.missed(name, &errs, &TEST_MAP_BOUNDS, must_fail));
    };

    // 1. The map not mirrored in z (both cubes written for a plain lookup): everything Bevy shows
    //    is mirrored front to back.
    let plain = bake(&sandbox, &path, "plain", &["cube.frame=Standard"], &[]);
    check_mistake("mirrored map", plain, &["mirror", "metal_0.25", "metal_0.5", "diffuse"]);

    // 2. Faces +Z and -Z exchanged in both files.
    let edit = |name: &str, diffuse: Vec<u8>, specular: Vec<u8>| Bake {
        diffuse: sandbox.write(format!("{name}/diffuse.ktx2"), diffuse),
        specular: sandbox.write(format!("{name}/specular.ktx2"), specular),
    };
    let (d, s) = (common::read_file(&good.diffuse), common::read_file(&good.specular));
    check_mistake(
        "swapped faces",
        edit("swapped", mistakes::swap_faces(&d, 4, 5), mistakes::swap_faces(&s, 4, 5)),
        &["mirror", "metal_0.25", "diffuse"],
    );

    // 3. A chain whose level k has Filament's roughness (lod = r (2 - r) (N - 1)), not k / (N - 1).
    let filament = bake(&sandbox, &path, "filament", &["spec.roughness_map=Filament"], &[]);
    check_mistake("filament roughness", filament, &["metal_0.25", "metal_0.5"]);

    // 4. Irradiance E written where Bevy expects E / pi.
    check_mistake(
        "irradiance x pi",
        edit("times_pi", mistakes::scale_rgb(&d, std::f32::consts::PI), s.clone()),
        &["diffuse", "metal_1"],
    );

    assert_eq!(good_failing, Vec::<String>::new(), "the correct bake must match");
    assert!(missed.is_empty(), "mistakes the comparison did not catch:\n{}", missed.join("\n"));
}

/// Bakes `assets/maps/{file}`, renders it and asserts `bounds`.
fn real_map(file: &str, label: &str, bounds: &[f64; 6]) {
    let Some(client) = client() else { return };
    let sandbox = common::Sandbox::new();
    let path = Path::new(common::MANIFEST_DIR).join("assets/maps").join(file);
    let map = hdrflow::formats::decode_by_extension(&common::read_file(&path), "hdr").expect("the map");
    let good = bake(&sandbox, &path, label, &[], &[]);
    let (frame, geometry) = render(&client, &sandbox, &good, label);
    let map = Map::new(map);
    let refs = references(&map, &geometry);
    let errs = errors(&format!("{label} map"), &frame, &geometry, &refs);
    write_pictures(label, &map, &frame, &geometry);
    assert_eq!(geometry.failing(&errs, bounds), Vec::<String>::new(), "the {label} map's bake must match");
}

#[test]
fn bevy_shows_the_park_map() {
    real_map("rooitou_park_1k.hdr", "park", &PARK_BOUNDS);
}

#[test]
fn bevy_shows_the_studio_map() {
    real_map("studio_small_03_1k.hdr", "studio", &STUDIO_BOUNDS);
}

/// A marker of the orientation map: a disc of one colour centred `azimuth` degrees to the right
/// of the map's centre and `elevation` degrees above it, as a 360-degree viewer shows the map
/// (image left is the viewer's left, the top row is up).
struct Marker {
    name: &'static str,
    /// which of R, G, B the marker lights (the others stay at the background's level)
    on: [bool; 3],
    azimuth: f64,
    elevation: f64,
}

/// Red at the centre, green 45 degrees to its left, blue 45 degrees to its right, yellow 22.5
/// degrees above it.
const MARKERS: [Marker; 4] = [
    Marker { name: "red (centre)", on: [true, false, false], azimuth: 0.0, elevation: 0.0 },
    Marker { name: "green (left)", on: [false, true, false], azimuth: -45.0, elevation: 0.0 },
    Marker { name: "blue (right)", on: [false, false, true], azimuth: 45.0, elevation: 0.0 },
    Marker { name: "yellow (up)", on: [true, true, false], azimuth: 0.0, elevation: 22.5 },
];

/// The orientation map's size.
const MARKER_MAP: (usize, usize) = (512, 256);
/// A marker's radius in texels (4.2 degrees).
const MARKER_RADIUS: f64 = 6.0;

impl Marker {
    /// The marker's centre in the map, in texels: column `W / 2 + azimuth / 360 W`, row
    /// `H / 2 - elevation / 180 H`.
    fn texel(&self) -> (f64, f64) {
        let (w, h) = (MARKER_MAP.0 as f64, MARKER_MAP.1 as f64);
        (w / 2.0 + self.azimuth / 360.0 * w, h / 2.0 - self.elevation / 180.0 * h)
    }
}

/// The orientation map, made in image coordinates only (no direction convention): grey 0.05, and
/// each marker a disc of `MARKER_RADIUS` texels and value 4 in its channels.
fn marker_map() -> Image {
    Image::from_fn_rgb(MARKER_MAP.0, MARKER_MAP.1, |x, y| {
        let mut px = [0.05f32; 3];
        for m in &MARKERS {
            let (cx, cy) = m.texel();
            if (x as f64 + 0.5 - cx).hypot(y as f64 + 0.5 - cy) <= MARKER_RADIUS {
                (0..3).filter(|&c| m.on[c]).for_each(|c| px[c] = 4.0);
            }
        }
        px
    })
}

/// The (column, row) of the orientation map a 360-degree viewer shows at camera-space ray
/// `(x right, y up, z forward)`: azimuth `atan2(x, z)` to the right of the map's centre, elevation
/// `atan2(y, hypot(x, z))` above it.
fn viewer_texel(x: f64, y: f64, z: f64, w: f64, h: f64) -> (f64, f64) {
    let (a, e) = (x.atan2(z), y.atan2(x.hypot(z)));
    (w / 2.0 + a / std::f64::consts::TAU * w, h / 2.0 - e / std::f64::consts::PI * h)
}

/// Where each marker is in a skybox frame and where it should be, or what is wrong.
///
/// Expected: the frame a 360-degree viewer would show looking at the map's centre with the
/// camera's projection: pixel (i, j) looks along `(x_ndc t aspect, y_ndc t, 1)` in camera space
/// (t = tan(fov_y / 2)), which `viewer_texel` turns into a texel of the map; the marker's
/// expected place is the centroid of the pixels whose texel lies in its disc. Found: the centroid
/// of the pixels weighted by how much the marker's channels exceed the others (0 on the grey
/// background). The two must agree within a pixel; a mirrored or turned map puts a marker
/// 100 pixels or more away, or out of the frame.
fn orientation_problems(frame: &Image, view: &SkyView) -> Vec<String> {
    let (fw, fh) = (frame.width, frame.height);
    let t = (view.fov_y_degrees.to_radians() / 2.0).tan();
    let aspect = fw as f64 / fh as f64;
    let (mw, mh) = (MARKER_MAP.0 as f64, MARKER_MAP.1 as f64);
    let mut out = Vec::new();
    for m in &MARKERS {
        let (cx, cy) = m.texel();
        let (mut ew, mut ex, mut ey) = (0.0, 0.0, 0.0);
        let (mut sw, mut sx, mut sy) = (0.0, 0.0, 0.0);
        for j in 0..fh {
            for i in 0..fw {
                let (pi, pj) = (i as f64 + 0.5, j as f64 + 0.5);
                let (xn, yn) = (2.0 * pi / fw as f64 - 1.0, 1.0 - 2.0 * pj / fh as f64);
                let (u, v) = viewer_texel(xn * t * aspect, yn * t, 1.0, mw, mh);
                if (u - cx).hypot(v - cy) <= MARKER_RADIUS {
                    ew += 1.0;
                    ex += pi;
                    ey += pj;
                }
                let p = &frame.data[(j * fw + i) * frame.channels..][..3];
                let on = (0..3).filter(|&c| m.on[c]).map(|c| p[c]).fold(f32::INFINITY, f32::min);
                let off = (0..3).filter(|&c| !m.on[c]).map(|c| p[c]).fold(0.0, f32::max);
                let weight = (on - off - 0.05).max(0.0) as f64;
                sw += weight;
                sx += weight * pi;
                sy += weight * pj;
            }
        }
        assert!(ew > 0.0, "{}: the marker is outside the view", m.name);
        let want = (ex / ew, ey / ew);
        if sw < 10.0 {
            out.push(format!(
                "{}: not in the frame (weight {sw:.2}), expected at ({:.1}, {:.1})",
                m.name, want.0, want.1
            ));
            continue;
        }
        let got = (sx / sw, sy / sw);
        let off = (got.0 - want.0).hypot(got.1 - want.1);
        eprintln!(
            "  {:<13} at ({:6.1}, {:6.1}), expected ({:6.1}, {:6.1}): {off:.2} px",
            m.name, got.0, got.1, want.0, want.1
        );
        if off > 1.0 {
            out.push(format!(
                "{}: at ({:.1}, {:.1}), expected at ({:.1}, {:.1})",
                m.name, got.0, got.1, want.0, want.1
            ));
        }
    }
    out
}

/// Renders `bake` as Bevy's `Skybox` looking along `forward` (512 x 256, 90 degrees high) and
/// checks the markers.
fn skybox_problems(client: &Path, sandbox: &common::Sandbox, bake: &Bake, name: &str, forward: &str) -> Vec<String> {
    let args = ["--skybox", forward, "--width", "512", "--height", "256"];
    let (frame, geometry) = run_client(client, sandbox, bake, name, "1", &args);
    let view = SkyView::read(&geometry);
    assert_eq!((frame.width, frame.height), (view.width, view.height));
    let stated: Vec<f64> = forward.split(',').map(|c| c.parse().expect("a number")).collect();
    let stated = glam::DVec3::new(stated[0], stated[1], stated[2]).normalize();
    assert!((view.forward - stated).length() < 1e-6, "{name}: the client looked along {}", view.forward);
    eprintln!("{name}: skybox looking along {forward}");
    orientation_problems(&frame, &view)
}

#[test]
fn bevy_shows_the_map_unmirrored_up_and_its_centre_forward() {
    let Some(client) = client() else { return };
    let sandbox = common::Sandbox::new();
    let path = write_map(&sandbox, "markers.pfm", &marker_map());
    // The orientation does not depend on the chain's size: the draft quality (a 128 chain).
    let draft = ["--quality", "draft"];

    // The preset: the map's centre faces -Z of Bevy's world (docs/src/guides/baking/index.md).
    let good = bake(&sandbox, &path, "good", &[], &draft);
    let forward = skybox_problems(&client, &sandbox, &good, "sky_forward", "0,0,-1");
    // --yaw -90 puts it at +X, where glTF-IBL-Sampler's Bevy assets have it (the tools' table).
    let turned = bake(&sandbox, &path, "turned", &[], &["--quality", "draft", "--yaw", "-90"]);
    let yaw = skybox_problems(&client, &sandbox, &turned, "sky_yaw", "1,0,0");
    // Not mirrored in z: the check must see it (the markers are behind the camera, mirrored).
    let plain = bake(&sandbox, &path, "plain", &["cube.frame=Standard"], &draft);
    let mistake = skybox_problems(&client, &sandbox, &plain, "sky_unmirrored", "0,0,-1");
    // Looking back at its centre there: up is up, but left and right are swapped (a reflection).
    let back = skybox_problems(&client, &sandbox, &plain, "sky_unmirrored_back", "0,0,1");

    assert!(forward.is_empty(), "looking along -Z:\n{}", forward.join("\n"));
    assert!(yaw.is_empty(), "--yaw -90, looking along +X:\n{}", yaw.join("\n"));
    assert!(!mistake.is_empty(), "a bake not mirrored in z passed the orientation check");
    eprintln!("not mirrored in z, as the check must see:\n  {}", mistake.join("\n  "));
    let named = |what: &str| back.iter().any(|p| p.starts_with(what));
    assert!(
        named("green") && named("blue") && !named("red") && !named("yellow"),
        "not mirrored, seen from behind: left and right must be swapped, the centre and up kept:\n{}",
        back.join("\n")
    );
}
