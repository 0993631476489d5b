//! `image` (2+ channels) and `scalar field` (1 channel): both are [`Image`]s; the type follows
//! the channel count, so an operator can demand a one-channel input at validation.
//!
//! Cache payload: width, height, channel names, then the f32 samples. Saved as `.png` (exposure
//! then sRGB, 8-bit; RGBA keeps alpha; or 16-bit linear, `PngFormat::Linear16`), `.exr` (f32, every channel under its name), `.hdr` (RGB)
//! or `.pfm` (RGB or grey), `.ktx2` (a 2D texture of one level in any `KtxFormat`: RGB gets
//! alpha 1, grey is replicated to RGB; `formats::ktx2`), `.ktx` (the same as KTX 1.1, `formats::ktx1`).

use crate::data::Image;
use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{SaveOptions, TypeSpec, Value, ValueData, ValueType};
use crate::formats;

pub static IMAGE: TypeSpec = TypeSpec {
    name: "image",
    doc: "a float raster of 2 or more named channels (RGB, RGBA, ...), linear radiance",
    decode,
    save_extensions: &["png", "exr", "hdr", "pfm", "ktx2", "ktx"],
    save: Some(save),
};

pub static SCALAR_FIELD: TypeSpec = TypeSpec {
    name: "scalar field",
    doc: "a one-channel float raster (luminance, weights, masks, one channel of an image)",
    decode,
    save_extensions: &["png", "exr", "hdr", "pfm", "ktx2", "ktx"],
    save: Some(save),
};

impl ValueData for Image {
    fn value_type(&self) -> ValueType {
        if self.channels == 1 {
            ValueType(&SCALAR_FIELD)
        } else {
            ValueType(&IMAGE)
        }
    }
    fn approx_bytes(&self) -> usize {
        self.data.len() * 4
    }
    fn summary(&self) -> String {
        let n = self.pixel_count().max(1) as f64;
        let means: Vec<String> = (0..self.channels)
            .map(|c| {
                let sum: f64 = self.data.iter().skip(c).step_by(self.channels).map(|&v| v as f64).sum();
                format!("{} {:.6}", self.names[c], sum / n)
            })
            .collect();
        format!("{}x{} image, channel means: {}", self.width, self.height, means.join(", "))
    }
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = Writer(out);
        w.u64(self.width as u64);
        w.u64(self.height as u64);
        w.u64(self.names.len() as u64);
        for n in &self.names {
            w.str(n);
        }
        w.f32s(&self.data);
    }
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let width = r.usize()?;
    let height = r.usize()?;
    let channels = r.usize()?;
    r.need(channels.saturating_mul(8))?;
    let names = (0..channels).map(|_| r.str()).collect::<Result<Vec<_>, _>>()?;
    let data = r.f32s()?;
    r.finish()?;
    if channels == 0 || width.checked_mul(height).and_then(|p| p.checked_mul(channels)) != Some(data.len()) {
        return Err("image dimensions do not match its data".into());
    }
    Ok(Value::new(Image::with_names(width, height, names, data)))
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

/// Encodes an image as a file of the given extension.
pub fn encode_image(img: &Image, o: &SaveOptions) -> Result<Vec<u8>, String> {
    let ext = o.ext.as_str();
    match ext {
        "png" => match o.get_or_default() {
            formats::png::PngFormat::Srgb8 => formats::png::encode(img, o.exposure),
            formats::png::PngFormat::Linear16 => formats::png::encode_linear16(img, o.exposure),
        }
        .map_err(|e| e.to_string()),
        "exr" => formats::exr::encode_with(img, &o.get_or_default()).map_err(|e| e.to_string()),
        "hdr" | "pfm" => {
            // RGBE and PFM hold RGB (PFM also grey): alpha and further channels are dropped
            // (`channels_not_kept` says which, and `Save` warns).
            let rgb = if img.channels > 3 || img.channels == 2 {
                crate::data::Image::from_fn_rgb(img.width, img.height, |x, y| img.rgb(x, y))
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

    #[test]
    fn round_trip_keeps_names_and_truncation_is_an_error() {
        let img = Image::with_names(
            2,
            1,
            vec!["R".into(), "G".into(), "B".into(), "A".into()],
            (0..8).map(|v| v as f32).collect(),
        );
        let mut bytes = Vec::new();
        img.encode(&mut bytes);
        let back = decode(&bytes).unwrap();
        assert_eq!(back.value_type(), ValueType(&IMAGE));
        assert_eq!(back.get::<Image>().unwrap(), &img);
        for cut in [0, 8, bytes.len() - 1] {
            let e = decode(&bytes[..cut]).unwrap_err();
            assert!(e.starts_with("truncated: need"), "cut at {cut}: {e}");
        }
        let y = Value::new(Image::new(2, 2, 1));
        assert_eq!(y.value_type(), ValueType(&SCALAR_FIELD));
    }

    /// Every format against every channel count: a channel the file does not hold is always
    /// announced by `channels_not_kept` (or the encoder refuses the image), so `Save` never
    /// loses one silently.
    #[test]
    fn no_format_loses_a_channel_silently() {
        use crate::data::image::default_names;
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
