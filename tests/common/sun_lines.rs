//! The sun a user cannot lose (issue 36), rendered by each engine: `hdrflow bake --sun
//! extract` moves the park map's sun (about two thirds of its light) out of the lighting files,
//! and the bake's README.txt ends with the engine code that adds it back as a directional light.
//! The engine's render page loads the extracted bake and runs those lines, read from the README
//! the bake wrote (`clients/web-common/page.js`, `runSunLines`; Bevy's client reads its Rust with
//! a strict reader, clients/bevy/src/sun_lines.rs); its diffuse sphere must match the
//! same page's render of the `--sun keep` bake, whose sun is still in the map, and three deliberate
//! mistakes must not: no sun lines, the intensity pi times too large, the direction negated (each
//! a README with its sun lines edited). Included by `#[path]` beside `common`, `web_page` and
//! `scene` (Bevy's geometry).

use std::path::{Path, PathBuf};

use hdrflow::ibl_presets::notes::fill_sun;
use hdrflow::values::{Image, Light};
use serde_json::Value as Json;

use crate::scene::Geometry;
use crate::{common, web_page};

/// The park map, area-resized to 512 x 256 (its sun still one to two texels, within SunExtract's
/// default rule): a draft bake of it takes about a second.
pub const PARK_SIZE: (usize, usize) = (512, 256);

/// The bakes' `--yaw`: the park's sun, 36 degrees right of the map's centre and 10.5 degrees up,
/// turned to 44 degrees right of +Z, towards the pages' cameras (on +Z looking down -Z), so that
/// the sun lights most of the diffuse sphere's visible side (unturned it lights a sliver at its
/// edge, and leaving out the sun lines changed the sphere by only 0.13).
pub const SUN_YAW: &str = "-100";

/// The bakes of one engine's sun test: the sun kept in the map, the sun extracted, and the
/// README each render runs the sun lines of (`None`: no sun lines).
pub struct SunBakes {
    /// `hdrflow bake PARK --for ENGINE --sun keep --quality draft`: the folder.
    pub keep: PathBuf,
    /// The same with `--sun extract`: the folder.
    pub extract: PathBuf,
    /// The renders of the extracted bake: the README's own lines ("sun"), then the mistakes
    /// ("no_sun", "times_pi", "negated").
    pub renders: Vec<(&'static str, Option<PathBuf>)>,
}

impl SunBakes {
    /// Every render of a sun test: `("keep", the keep bake, no sun lines)`, then each of
    /// [`SunBakes::renders`] on the extracted bake.
    #[allow(dead_code)] // three's page has its own scenes
    pub fn all_renders(&self) -> impl Iterator<Item = (&'static str, &Path, Option<&Path>)> {
        std::iter::once(("keep", self.keep.as_path(), None))
            .chain(self.renders.iter().map(|(name, readme)| (*name, self.extract.as_path(), readme.as_deref())))
    }
}

/// The park map at [`PARK_SIZE`] as a Radiance `.hdr` in the sandbox (`park.hdr`).
pub fn park_map(sandbox: &common::Sandbox) -> PathBuf {
    let path = Path::new(common::MANIFEST_DIR).join("assets/maps/rooitou_park_1k.hdr");
    let park = hdrflow::formats::decode_by_extension(&common::read_file(&path), "hdr").expect("the park map");
    let park = hdrflow::maths::resample::area_resize::resize(&park, PARK_SIZE.0, PARK_SIZE.1);
    sandbox.write("park.hdr", hdrflow::formats::rgbe::encode(&park))
}

/// The park map baked for `engine` with the sun kept and extracted (draft quality, [`SUN_YAW`], folders
/// `keep/` and `extract/`), and the mistakes' READMEs (`mistakes/NAME/README.txt`).
pub fn bake_park(sandbox: &common::Sandbox, engine: &str) -> SunBakes {
    let map = park_map(sandbox);
    let extra = ["--quality", "draft", "--yaw", SUN_YAW];
    let keep = web_page::bake_with_sun(sandbox, &map, engine, "keep", "keep", &extra);
    let extract = web_page::bake_with_sun(sandbox, &map, engine, "extract", "extract", &extra);
    let readme = extract.join("README.txt");
    let text = std::fs::read_to_string(&readme).expect("the bake's README.txt");
    let at = text.find("\nThe sun:\n").unwrap_or_else(|| panic!("no sun lines in {}:\n{text}", readme.display()));
    let (head, lines) = text.split_at(at);
    let sun = read_sun(&extract.join("park_sun.json"));
    let fill = |key: &str| fill_sun(&format!("{{sun:{key}}}"), &sun);
    // The intensity as the README gives it: the illuminance (a light of unit luminance colour)
    // or the largest channel (KHR_lights_punctual's colour in [0, 1]); both times pi.
    let times_pi = |key: &str| {
        let value = fill(key);
        let brighter = format!("{:.6}", value.parse::<f64>().expect("a number") * std::f64::consts::PI);
        (value, brighter)
    };
    let ((illuminance, brighter), (peak, brighter_peak)) = (times_pi("illuminance"), times_pi("peak"));
    // The direction as the README gives it, towards the light or from it: swapped, it is negated.
    let (to, from) = (fill("to_light"), fill("from_light"));
    let negated = if lines.contains(&to) { lines.replace(&to, &from) } else { lines.replace(&from, &to) };
    let write = |name: &str, lines: String| {
        assert_ne!(lines, text[at..], "{name}: the edit changed nothing in the sun lines:\n{lines}");
        Some(sandbox.write(format!("mistakes/{name}/README.txt"), format!("{head}{lines}")))
    };
    let renders = vec![
        ("sun", Some(readme.clone())),
        ("no_sun", None),
        ("times_pi", write("times_pi", lines.replace(&illuminance, &brighter).replace(&peak, &brighter_peak))),
        ("negated", write("negated", negated)),
    ];
    SunBakes { keep, extract, renders }
}

/// The extracted sun, from the bake's `{name}_sun.json`.
fn read_sun(path: &Path) -> Light {
    let json: Json = serde_json::from_slice(&common::read_file(path)).expect("the sun's JSON");
    let triple = |key: &str| -> [f64; 3] {
        let v: Vec<f64> = json[key].as_array().expect("an array").iter().filter_map(Json::as_f64).collect();
        [v[0], v[1], v[2]]
    };
    let solid_angle = json["solid_angle"].as_f64().expect("solid_angle");
    assert!(solid_angle > 0.0, "no sun extracted from the park map: {json}");
    Light { direction: triple("direction"), solid_angle, radiance: triple("radiance") }
}

/// What a white Lambertian sphere shows at each of `pixels` (index, world normal): E / pi of the
/// park map as the bakes read it (`park.hdr`, turned by [`SUN_YAW`]), its exact irradiance (the
/// sum over its texels). The engines' diffuse spheres against it: how much of the difference
/// between the two bakes is the engine's approximation of a sun held in the map.
pub fn exact_diffuse(sandbox: &common::Sandbox, pixels: &[(usize, glam::DVec3)]) -> Vec<[f64; 3]> {
    use hdrflow::geometry::rotation::Rotation;
    let map =
        hdrflow::formats::decode_by_extension(&common::read_file(&sandbox.join("park.hdr")), "hdr").expect("RGBE");
    let yaw: f64 = SUN_YAW.parse().expect("a number");
    let map = hdrflow::maths::resample::rotation::rotate_latlong(&map, Rotation::from_yaw_pitch_roll(yaw, 0.0, 0.0));
    let normals: Vec<[f64; 3]> = pixels.iter().map(|p| p.1.to_array()).collect();
    let e = hdrflow::maths::render::reference::irradiance_exact(&map, &normals);
    e.iter().map(|e| e.map(|c| c / std::f64::consts::PI)).collect()
}

/// `frame` against `reference` values at `pixels` (relative RMSE).
pub fn against(frame: &Image, pixels: &[usize], reference: &[[f64; 3]]) -> f64 {
    crate::reference::relative_rmse(frame, 1.0, pixels, reference)
}

/// `frame`'s pixels against `reference`'s (the keep bake's render) as relative RMSE over `pixels`.
pub fn difference(frame: &Image, reference: &Image, pixels: &[usize]) -> f64 {
    let c = reference.channels;
    let values: Vec<[f64; 3]> = pixels.iter().map(|&p| [0, 1, 2].map(|k| reference.data[p * c + k] as f64)).collect();
    against(frame, pixels, &values)
}

/// A reported sphere of [`assert_sun`]: its name, and its difference from the keep bake's render
/// by render name.
pub type Rough<'a> = (&'a str, &'a dyn Fn(&str) -> f64);

/// The bounds of an engine's sun test, relative RMSE on the diffuse sphere: `keep`, against the
/// same engine's render of the `--sun keep` bake (whose own approximation of a sun held in the map
/// is most of what is measured: `exact` for `keep` in the table), and `exact`, against the map's
/// exact E / pi. The README's own lines must be within both, each mistake beyond both.
pub struct SunBound {
    pub keep: f64,
    pub exact: f64,
}

/// Prints the table of `label` (per render of [`SunBakes::renders`], the diffuse sphere against
/// the keep bake's render (`diffuse(name)`) and against exact E / pi (`exact(name)`, with "keep"
/// the keep bake's own), and, when given, a rough sphere's against the keep bake's, reported only)
/// and, given a `bound`, asserts it ([`SunBound`]).
pub fn assert_sun(
    label: &str,
    bakes: &SunBakes,
    bound: Option<SunBound>,
    diffuse: impl Fn(&str) -> f64,
    exact: impl Fn(&str) -> f64,
    rough: Option<Rough>,
) {
    eprintln!("{label}: the extracted bake with the README's sun lines against the --sun keep bake, relative RMSE:");
    let rough_head = rough.map(|(n, _)| format!(" {n} vs keep (reported) |")).unwrap_or_default();
    eprintln!("| render | diffuse vs keep | diffuse vs exact E / pi |{rough_head}");
    eprintln!("| keep | 0 | {:.4} |{}", exact("keep"), rough.map(|_| " 0 |").unwrap_or_default());
    let mut problems = Vec::new();
    for (name, _) in &bakes.renders {
        let (d, x) = (diffuse(name), exact(name));
        let r = rough.map(|(_, f)| format!(" {:.4} |", f(name))).unwrap_or_default();
        eprintln!("| {name} | {d:.4} | {x:.4} |{r}");
        let (good, Some(bound)) = (*name == "sun", &bound) else { continue };
        if good && (d > bound.keep || x > bound.exact) {
            problems.push(format!(
                "{name}: the README's sun lines leave the diffuse sphere {d:.4} off the keep bake's (bound {}), \
                 {x:.4} off exact (bound {})",
                bound.keep, bound.exact
            ));
        }
        if !good && (d <= bound.keep || x <= bound.exact) {
            problems.push(format!("{name}: the mistake passes ({d:.4} vs keep, {x:.4} vs exact)"));
        }
    }
    assert!(problems.is_empty(), "{label}:\n{}", problems.join("\n"));
}

/// A render's sun lines as the page ran them (`sun` in its report), checked to be the README's.
pub fn assert_ran(report: &Json, name: &str, wanted: bool) {
    let ran = report["sun"].as_str();
    assert_eq!(
        ran.is_some(),
        wanted,
        "{name}: the sun lines {} run: {report}",
        if wanted { "were not" } else { "were" }
    );
}

/// The renders of a page of the six-sphere scene (clients/web-common/scene.js): "keep" (the keep
/// bake) and each of [`SunBakes::renders`] (the extracted bake with its README's sun lines or a
/// mistake's), as `entry(name, bake folder)` gives a render of that page, plus `"sun"`.
#[allow(dead_code)] // three's page has its own scenes
pub fn scene_renders(sandbox: &common::Sandbox, bakes: &SunBakes, entry: impl Fn(&str, &Path) -> Json) -> Vec<Json> {
    bakes
        .all_renders()
        .map(|(name, dir, readme)| {
            // The pages read a null "sun" as none.
            let mut e = entry(name, dir);
            e["sun"] = readme.map(|p| web_page::rel(sandbox, p)).into();
            e
        })
        .collect()
}

/// [`assert_sun`] on a page of [`scene_renders`]: the diffuse sphere asserted within `bound`, the
/// metal of roughness 0.5 reported.
#[allow(dead_code)] // three's page has its own scenes
pub fn assert_scene_sun(
    label: &str,
    sandbox: &common::Sandbox,
    page: &web_page::Page,
    bakes: &SunBakes,
    bound: SunBound,
) {
    let g = Geometry::read(&page.results.join("scene.json"));
    for (name, readme) in &bakes.renders {
        assert_ran(page.render_report(name), name, readme.is_some());
    }
    assert_frames_sun(label, sandbox, &g, bakes, |name| page.frame(name, g.width, g.height), bound);
}

/// [`assert_sun`] on the six-sphere scene `g` (clients/web-common/scene.js, clients/bevy's
/// `scene.rs`), `frame(name)` the render `name` of [`scene_renders`]' (or Bevy's) in the map's units:
/// the diffuse sphere asserted within `bound`, the metal of roughness 0.5 reported.
#[allow(dead_code)] // three's page has its own scenes
pub fn assert_frames_sun(
    label: &str,
    sandbox: &common::Sandbox,
    g: &Geometry,
    bakes: &SunBakes,
    frame: impl Fn(&str) -> Image,
    bound: SunBound,
) {
    let inner = |name: &str| -> Vec<usize> {
        let k = g.spheres.iter().position(|s| s.name == name).unwrap_or_else(|| panic!("no sphere {name}"));
        g.pixels(k, 0.9, 2).iter().map(|p| p.0).collect()
    };
    let (diffuse, metal) = (inner("diffuse"), inner("metal_0.5"));
    let k = g.spheres.iter().position(|s| s.name == "diffuse").expect("a diffuse sphere");
    let exact = exact_diffuse(sandbox, &g.pixels(k, 0.9, 2));
    let keep = frame("keep");
    let metal_difference = |name: &str| difference(&frame(name), &keep, &metal);
    let diffuse_difference = |name: &str| difference(&frame(name), &keep, &diffuse);
    let exact_difference = |name: &str| against(&frame(name), &diffuse, &exact);
    assert_sun(label, bakes, Some(bound), diffuse_difference, exact_difference, Some(("metal_0.5", &metal_difference)));
}
