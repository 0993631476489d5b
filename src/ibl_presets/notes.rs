//! A bake's notes, `README.txt` in its folder: what was baked (its first line, `hdrflow bake MAP
//! --for ENGINE (...)`, also marks the folder as that engine's bake), the preset's conventions, the
//! files, and the engine code that loads them (the preset's `loading_code`) and, for an extracted
//! sun, adds it as the engine's light (`sun_code`, the sun's numbers in the engine's terms).
//!
//! One folder holds one engine's bake: [`Preset::check_out`] refuses a folder whose notes name
//! another engine (the files would mix and the notes of one would replace the other's), or whose
//! `README.txt` no bake wrote; and whatever the preset's `check_assets` refuses (for `--for
//! gltf`, a folder holding another glTF asset).

use std::path::Path;

use super::bake::{save_path, Bake, BakeOptions, Sun};
use super::Preset;
use crate::engine::graph::Pipeline;
use crate::engine::params::ParamValue;
use crate::maths::fit::sun_rule::SunRule;
use crate::values::{Light, Metrics};

/// The notes' file name, in the bake's folder.
pub const NOTES_FILE: &str = "README.txt";

/// The engine whose bake `notes` (a `README.txt`) describes, from its first line, or `None` when
/// no bake wrote it.
pub fn engine_of_notes(notes: &str) -> Option<&str> {
    let first = notes.lines().next()?.strip_prefix("hdrflow bake ")?;
    // The last " --for ": MAP comes before it and may hold anything.
    let (_, after) = first.rsplit_once(" --for ")?;
    after.split(" (").next().filter(|e| !e.is_empty())
}

impl Preset {
    /// Whether this engine's bake of the map named `map` (`bake::map_name`) may write into
    /// `dir`: a missing folder, an empty one, or one holding no `README.txt` or this engine's
    /// may; a file, another engine's bake or a `README.txt` no bake wrote is refused, and for
    /// glTF another asset (the preset's `check_assets`) (the message without `error: `).
    pub fn check_out(&self, dir: &Path, map: &str) -> Result<(), String> {
        let default = self.default_out();
        if dir.exists() && !dir.is_dir() {
            return Err(format!("--out {}: is a file; --out names the folder the bake writes into", dir.display()));
        }
        let notes = dir.join(NOTES_FILE);
        let text = std::fs::read_to_string(&notes).ok();
        if let Some(check_assets) = self.check_assets {
            let ours = text.as_deref().and_then(engine_of_notes).is_some_and(|e| e.eq_ignore_ascii_case(self.name));
            check_assets(dir, map, ours)?;
        }
        let Some(text) = text else { return Ok(()) };
        match engine_of_notes(&text) {
            Some(e) if e.eq_ignore_ascii_case(self.name) => Ok(()),
            Some(e) => Err(format!(
                "{} holds a bake for {e} (its {NOTES_FILE}); a bake for {} there would mix the two engines' files \
                 and replace its notes: write it elsewhere with --out (the default, {}, keeps each engine apart) \
                 or empty the folder first",
                dir.display(),
                self.name,
                default.display()
            )),
            None => Err(format!(
                "{} holds a {NOTES_FILE} that hdrflow bake did not write, which the bake's notes would replace: \
                 write it elsewhere with --out (the default is {}) or move that file",
                dir.display(),
                default.display()
            )),
        }
    }
}

/// `text` with every `{file:NODE}` replaced by the path NODE writes.
pub(super) fn fill_files(text: &str, p: &Pipeline) -> String {
    let mut out = String::new();
    let mut rest = text;
    while let Some(start) = rest.find("{file:") {
        out.push_str(&rest[..start]);
        let after = &rest[start + 6..];
        let end = after.find('}').unwrap_or(after.len());
        out.push_str(&save_path(p, &after[..end]).unwrap_or_else(|| after[..end].to_string()));
        rest = after.get(end + 1..).unwrap_or("");
    }
    out.push_str(rest);
    out
}

fn triple(v: [f64; 3]) -> String {
    format!("{:.6}, {:.6}, {:.6}", v[0], v[1], v[2])
}

/// The sun's numbers in `sun_code`, from the irradiance `E = radiance * solid_angle` it gives a
/// surface facing it (per channel, in the map's units):
/// - `{sun:illuminance}`: the Rec. 709 luminance of E, and `{sun:color}`: E divided by it
///   (linear Rec. 709, luminance 1, a channel may exceed 1);
/// - `{sun:peak}`: E's largest channel, and `{sun:unit_color}`: E divided by it (each channel
///   in [0, 1], as glTF's `KHR_lights_punctual` requires; `unit_color * peak = E`);
/// - `{sun:to_light}`, `{sun:from_light}` and `{sun:radius_deg}` (the cone of its solid angle).
pub fn fill_sun(text: &str, sun: &Light) -> String {
    let e = sun.power();
    let y: f64 = e.iter().zip(crate::colour::REC709).map(|(a, b)| a * b).sum();
    let colour = if y > 0.0 { e.map(|v| v / y) } else { [1.0; 3] };
    let peak = e.iter().copied().fold(0.0, f64::max);
    let unit = if peak > 0.0 { e.map(|v| v / peak) } else { [1.0; 3] };
    let d = sun.direction;
    let radius = crate::maths::fit::sun_rule::cone_radius_deg(sun.solid_angle);
    text.replace("{sun:illuminance}", &format!("{y:.6}"))
        .replace("{sun:color}", &triple(colour))
        .replace("{sun:peak}", &format!("{peak:.6}"))
        .replace("{sun:unit_color}", &triple(unit))
        .replace("{sun:to_light}", &triple(d))
        .replace("{sun:from_light}", &triple(d.map(|v| -v)))
        .replace("{sun:radius_deg}", &format!("{radius:.4}"))
}

/// What the bake did with the sun, in one paragraph: the notes lead with it and `hdrflow bake`
/// prints it every time, because a scene that loads only the lighting files loses the light a
/// `--sun extract` moved out (the park map's sun is two thirds of its light). `sun`: the
/// extracted light (`None` for `Sun::Keep`); `metrics`: `SunExtract`'s.
pub fn sun_statement(bake: &Bake, options: &BakeOptions, sun: Option<&Light>, metrics: Option<&Metrics>) -> String {
    let metric = |name: &str| metrics.and_then(|m| m.get(name)).unwrap_or(0.0);
    // The rule's bounds as the bake ran them (`--set sun.max_radius_deg=...` included).
    let p = &bake.pipeline;
    let bound = |field: &str, default: f64| match p.index_of("sun").and_then(|i| p.nodes[i].params.values.get(field)) {
        Some(ParamValue::Float(v)) => *v,
        _ => default,
    };
    let file = save_path(p, "save_sun").unwrap_or_else(|| "the sun's JSON file".into());
    match (options.sun, sun) {
        (Sun::Keep, _) => "Sun: kept in the map (--sun keep): these files hold all of its light.".into(),
        (Sun::Extract, Some(s)) if s.solid_angle > 0.0 => format!(
            "Sun: {:.0}% OF THE MAP'S LIGHT IS NOT IN THESE LIGHTING FILES. SunExtract moved the sun ({:.2} degrees \
             across) into {file}, as a directional light: a scene that loads only the lighting files is that much \
             darker than the map. Add the light with the lines under \"The sun\" at the end of this file, or bake \
             with --sun keep to leave it in the map.",
            100.0 * metric("share"),
            2.0 * metric("radius_deg"),
        ),
        (Sun::Extract, _) if metric("region_share") > 0.0 => format!(
            "Sun: none taken out: the brightest region ({:.2} degrees across, {:.1}% of the light) is not a sun by \
             SunExtract's rule (at most {} degrees across, at least {:.0}% of the light), so these files hold all of \
             the map's light and there is no light to add.",
            2.0 * metric("region_radius_deg"),
            100.0 * metric("region_share"),
            2.0 * bound("max_radius_deg", SunRule::DEFAULT.max_radius_deg),
            100.0 * bound("min_share", SunRule::DEFAULT.min_share),
        ),
        (Sun::Extract, _) => "Sun: none found (nothing exceeds SunExtract's threshold): these files hold all of the \
                              map's light."
            .into(),
    }
}

/// `README.txt`: what was baked, what became of the sun ([`sun_statement`]), the files
/// (`written`, relative to the folder), and the engine code that loads them; `sun`: the extracted
/// light (`None` for `Sun::Keep`), `metrics` SunExtract's.
pub fn notes(
    bake: &Bake,
    options: &BakeOptions,
    written: &[String],
    sun: Option<&Light>,
    metrics: Option<&Metrics>,
) -> String {
    let (preset, p) = (bake.preset, &bake.pipeline);
    let mut out = format!(
        "hdrflow bake {} --for {} (quality {:?}, yaw {}, sun {:?}{})\n\n{}\n\n{}\n\nConventions: {}; {}; irradiance: {}.\n\nFiles:\n",
        options.map,
        preset.name,
        options.quality,
        options.yaw,
        options.sun,
        if options.sanitize { ", sanitized" } else { "" },
        sun_statement(bake, options, sun, metrics),
        preset.loads,
        preset.world,
        preset.lod,
        preset.irradiance
    );
    for f in written {
        out.push_str(&format!("  {f}\n"));
    }
    out.push('\n');
    out.push_str(&fill_files(preset.loading_code, p));
    if let Some(s) = sun.filter(|s| s.solid_angle > 0.0) {
        out.push_str("\nThe sun:\n");
        out.push_str(&fill_sun(&fill_files(preset.sun_code, p), s));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ibl_presets::bake::QualityLevel;
    use crate::ibl_presets::PRESETS;

    #[test]
    fn sun_numbers_are_the_irradiance_it_gives() {
        let sun = Light { direction: [0.0, 0.6, -0.8], solid_angle: 6e-5, radiance: [5e4, 4e4, 3e4] };
        let text = fill_sun(
            "{sun:illuminance}|{sun:color}|{sun:from_light}|{sun:radius_deg}|{sun:peak}|{sun:unit_color}",
            &sun,
        );
        let parts: Vec<&str> = text.split('|').collect();
        let y = 6e-5 * (0.2126 * 5e4 + 0.7152 * 4e4 + 0.0722 * 3e4);
        assert_eq!(parts[0], format!("{y:.6}"));
        assert!(parts[1].starts_with(&format!("{:.6}", 3.0 / y)), "{}", parts[1]);
        assert_eq!(parts[2], "-0.000000, -0.600000, 0.800000");
        let r: f64 = parts[3].parse().unwrap();
        assert!((r - 0.2502).abs() < 1e-3, "{r}");
        // KHR_lights_punctual: colour in [0, 1], the magnitude in the intensity.
        assert_eq!(parts[4], "3.000000");
        assert_eq!(parts[5], "1.000000, 0.800000, 0.600000");
    }

    /// The notes' first line names their engine, read back whatever MAP is.
    #[test]
    fn the_notes_first_line_names_the_engine() {
        let registry = crate::ops::builtin_registry();
        for preset in PRESETS {
            for map in ["builtin:sky", "maps/a --for b (c).hdr"] {
                let options = BakeOptions {
                    map: map.into(),
                    quality: QualityLevel::Draft,
                    yaw: 0.0,
                    sun: Sun::Keep,
                    sanitize: false,
                    user: vec![],
                };
                // The pipeline is the sky's (the odd MAP is no file); the notes name the odd MAP.
                let sized = BakeOptions { map: "builtin:sky".into(), ..options.clone() };
                let bake = preset.bake(&registry, &sized).expect("validates");
                let text = notes(&bake, &options, &[], None, None);
                assert_eq!(engine_of_notes(&text), Some(preset.name), "{text}");
            }
        }
        assert_eq!(engine_of_notes("My project\n"), None);
        assert_eq!(engine_of_notes(""), None);
    }
}
