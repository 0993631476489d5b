//! `Save(input, path, exposure: 0.0, auto_exposure: false, exposure_from: NODE, plot_size: (800,
//! 500), ktx_format: Rgba16f, ktx_supercompression: None, zstd_level: 3, ktx1_format: Rg11b10f,
//! sh: NODE, png_format: Srgb8)`: encode a value as a file in the output folder. `exposure_from`
//! (optional) takes the automatic exposure from another image, so that several PNGs (spheres side
//! by side) share one. The format follows the extension and the value's type:
//!
//! | value                 | extensions                         |
//! |-----------------------|------------------------------------|
//! | image, scalar field   | `.png` (exposure, sRGB, clamped; or 16-bit linear, or PlayCanvas' RGBP, `png_format`), `.exr`, `.hdr`, `.pfm` |
//! | distribution          | the same, of its solid-angle pdf per texel |
//! | sample set            | `.csv` (`index,x,y,theta,phi,dx,dy,dz,pdf`), `.json` |
//! | curves                | `.json`, `.csv`, `.png`, `.svg` (a plot) |
//! | metrics               | `.json`, `.csv` |
//! | cube map              | `.exr`, `.pfm`, `.hdr`, `.png`: one 6S x S strip, faces +X -X +Y -Y +Z -Z |
//! | mip chain             | the same, one strip per level: the path must contain `{level}` (`spec_{level}.exr`) |
//! | brackets              | one photograph per frame with its EXIF exposure time: a folder `frames/` (`frame_0.png`, ...) or a path with `{frame}` (`.png` 8/16-bit, `.jpg`, `.tif`) |
//! | image, cube map, mip chain | `.ktx2`: a 2D texture, a cube texture, a cube texture with every level (`ktx_format`, `ktx_supercompression`) |
//! | image, cube map, mip chain | `.ktx` (KTX 1.1, for Filament): the same (`ktx1_format`; `sh`: SH coefficients under the key `sh`, as cmgen writes them) |
//! | mip chain             | `.env` (Babylon.js): every level down to 1 x 1 as RGBD PNGs; `sh`: 9 SH coefficients in Babylon's axes, written as its irradiance polynomial; texels beyond RGBD's 255 are clamped, with one warning |
//! | mip chain             | `.gltf`: a glTF 2.0 asset whose `EXT_lights_image_based` light is the chain (its RGBD PNG faces written beside it) and `sh` (required: 9 SH coefficients in the engine's axes) as its `irradianceCoefficients`; clamped as `.env` |
//!
//! The operator only encodes: the engine writes the bytes atomically into `--out`, and refuses
//! paths that are absolute or leave that folder. Encoding is cached like any result.

use crate::engine::fields::{AnyValue, Check, Input};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec};
use crate::engine::params::OutputPath;
use crate::engine::save::SaveOptions;
use crate::engine::typed_op::Op;
use crate::engine::value::{FileBlob, Value, ValueType, FILE};
use crate::formats::babylon_env::{EnvIrradiance, Polynomial};
use crate::formats::gltf_ibl;
use crate::formats::ktx1::{self, Ktx1Format};
use crate::formats::ktx2::{Compression, KtxFormat, KtxSupercompression};
use crate::formats::png::PngFormat;
use crate::formats::rgbd::RGBD_MAX;
use crate::formats::save::brackets;
use crate::formats::save::image::{channels_not_kept, channels_not_kept_in};
use crate::values::Image;
use crate::values::{FilamentSh, ShCoefficients};

/// The files that hold a whole mip chain (every other format writes one file per level).
const CHAIN_FILES: [&str; 4] = ["ktx2", "ktx", "env", "gltf"];

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
        /// (.ktx2) texel format: Rgba16f (VK_FORMAT_R16G16B16A16_SFLOAT, values clamped to +-65504), Rgba32f (VK_FORMAT_R32G32B32A32_SFLOAT), Rgb9e5 (E5B9G9R9_UFLOAT_PACK32: [0, 65408], within 2^-9 of the largest channel), Rg11b10f (B10G11R11_UFLOAT_PACK32: [0, 65024], relative 2^-7, B 2^-6) or Rg16f (R16G16_SFLOAT: R and G, for a BRDF LUT); values a format cannot hold are clamped, with one warning
        pub ktx_format: KtxFormat = KtxFormat::Rgba16f,
        /// (.ktx2) None, or Zstd: Zstandard supercompression (supercompressionScheme 2), each level compressed on its own
        pub ktx_supercompression: KtxSupercompression = KtxSupercompression::None,
        /// (.ktx2 with ktx_supercompression: Zstd) the Zstandard level, 1 (fastest) to 22 (smallest); 3 is zstd's default, 19 about 10% smaller and 10x slower
        #[range(1, 22)]
        pub zstd_level: usize = 3,
        /// (.ktx) texel format: Rg11b10f (GL_R11F_G11F_B10F, cmgen's default: [0, 65024], relative 2^-7, B 2^-6) or Rgba16f (GL_RGBA16F, clamped to +-65504)
        pub ktx1_format: Ktx1Format = Ktx1Format::Rg11b10f,
        /// (.ktx) 3-band SH written under the key "sh" as Filament's cmgen writes them (9 lines "r g b"), as given: Filament expects its pre-scaled irradiance SH, ShIrradiance's filament port; (.env) ShIrradiance's coefficients, written as Babylon's irradiance polynomial; (.gltf, required) ShIrradiance's coefficients, written as the light's irradianceCoefficients
        #[input(&[crate::values::ty::FILAMENT_SH_T, crate::values::ty::SH_COEFFICIENTS_T])]
        pub sh: Option<Input<AnyValue>>,
        /// (.png of an image or cube map) Srgb8 (an 8-bit sRGB preview), Linear16 (16-bit linear values clamped to [0, 1], for data such as a BRDF LUT: two channels as R, G with B = 0) or Rgbp (PlayCanvas' 8-bit RGBP, values up to 64, beyond that clamped with one warning; exposure not applied)
        pub png_format: PngFormat = PngFormat::Srgb8,
        /// (.exr) Zip (lossless, 16-line blocks), Rle (lossless run lengths: twice as fast as Zip, compact only where large areas are flat, such as a render's transparent background), Piz (lossless wavelet), Dwaa (lossy DCT, 32-line blocks) or None
        pub compression: crate::formats::exr::ExrCompression = crate::formats::exr::ExrCompression::Zip,
        /// (.exr) store half floats (16-bit; values beyond 65504 become infinite) instead of f32
        pub half: bool = false,
    }
}

pub fn spec() -> OpSpec {
    Op::new("Save", 2, "Write a value to a file in the output folder; the format follows the extension", eval)
        .output("file", ValueType(&FILE), "the encoded file (the engine writes it into --out)")
        .check(check)
        .into()
}

fn check(ctx: &CheckContext, p: SaveParams<Check>) -> Result<(), CheckProblem> {
    if p.auto_exposure && p.exposure_from.is_some() {
        return Err(CheckProblem::at(
            SaveParams::auto_exposure,
            "give either auto_exposure (each PNG its own exposure) or exposure_from (one shared exposure), not both",
        ));
    }
    let t = p.input.ty;
    let ext = if t == crate::values::ty::BRACKETS_T {
        let pattern = brackets::frame_pattern(&p.path.0).ok_or_else(|| {
            CheckProblem::at(
                SaveParams::path,
                "brackets are saved one file per frame: give a folder (\"frames/\": frame_0.png, frame_1.png, ...) or a path with {frame} (\"frames/shot_{frame}.jpg\")",
            )
        })?;
        OutputPath(pattern).extension()
    } else {
        p.path.extension()
    };
    if p.ktx_format != KtxFormat::Rgba16f && ext != "ktx2" {
        return Err(CheckProblem::at(SaveParams::ktx_format, "ktx_format applies to .ktx2 files only"));
    }
    if p.ktx_supercompression != KtxSupercompression::None && ext != "ktx2" {
        return Err(CheckProblem::at(
            SaveParams::ktx_supercompression,
            "ktx_supercompression applies to .ktx2 files only",
        ));
    }
    if p.zstd_level != crate::formats::ktx2::DEFAULT_ZSTD_LEVEL as usize
        && p.ktx_supercompression != KtxSupercompression::Zstd
    {
        return Err(CheckProblem::at(SaveParams::zstd_level, "zstd_level applies to ktx_supercompression: Zstd only"));
    }
    if p.ktx1_format != Ktx1Format::Rg11b10f && ext != "ktx" {
        return Err(CheckProblem::at(SaveParams::ktx1_format, "ktx1_format applies to .ktx files only"));
    }
    if p.sh.is_some() && !["ktx", "env", "gltf"].contains(&ext.as_str()) {
        return Err(CheckProblem::at(
            SaveParams::sh,
            "sh applies to .ktx files (Filament's key \"sh\"), .env files (Babylon's irradiance) and .gltf files (irradianceCoefficients) only",
        ));
    }
    if p.sh.is_none() && ext == "gltf" {
        return Err(CheckProblem::at(
            SaveParams::sh,
            "a .gltf's EXT_lights_image_based light needs irradianceCoefficients: give sh (ShIrradiance's coefficients)",
        ));
    }
    if p.png_format != PngFormat::Srgb8 && (ext != "png" || t == crate::values::ty::CURVES_T) {
        return Err(CheckProblem::at(
            SaveParams::png_format,
            "png_format applies to .png files of images and cube maps only",
        ));
    }
    if t == crate::values::ty::MIP_CHAIN_T && !CHAIN_FILES.contains(&ext.as_str()) && !p.path.0.contains("{level}") {
        return Err(CheckProblem::at(
            SaveParams::path,
            "a mip chain is saved one file per level: put {level} in the path (e.g. \"spec_{level}.exr\"), or save it as one .ktx2",
        ));
    }
    let ok = ctx.savers.get(t).map_or(&[][..], |s| s.extensions);
    if ok.is_empty() {
        return Err(CheckProblem::at(SaveParams::input, format!("a value of type {t} cannot be saved")));
    }
    if !ok.contains(&ext.as_str()) {
        return Err(CheckProblem::at(
            SaveParams::path,
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
    if let Some(b) = value.get::<crate::values::Brackets>() {
        let fail = |m: String| OpError::Invalid(format!("encoding {rel_path}: {m}"));
        let pattern =
            brackets::frame_pattern(&rel_path).ok_or_else(|| fail("a bracket needs a folder or {frame}".into()))?;
        let mut files = brackets::save_frames(b, &pattern).map_err(fail)?.into_iter();
        let (first_path, first) = files.next().ok_or_else(|| fail("an empty bracket".into()))?;
        return Ok(Value::new(FileBlob { rel_path: first_path, bytes: first, more: files.collect() }));
    }
    let ext = p.path.extension();
    // The texel format of a KTX file (either version), for the warnings.
    let ktx = match ext.as_str() {
        "ktx2" => Some(p.ktx_format),
        "ktx" => Some(p.ktx1_format.texels()),
        _ => None,
    };
    let note = match (value.get::<Image>(), ktx) {
        (Some(img), Some(format)) => channels_not_kept_in(img, &ext, format.channels()),
        (Some(img), None) => channels_not_kept(img, &ext),
        // Cube maps and chains are RGB: only an RG format drops a channel.
        (None, Some(KtxFormat::Rg16f)) => Some(format!(
            ".ktx2 holds RG with ktx_format {}: channel B of the {} is dropped",
            p.ktx_format,
            value.value_type()
        )),
        (None, _) => None,
    };
    if let Some(note) = note {
        ctx.warn(format!("{rel_path}: {note}"));
    }
    let half = match ext.as_str() {
        "ktx2" if p.ktx_format == KtxFormat::Rgba16f => Some("are clamped to +-65504 (ktx_format: Rgba32f keeps them)"),
        "ktx" if p.ktx1_format == Ktx1Format::Rgba16f => Some("are clamped to +-65504"),
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
    if let Some(format) = ktx.filter(|f| !matches!(f, KtxFormat::Rgba16f | KtxFormat::Rgba32f)) {
        let count = clamped_texels(value, format);
        if count > 0 {
            ctx.warn(format!(
                "{rel_path}: {count} texel{} {} values that {} {format} cannot hold: values {}",
                if count == 1 { "" } else { "s" },
                if count == 1 { "has" } else { "have" },
                if ext == "ktx" { "ktx1_format" } else { "ktx_format" },
                format.clamp_note(),
            ));
        }
    }
    let fail = |m: String| OpError::Invalid(format!("encoding {rel_path}: {m}"));
    let save = ctx
        .savers
        .get(value.value_type())
        .map(|s| s.save)
        .ok_or_else(|| fail(format!("a {} cannot be saved", value.value_type())))?;
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
    if let (PngFormat::Rgbp, "png") = (p.png_format, ext.as_str()) {
        let count = beyond_rgbp(value);
        if count > 0 {
            ctx.warn(format!(
                "{rel_path}: {count} texel{} beyond RGBP's range (64) clamped to it (colour kept)",
                if count == 1 { " is" } else { "s are" }
            ));
        }
    }
    if ext == "env" || ext == "gltf" {
        let count = beyond_rgbd(value);
        if count > 0 {
            ctx.warn(format!(
                "{rel_path}: {count} texel{} beyond RGBD's range (255) clamped to it (colour kept)",
                if count == 1 { " is" } else { "s are" }
            ));
        }
    }
    let mut env_irradiance = EnvIrradiance::default();
    let mut gltf_irradiance = None;
    let mut key_values = ktx1::KeyValues::default();
    if let (Some(sh), "env" | "gltf") = (&p.sh, ext.as_str()) {
        let c = sh
            .value()
            .get::<ShCoefficients>()
            .ok_or_else(|| fail(format!("sh of a .{ext}: give ShIrradiance's coefficients")))?;
        let sh_error = |e: String| fail(format!("the sh input: {e}"));
        if ext == "env" {
            env_irradiance.0 = Some(Polynomial::from_sh(&c.rgb).map_err(sh_error)?);
        } else {
            gltf_irradiance = Some(gltf_ibl::irradiance_coefficients(&c.rgb).map_err(sh_error)?);
        }
    } else if let Some(sh) = &p.sh {
        let rgb = match sh.value().get::<FilamentSh>() {
            Some(filament) => filament.rgb.to_vec(),
            None => sh.value().get::<ShCoefficients>().map(|c| c.rgb.clone()).unwrap_or_default(),
        };
        let text = ktx1::sh_text(&rgb).map_err(|e| fail(format!("the sh input: {e}")))?;
        key_values.0.push(("sh".into(), text.into_bytes()));
    }
    let mut options = SaveOptions::new(ext)
        .with(p.ktx_format)
        .with(Compression { scheme: p.ktx_supercompression, zstd_level: p.zstd_level as i32 })
        .with(p.ktx1_format)
        .with(key_values)
        .with(env_irradiance)
        .with(p.png_format)
        .with(crate::formats::exr::EncodeOptions { compression: p.compression, half: p.half });
    options.exposure = exposure;
    options.plot_size = (p.plot_size[0] as u32, p.plot_size[1] as u32);
    if let Some(chain) = value.get::<crate::values::MipChain>().filter(|_| !CHAIN_FILES.contains(&options.ext.as_str()))
    {
        let mut files =
            crate::formats::save::cubemap::save_levels(chain, &rel_path, &options).map_err(fail)?.into_iter();
        let (first_path, first) = files.next().ok_or_else(|| fail("an empty mip chain".into()))?;
        return Ok(Value::new(FileBlob { rel_path: first_path, bytes: first, more: files.collect() }));
    }
    if let (Some(chain), Some(c)) = (value.get::<crate::values::MipChain>(), gltf_irradiance) {
        // The .gltf, then its images (`formats::gltf_ibl`).
        let (mut files, _) = gltf_ibl::encode(&chain.levels, &c, &rel_path).map_err(fail)?;
        let (first_path, first) = files.remove(0);
        return Ok(Value::new(FileBlob { rel_path: first_path, bytes: first, more: files }));
    }
    if let (Some(img), "png", PngFormat::Srgb8) = (value.get::<Image>(), options.ext.as_str(), p.png_format) {
        // An image as PNG (the bytes of `formats::save::image`'s encoder): the 8-bit copy first, then the
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

/// How many texels of an image, a cube map or a mip chain (every level: `Save` writes each) an
/// RGBP `.png` clamps (`formats::rgbp`), counted on the RGB data without the strip's copy.
fn beyond_rgbp(value: &Value) -> usize {
    use crate::formats::rgbp::{beyond_rgbp as in_image, beyond_rgbp_rgb as in_rgb};
    if let Some(img) = value.get::<Image>() {
        in_image(img)
    } else if let Some(c) = value.get::<crate::values::Cubemap>() {
        in_rgb(&c.data)
    } else if let Some(chain) = value.get::<crate::values::MipChain>() {
        chain.levels.iter().map(|c| in_rgb(&c.data)).sum()
    } else {
        0
    }
}

/// How many texels of a mip chain have a channel beyond RGBD's range (`formats::babylon_env`).
fn beyond_rgbd(value: &Value) -> usize {
    let Some(chain) = value.get::<crate::values::MipChain>() else { return 0 };
    chain.levels.iter().flat_map(|c| c.data.chunks_exact(3)).filter(|t| t.iter().any(|v| *v > RGBD_MAX)).count()
}

/// How many texels of an image, cube map or mip chain `format` changes beyond rounding
/// ([`KtxFormat::clamps`]), each read as the KTX encoder reads it (RGB and alpha, alpha 1).
fn clamped_texels(value: &Value, format: KtxFormat) -> usize {
    if let Some(img) = value.get::<Image>() {
        let alpha = img.alpha_index();
        (0..img.height)
            .flat_map(|y| (0..img.width).map(move |x| (x, y)))
            .filter(|&(x, y)| {
                let [r, g, b] = img.rgb(x, y);
                format.clamps([r, g, b, alpha.map_or(1.0, |a| img.pixel(x, y)[a])])
            })
            .count()
    } else {
        let cubes: Vec<&crate::values::Cubemap> = if let Some(c) = value.get::<crate::values::Cubemap>() {
            vec![c]
        } else if let Some(chain) = value.get::<crate::values::MipChain>() {
            chain.levels.iter().collect()
        } else {
            Vec::new()
        };
        cubes.iter().flat_map(|c| c.data.chunks_exact(3)).filter(|t| format.clamps([t[0], t[1], t[2], 1.0])).count()
    }
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
