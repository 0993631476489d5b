//! How `Save` writes an [`Image`] (an `image` or a `scalar field`): `.png` (exposure then sRGB,
//! 8-bit; RGBA keeps alpha), `.exr` (f32, every channel under its name), `.hdr` (RGB) or `.pfm`
//! (RGB or grey), `.ktx2` (a 2D texture of one level in any `KtxFormat`: RGB gets alpha 1, grey is
//! replicated to RGB; `formats::ktx2`), `.ktx` (the same as KTX 1.1, `formats::ktx1`); PNG may be
//! 16-bit linear (`PngFormat::Linear16`). A `distribution` is written as the scalar field of its
//! solid-angle pdf per texel (`values::distribution::pdf_image`), in the same formats but KTX.
//! Also what a file does not keep of an image's channels, for `Save`'s warnings.

use crate::engine::registry::Registry;
use crate::engine::save::SaveOptions;
use crate::engine::value::Value;
use crate::formats;
use crate::values::distribution::{pdf_image, Distribution2D};
use crate::values::{Image, DISTRIBUTION, IMAGE, SCALAR_FIELD};

/// Registers the savers of images, scalar fields and distributions.
pub fn register(r: &mut Registry) {
    r.register_saver(&IMAGE, &["png", "exr", "hdr", "pfm", "ktx2", "ktx"], save);
    r.register_saver(&SCALAR_FIELD, &["png", "exr", "hdr", "pfm", "ktx2", "ktx"], save);
    r.register_saver(&DISTRIBUTION, &["png", "exr", "hdr", "pfm"], save_distribution);
}

fn save(value: &Value, o: &SaveOptions) -> Result<Vec<u8>, String> {
    let img = value.get::<Image>().ok_or("not an image")?;
    if o.ext == "ktx2" || o.ext == "ktx" {
        let rgba = formats::ktx2::image_rgba(img);
        let level = formats::ktx2::Level { width: img.width, height: img.height, rgba: &rgba };
        let bytes = if o.ext == "ktx2" {
            formats::ktx2::encode_with(&[level], 1, o.get_or_default(), o.get_or_default())
        } else {
            formats::ktx1::encode(&[level], 1, o.get_or_default(), &o.get_or_default())
        };
        return bytes.map_err(|e| e.to_string());
    }
    encode_image(img, o)
}

fn save_distribution(value: &Value, o: &SaveOptions) -> Result<Vec<u8>, String> {
    let d = value.get::<Distribution2D>().ok_or("not a distribution")?;
    encode_image(&pdf_image(d), o)
}

/// Encodes an image as a file of the given extension.
pub fn encode_image(img: &Image, o: &SaveOptions) -> Result<Vec<u8>, String> {
    let ext = o.ext.as_str();
    match ext {
        "png" => match o.get_or_default() {
            formats::png::PngFormat::Srgb8 => formats::png::encode(img, o.exposure).map_err(|e| e.to_string()),
            formats::png::PngFormat::Linear16 => {
                formats::png::encode_linear16(img, o.exposure).map_err(|e| e.to_string())
            }
            formats::png::PngFormat::Rgbp => formats::rgbp::encode_png(img).map(|(png, _)| png),
        },
        "exr" => formats::exr::encode_with(img, &o.get_or_default()).map_err(|e| e.to_string()),
        "hdr" | "pfm" => {
            // RGBE and PFM hold RGB (PFM also grey): alpha and further channels are dropped
            // (`channels_not_kept` says which, and `Save` warns).
            let rgb = if img.channels > 3 || img.channels == 2 {
                Image::from_fn_rgb(img.width, img.height, |x, y| img.rgb(x, y))
            } else {
                img.clone()
            };
            Ok(if ext == "hdr" { formats::rgbe::encode(&rgb) } else { formats::pfm::encode(&rgb) })
        }
        other => Err(format!("unsupported image extension .{other}")),
    }
}

/// What a file of extension `ext` does not keep of `img`'s channels, said for a warning: the
/// channels it drops, or the zero channel it adds to two colour channels; `None` when every
/// channel is kept as it is. PNG refuses 2 and 5+ channels (an error, so nothing to say here);
/// EXR keeps every channel under its name.
pub fn channels_not_kept(img: &Image, ext: &str) -> Option<String> {
    // RGB formats, and KTX2 (RGBA in its default format); PNG and EXR keep what they accept.
    let holds = match ext {
        "hdr" | "pfm" => "RGB",
        "ktx2" => "RGBA",
        _ => return None,
    };
    channels_not_kept_in(img, ext, holds)
}

/// [`channels_not_kept`] for a file of extension `ext` whose texels hold `holds`: `RGBA`, `RGB`
/// or `RG` (a KTX texel format's channels: `KtxFormat::channels`).
pub fn channels_not_kept_in(img: &Image, ext: &str, holds: &str) -> Option<String> {
    let kept_alpha = holds == "RGBA";
    let colours = if holds == "RG" { 2 } else { 3 };
    let alpha = img.alpha_index().filter(|_| kept_alpha);
    let dropped: Vec<&str> = (0..img.channels)
        .filter(|&c| c >= colours && Some(c) != alpha)
        .chain((img.channels == 2 && img.names[1] == "A" && !kept_alpha).then_some(1))
        .map(|c| img.names[c].as_str())
        .collect();
    if !dropped.is_empty() {
        return Some(format!(
            ".{ext} holds {holds}: channel{} {} of the {}-channel image {} dropped (.exr keeps every channel)",
            if dropped.len() == 1 { "" } else { "s" },
            dropped.join(", "),
            img.channels,
            if dropped.len() == 1 { "is" } else { "are" },
        ));
    }
    (img.channels == 2 && img.names[1] != "A" && colours == 3).then(|| {
        format!(
            ".{ext} holds {holds}: the two channels {} and {} are written as R and G, with B = 0 (.exr keeps the two channels as they are)",
            img.names[0], img.names[1]
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::values::image::default_names;

    /// Every format against every channel count: a channel the file does not hold is always
    /// announced by `channels_not_kept` (or the encoder refuses the image), so `Save` never
    /// loses one silently.
    #[test]
    fn no_format_loses_a_channel_silently() {
        let values = [0.25f32, 0.5, 0.75, 0.125, 0.375];
        let mut cases: Vec<Vec<String>> = (1..=5).map(default_names).collect();
        cases.push(vec!["R".into(), "G".into()]);
        cases.push(vec!["R".into(), "G".into(), "B".into(), "Z".into()]);
        for names in cases {
            let c = names.len();
            let data: Vec<f32> = (0..4).flat_map(|_| values[..c].iter().copied()).collect();
            let img = Image::with_names(2, 2, names.clone(), data);
            for ext in ["exr", "hdr", "pfm", "png", "ktx2"] {
                let mut o = SaveOptions::new(ext).with(formats::ktx2::KtxFormat::Rgba32f);
                o.plot_size = (1, 1);
                let stored: Vec<f32> = match ext {
                    "ktx2" => formats::ktx2::image_rgba(&img)[..4].to_vec(),
                    _ => match save(&Value::new(img.clone()), &o) {
                        Ok(bytes) if ext == "png" => {
                            // 8-bit: each byte read back both as sRGB colour and as linear alpha.
                            let png = ::image::load_from_memory(&bytes).expect("decodes");
                            let n = png.color().channel_count() as usize;
                            png.as_bytes()[..n]
                                .iter()
                                .flat_map(|&b| {
                                    let v = b as f32 / 255.0;
                                    let srgb = if v <= 0.04045 { v / 12.92 } else { ((v + 0.055) / 1.055).powf(2.4) };
                                    [srgb, v]
                                })
                                .collect()
                        }
                        Ok(bytes) if ext == "exr" => {
                            // Every channel as stored (hdrflow's reader wants a colour channel).
                            use ::exr::prelude::*;
                            let file = read()
                                .no_deep_data()
                                .largest_resolution_level()
                                .all_channels()
                                .all_layers()
                                .all_attributes()
                                .from_buffered(std::io::Cursor::new(bytes))
                                .expect("decodes");
                            file.layer_data[0]
                                .channel_data
                                .list
                                .iter()
                                .map(|ch| ch.sample_data.value_by_flat_index(0).to_f32())
                                .collect()
                        }
                        Ok(bytes) => formats::decode_by_extension(&bytes, ext).expect("decodes").pixel(0, 0).to_vec(),
                        Err(_) => {
                            assert!(ext == "png" && (c == 2 || c == 5), "{ext} refused {names:?}");
                            continue;
                        }
                    },
                };
                let tol = if ext == "hdr" || ext == "png" { 0.02 } else { 1e-6 };
                let lost: Vec<&String> = (0..c)
                    .filter(|&k| !stored.iter().any(|s| (s - values[k]).abs() <= tol * values[k]))
                    .map(|k| &names[k])
                    .collect();
                let note = channels_not_kept(&img, ext);
                if !lost.is_empty() {
                    let note = note.as_deref().unwrap_or_else(|| panic!(".{ext} loses {lost:?} of {names:?} silently"));
                    for n in &lost {
                        assert!(note.contains(n.as_str()), ".{ext} {names:?}: {note:?} does not name {n}");
                    }
                }
                if c == 2 && names[1] != "A" && ext != "exr" && ext != "png" {
                    assert!(note.is_some_and(|n| n.contains("B = 0")), ".{ext} {names:?}: the zero B is not said");
                }
            }
        }
    }
}
