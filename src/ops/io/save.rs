//! `Save(input, path, exposure: 0.0, auto_exposure: false, exposure_from: NODE, plot_size: (800,
//! 500), ktx_format: Rgba16f)`: encode a value as a file in the output folder. `exposure_from` (optional) takes the
//! automatic exposure from another image, so that several PNGs (spheres side by side) share one. The format follows the extension and the value's type:
//!
//! | value                 | extensions                         |
//! |-----------------------|------------------------------------|
//! | image, scalar field   | `.png` (exposure, sRGB, clamped), `.exr`, `.hdr`, `.pfm` |
//! | distribution          | the same, of its solid-angle pdf per texel |
//! | sample set            | `.csv` (`index,x,y,theta,phi,dx,dy,dz,pdf`), `.json` |
//! | curves                | `.json`, `.csv`, `.png`, `.svg` (a plot) |
//! | metrics               | `.json`, `.csv` |
//! | cube map              | `.exr`, `.pfm`, `.hdr`, `.png`: one 6S x S strip, faces +X -X +Y -Y +Z -Z |
//! | mip chain             | the same, one strip per level: the path must contain `{level}` (`spec_{level}.exr`) |
//! | image, cube map, mip chain | `.ktx2`: a 2D texture, a cube texture, a cube texture with every level (`ktx_format`) |
//!
//! The operator only encodes: the engine writes the bytes atomically into `--out`, and refuses
//! paths that are absolute or leave that folder. Encoding is cached like any result.

use crate::engine::fields::{AnyValue, Check, Input};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec, OutputType};
use crate::engine::params::OutputPath;
use crate::engine::value::{FileBlob, SaveOptions, Value, ValueType, FILE};
use crate::formats::ktx2::KtxFormat;
use crate::values::image::channels_not_kept;
use crate::values::Image;

crate::params! {
    pub struct SaveParams {
        /// the value to write (any type that can be saved: see the type list in `hdrflow ops`)
        pub input: Input<AnyValue>,
        /// (.png) take the automatic exposure from this image instead, so several PNGs share one exposure
        #[input(crate::values::ty::ANY_IMAGE)]
        pub exposure_from: Option<Input<Image>>,
        /// file name relative to the output folder (--out); no `..`, not absolute
        pub path: OutputPath,
        /// exposure in stops applied before the sRGB transfer (.png only)
        #[range(-64.0, 64.0)]
        pub exposure: f64 = 0.0,
        /// (.png) first scale so the 99.5th percentile of lit pixels' max channel maps to 1 (a mip chain: of level 0, for every level)
        pub auto_exposure: bool = false,
        /// width and height in pixels of a curve plot (.png, .svg)
        #[range(64.0, 8192.0)]
        pub plot_size: [f64; 2] = [800.0, 500.0],
        /// (.ktx2) texel format: Rgba16f (VK_FORMAT_R16G16B16A16_SFLOAT, values clamped to +-65504) or Rgba32f (VK_FORMAT_R32G32B32A32_SFLOAT)
        pub ktx_format: KtxFormat = KtxFormat::Rgba16f,
        /// (.exr) Zip (lossless, 16-line blocks), Piz (lossless wavelet), Dwaa (lossy DCT, 32-line blocks) or None
        pub compression: crate::formats::exr::ExrCompression = crate::formats::exr::ExrCompression::Zip,
        /// (.exr) store half floats (16-bit; values beyond 65504 become infinite) instead of f32
        pub half: bool = false,
    }
}

pub fn spec() -> OpSpec {
    OpSpec::new("Save", "io", 2, "Write a value to a file in the output folder; the format follows the extension")
        .output("file", OutputType::Fixed(ValueType(&FILE)), "the encoded file (the engine writes it into --out)")
        .code_hash(crate::op_code_hash!())
        .eval(eval)
        .check(check)
}

fn check(_: &CheckContext, p: SaveParams<Check>) -> Result<(), CheckProblem> {
    if p.auto_exposure && p.exposure_from.is_some() {
        return Err(CheckProblem::at(
            "auto_exposure",
            "give either auto_exposure (each PNG its own exposure) or exposure_from (one shared exposure), not both",
        ));
    }
    let ext = p.path.extension();
    if p.ktx_format != KtxFormat::Rgba16f && ext != "ktx2" {
        return Err(CheckProblem::at("ktx_format", "ktx_format applies to .ktx2 files only"));
    }
    let t = p.input.ty;
    if t == crate::values::ty::MIP_CHAIN_T && ext != "ktx2" && !p.path.0.contains("{level}") {
        return Err(CheckProblem::at(
            "path",
            "a mip chain is saved one file per level: put {level} in the path (e.g. \"spec_{level}.exr\"), or save it as one .ktx2",
        ));
    }
    let ok = t.spec().save_extensions;
    if ok.is_empty() {
        return Err(CheckProblem::at("input", format!("a value of type {t} cannot be saved")));
    }
    if !ok.contains(&ext.as_str()) {
        return Err(CheckProblem::at(
            "path",
            format!(
                "cannot save a value of type {t} as {:?}: use one of {}",
                if ext.is_empty() { "(no extension)".to_string() } else { format!(".{ext}") },
                ok.iter().map(|e| format!(".{e}")).collect::<Vec<_>>().join(", ")
            ),
        ));
    }
    Ok(())
}

fn eval(ctx: &mut OpContext, p: SaveParams) -> Result<Value, OpError> {
    let rel_path = p.path.0.clone();
    let value = p.input.value();
    let ext = p.path.extension();
    if let Some(note) = value.get::<Image>().and_then(|img| channels_not_kept(img, &ext)) {
        ctx.warn(format!("{rel_path}: {note}"));
    }
    let half = match ext.as_str() {
        "ktx2" if p.ktx_format == KtxFormat::Rgba16f => Some("are clamped to +-65504 (ktx_format: Rgba32f keeps them)"),
        "exr" if p.half => Some("become infinite (half: false keeps them)"),
        _ => None,
    };
    if let Some(fate) = half {
        let (count, brightest) = beyond_half(value);
        if count > 0 {
            ctx.warn(format!(
                "{rel_path}: {count} texel{} exceed{} the half-float maximum 65504 (the largest: {brightest}) and {fate}",
                if count == 1 { "" } else { "s" },
                if count == 1 { "s" } else { "" },
            ));
        }
    }
    let fail = |m: String| OpError::Invalid(format!("encoding {rel_path}: {m}"));
    let save =
        value.value_type().spec().save.ok_or_else(|| fail(format!("a {} cannot be saved", value.value_type())))?;
    let mut exposure = p.exposure;
    if let Some(reference) = p.exposure_from.as_deref() {
        exposure += auto_exposure(reference);
    } else if p.auto_exposure {
        if let Some(img) = value.get::<Image>() {
            exposure += auto_exposure(img);
        } else if let Some(d) = value.get::<crate::values::Distribution2D>() {
            exposure += auto_exposure(&crate::values::distribution::pdf_image(d));
        } else if let Some(c) = value.get::<crate::values::Cubemap>() {
            exposure += auto_exposure(&c.to_strip());
        } else if let Some(c) = value.get::<crate::values::MipChain>().and_then(|c| c.levels.first()) {
            exposure += auto_exposure(&c.to_strip());
        }
    }
    let mut options = SaveOptions::new(ext)
        .with(p.ktx_format)
        .with(crate::formats::exr::EncodeOptions { compression: p.compression, half: p.half });
    options.exposure = exposure;
    options.plot_size = (p.plot_size[0] as u32, p.plot_size[1] as u32);
    if let Some(chain) = value.get::<crate::values::MipChain>().filter(|_| options.ext != "ktx2") {
        let mut files = crate::values::cubemap::save_levels(chain, &rel_path, &options).map_err(fail)?.into_iter();
        let (first_path, first) = files.next().ok_or_else(|| fail("an empty mip chain".into()))?;
        return Ok(Value::new(FileBlob { rel_path: first_path, bytes: first, more: files.collect() }));
    }
    if let (Some(img), "png") = (value.get::<Image>(), options.ext.as_str()) {
        // An image as PNG (the bytes of `values::image`'s encoder): the 8-bit copy first, then the
        // float image is handed back before the deflate, which takes most of the time, so that a
        // run drawing several large overlays need not hold two at once (`scheduler::admission`).
        let srgb = crate::formats::png::to_srgb8(img, options.exposure).map_err(|e| fail(e.to_string()))?;
        ctx.release(p.input.into_value());
        let bytes = srgb.encode().map_err(|e| fail(e.to_string()))?;
        return Ok(Value::new(FileBlob::new(rel_path, bytes)));
    }
    let bytes = save(value, &options).map_err(fail)?;
    Ok(Value::new(FileBlob::new(rel_path, bytes)))
}

/// How many texels of an image, cube map or mip chain have a channel beyond the half-float
/// range (|v| > 65504, infinities included), and the largest such magnitude.
fn beyond_half(value: &Value) -> (usize, f32) {
    // (data, channels) of every texel array the value holds.
    let arrays: Vec<(&[f32], usize)> = if let Some(img) = value.get::<Image>() {
        vec![(&img.data, img.channels)]
    } else if let Some(c) = value.get::<crate::values::Cubemap>() {
        vec![(&c.data, 3)]
    } else if let Some(chain) = value.get::<crate::values::MipChain>() {
        chain.levels.iter().map(|c| (c.data.as_slice(), 3)).collect()
    } else {
        Vec::new()
    };
    let mut found = (0, 0.0f32);
    for (data, channels) in arrays {
        for texel in data.chunks_exact(channels.max(1)) {
            let m = texel.iter().fold(0.0f32, |m, v| m.max(v.abs()));
            if m > 65504.0 {
                found = (found.0 + 1, found.1.max(m));
            }
        }
    }
    found
}

/// The stops that bring the 99.5th percentile of the non-black pixels' max channel to 1.0.
fn auto_exposure(img: &Image) -> f64 {
    let mut lit: Vec<f32> = (0..img.height)
        .flat_map(|y| (0..img.width).map(move |x| (x, y)))
        .map(|(x, y)| img.rgb(x, y).into_iter().fold(0.0f32, f32::max))
        .filter(|v| *v > 0.0 && v.is_finite())
        .collect();
    if lit.is_empty() {
        return 0.0;
    }
    let k = ((lit.len() - 1) as f64 * 0.995) as usize;
    let (_, p, _) = lit.select_nth_unstable_by(k, f32::total_cmp);
    -(*p as f64).log2()
}
