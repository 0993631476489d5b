//! `Save(input, path, exposure: 0.0, plot_size: (800, 500))`: encode a value as a file in the
//! output folder. The format follows the extension and the value's type:
//!
//! | value                 | extensions                         |
//! |-----------------------|------------------------------------|
//! | image, scalar field   | `.png` (exposure, sRGB, clamped), `.exr`, `.hdr`, `.pfm` |
//! | distribution          | the same, of its solid-angle pdf per texel |
//! | sample set            | `.csv` (`index,x,y,theta,phi,dx,dy,dz,pdf`), `.json` |
//! | curves                | `.json`, `.csv`, `.png`, `.svg` (a plot) |
//! | metrics               | `.json`, `.csv` |
//!
//! The operator only encodes: the engine writes the bytes atomically into `--out`, and refuses
//! paths that are absolute or leave that folder. Encoding is cached like any result.

use std::fmt::Write as _;

use crate::data::{Curves, Distribution2D, Image, Metrics, SampleSet};
use crate::engine::op::{
    CheckContext, CheckProblem, Default, FieldKind, FieldSpec, OpContext, OpError, OpSpec, OutputType,
};
use crate::engine::scheduler::check_output_path;
use crate::engine::value::{FileBlob, Value, ValueType};
use crate::formats;

pub static SPEC: OpSpec = OpSpec {
    name: "Save",
    category: "io",
    version: 1,
    doc: "Write a value to a file in the output folder; the format follows the extension",
    fields: &[
        FieldSpec::input(
            "input",
            &[
                ValueType::Image,
                ValueType::ScalarField,
                ValueType::Distribution,
                ValueType::Samples,
                ValueType::Curves,
                ValueType::Metrics,
            ],
            "the value to write",
        ),
        FieldSpec {
            name: "path",
            kind: FieldKind::Text,
            default: Default::Required,
            doc: "file name relative to the output folder (--out); no `..`, not absolute",
        },
        FieldSpec {
            name: "exposure",
            kind: FieldKind::Float { min: -64.0, max: 64.0 },
            default: Default::Float(0.0),
            doc: "exposure in stops applied before the sRGB transfer (.png only)",
        },
        FieldSpec {
            name: "auto_exposure",
            kind: FieldKind::Bool,
            default: Default::Bool(false),
            doc: "(.png) first scale so the 99.5th percentile of lit pixels' max channel maps to 1",
        },
        FieldSpec {
            name: "plot_size",
            kind: FieldKind::Tuple { len: 2, min: 64.0, max: 8192.0 },
            default: Default::Tuple(&[800.0, 500.0]),
            doc: "width and height in pixels of a curve plot (.png, .svg)",
        },
    ],
    output: OutputType::Fixed(ValueType::File),
    eval,
    content_key: None,
    check: Some(check),
};

fn extension(path: &str) -> String {
    std::path::Path::new(path).extension().map(|e| e.to_string_lossy().to_lowercase()).unwrap_or_default()
}

/// Extensions accepted for each input type.
fn formats_for(t: ValueType) -> &'static [&'static str] {
    match t {
        ValueType::Image | ValueType::ScalarField | ValueType::Distribution => &["png", "exr", "hdr", "pfm"],
        ValueType::Samples => &["csv", "json"],
        ValueType::Curves => &["json", "csv", "png", "svg"],
        ValueType::Metrics => &["json", "csv"],
        ValueType::File => &[],
    }
}

fn check(ctx: &CheckContext) -> Result<(), CheckProblem> {
    let path = ctx.params.text("path");
    check_output_path(path).map_err(|message| CheckProblem { field: Some("path"), message })?;
    let t = ctx.input_types["input"];
    let ext = extension(path);
    let ok = formats_for(t);
    if !ok.contains(&ext.as_str()) {
        return Err(CheckProblem {
            field: Some("path"),
            message: format!(
                "cannot save a {t} as {:?}: use one of {}",
                if ext.is_empty() { "(no extension)".to_string() } else { format!(".{ext}") },
                ok.iter().map(|e| format!(".{e}")).collect::<Vec<_>>().join(", ")
            ),
        });
    }
    Ok(())
}

fn eval(ctx: &OpContext) -> Result<Value, OpError> {
    let rel_path = ctx.params.text("path").to_string();
    let ext = extension(&rel_path);
    let fail = |m: String| OpError::Invalid(format!("encoding {rel_path}: {m}"));
    let bytes = match ctx.input("input") {
        Value::Image(img) => encode_image(img, &ext, exposure(ctx, img)).map_err(fail)?,
        Value::Distribution(d) => {
            let img = pdf_image(d);
            encode_image(&img, &ext, exposure(ctx, &img)).map_err(fail)?
        }
        Value::Samples(s) => match ext.as_str() {
            "csv" => samples_csv(s).into_bytes(),
            _ => samples_json(s).into_bytes(),
        },
        Value::Curves(c) => {
            let [w, h] = ctx.params.vec2("plot_size");
            match ext.as_str() {
                "json" => curves_json(c).into_bytes(),
                "csv" => curves_csv(c).into_bytes(),
                "svg" => crate::plotting::curves_plot::plot_svg(c, w as u32, h as u32).map_err(fail)?.into_bytes(),
                _ => crate::plotting::curves_plot::plot_png(c, w as u32, h as u32).map_err(fail)?,
            }
        }
        Value::Metrics(m) => match ext.as_str() {
            "csv" => metrics_csv(m).into_bytes(),
            _ => metrics_json(m).into_bytes(),
        },
        Value::File(_) => return Err(OpError::Invalid("cannot save a file value".into())),
    };
    Ok(Value::File(std::sync::Arc::new(FileBlob { rel_path, bytes })))
}

/// The exposure in stops for a PNG: the `exposure` field, plus with `auto_exposure` the stops
/// that bring the 99.5th percentile of the non-black pixels' max channel to 1.0.
fn exposure(ctx: &OpContext, img: &Image) -> f64 {
    let mut stops = ctx.params.f64("exposure");
    if ctx.params.bool("auto_exposure") {
        let mut lit: Vec<f32> = (0..img.height)
            .flat_map(|y| (0..img.width).map(move |x| (x, y)))
            .map(|(x, y)| img.rgb(x, y).into_iter().fold(0.0f32, f32::max))
            .filter(|v| *v > 0.0 && v.is_finite())
            .collect();
        if !lit.is_empty() {
            let k = ((lit.len() - 1) as f64 * 0.995) as usize;
            let (_, p, _) = lit.select_nth_unstable_by(k, f32::total_cmp);
            stops -= (*p as f64).log2();
        }
    }
    stops
}

fn encode_image(img: &Image, ext: &str, exposure: f64) -> Result<Vec<u8>, String> {
    match ext {
        "png" => formats::png::encode(img, exposure).map_err(|e| e.0),
        "exr" => formats::exr::encode(img).map_err(|e| e.0),
        "hdr" => Ok(formats::rgbe::encode(img)),
        "pfm" => Ok(formats::pfm::encode(img)),
        other => Err(format!("unsupported image extension .{other}")),
    }
}

/// The distribution's solid-angle pdf per texel, as a scalar field.
fn pdf_image(d: &Distribution2D) -> Image {
    let mut img = Image::new(d.width, d.height, 1);
    for y in 0..d.height {
        for x in 0..d.width {
            img.data[y * d.width + x] = d.pdf(x, y) as f32;
        }
    }
    img
}

/// A JSON number, or `null` for NaN and infinities (JSON has neither).
fn num(v: f64) -> serde_json::Value {
    serde_json::Number::from_f64(v).map(serde_json::Value::Number).unwrap_or(serde_json::Value::Null)
}

fn samples_csv(s: &SampleSet) -> String {
    let mut out = String::with_capacity(s.samples.len() * 96);
    out.push_str("index,x,y,theta,phi,dx,dy,dz,pdf\n");
    for (i, p) in s.samples.iter().enumerate() {
        let _ =
            writeln!(out, "{i},{},{},{},{},{},{},{},{}", p.x, p.y, p.theta, p.phi, p.dir[0], p.dir[1], p.dir[2], p.pdf);
    }
    out
}

fn samples_json(s: &SampleSet) -> String {
    let samples: Vec<serde_json::Value> = s
        .samples
        .iter()
        .map(|p| {
            serde_json::json!({
                "x": p.x, "y": p.y, "theta": num(p.theta as f64), "phi": num(p.phi as f64),
                "dx": num(p.dir[0] as f64), "dy": num(p.dir[1] as f64), "dz": num(p.dir[2] as f64),
                "pdf": num(p.pdf as f64),
            })
        })
        .collect();
    let v = serde_json::json!({ "width": s.width, "height": s.height, "count": s.samples.len(), "samples": samples });
    serde_json::to_string_pretty(&v).expect("JSON of plain values") + "\n"
}

fn curves_json(c: &Curves) -> String {
    let mut map = serde_json::Map::new();
    for (name, v) in &c.scalars {
        map.insert(name.clone(), v.map(num).unwrap_or(serde_json::Value::Null));
    }
    map.insert(c.x_name.clone(), c.x.iter().map(|&v| num(v)).collect());
    for (name, ys) in &c.series {
        map.insert(name.clone(), ys.iter().map(|&v| num(v)).collect());
    }
    serde_json::to_string_pretty(&serde_json::Value::Object(map)).expect("JSON of plain values") + "\n"
}

/// Curves as CSV: scalars as leading `# name=value` comment lines, then one row per x.
fn curves_csv(c: &Curves) -> String {
    let mut out = String::new();
    for (name, v) in &c.scalars {
        match v {
            Some(v) => {
                let _ = writeln!(out, "# {name}={v}");
            }
            None => {
                let _ = writeln!(out, "# {name}=none");
            }
        }
    }
    out.push_str(&c.x_name);
    for (name, _) in &c.series {
        out.push(',');
        out.push_str(name);
    }
    out.push('\n');
    for (i, x) in c.x.iter().enumerate() {
        let _ = write!(out, "{x}");
        for (_, ys) in &c.series {
            let _ = write!(out, ",{}", ys[i]);
        }
        out.push('\n');
    }
    out
}

fn metrics_json(m: &Metrics) -> String {
    let mut map = serde_json::Map::new();
    for (name, v) in &m.fields {
        map.insert(name.clone(), num(*v));
    }
    serde_json::to_string_pretty(&serde_json::Value::Object(map)).expect("JSON of plain values") + "\n"
}

fn metrics_csv(m: &Metrics) -> String {
    let names: Vec<&str> = m.fields.iter().map(|(n, _)| n.as_str()).collect();
    let values: Vec<String> = m.fields.iter().map(|(_, v)| v.to_string()).collect();
    format!("{}\n{}\n", names.join(","), values.join(","))
}
