//! EXIF through `kamadak-exif` (imported as `exif`): reading a photograph's camera settings
//! ([`read`]) and writing the block that carries a frame's exposure time ([`block`]).
//!
//! A block is a TIFF structure (`II*\0`, IFD 0, an Exif sub-IFD), what PNG's `eXIf` chunk holds
//! and what JPEG's APP1 segment holds after `Exif\0\0`. The exposure time is the rational
//! ExposureTime (tag 0x829A): [`rational`] finds the closest fraction with 32-bit terms by
//! continued fractions, so the times photographers use (`1/250`, `1/3`, `0.016 = 2/125`, `30`)
//! read back as the same f64.

use std::io::Cursor;

use ::exif::{Field, In, Rational, Reader, Tag, Value};

use crate::values::Exif;

/// The settings in the EXIF block of a PNG, JPEG or TIFF file's bytes; a field absent, of an
/// unexpected type or not a positive finite number is `None`, and a missing or broken block
/// gives no settings at all (the fields read before the damage are kept).
pub fn read(bytes: &[u8]) -> Exif {
    let parsed = match Reader::new().continue_on_error(true).read_from_container(&mut Cursor::new(bytes)) {
        Ok(e) => e,
        Err(::exif::Error::PartialResult(partial)) => partial.into_inner().0,
        Err(_) => return Exif::default(),
    };
    let field = |tag: Tag| parsed.get_field(tag, In::PRIMARY).map(|f| &f.value);
    let positive = |v: f64| (v.is_finite() && v > 0.0).then_some(v);
    let number = |tag: Tag| match field(tag)? {
        Value::Rational(r) => r.first().map(Rational::to_f64).and_then(positive),
        Value::SRational(r) => r.first().map(|r| r.to_f64()).and_then(positive),
        v => v.get_uint(0).map(f64::from).and_then(positive),
    };
    let text = |tag: Tag| match field(tag)? {
        Value::Ascii(parts) => {
            let s = String::from_utf8_lossy(parts.first()?);
            let s = s.trim_matches(|c: char| c == '\0' || c.is_whitespace());
            (!s.is_empty()).then(|| s.to_string())
        }
        _ => None,
    };
    Exif {
        exposure_time: number(Tag::ExposureTime),
        f_number: number(Tag::FNumber),
        iso: number(Tag::PhotographicSensitivity),
        make: text(Tag::Make),
        model: text(Tag::Model),
    }
}

/// The closest fraction p/q to `t` (> 0) with p and q within 32 bits: the last continued-fraction
/// convergent that fits, stopping once it equals `t` to the last bit of an f64.
pub fn rational(t: f64) -> Option<Rational> {
    if !(t.is_finite() && t > 0.0 && t <= u32::MAX as f64) {
        return None;
    }
    // Convergents h_k / k_k with h_k = a_k h_{k-1} + h_{k-2}, from h_{-1} = 1, h_{-2} = 0 (k: 0, 1).
    let (mut h0, mut h1, mut k0, mut k1) = (0u128, 1u128, 1u128, 0u128);
    let mut x = t;
    let mut best = None;
    for _ in 0..64 {
        let a = x.floor();
        let (h, k) = (a as u128 * h1 + h0, a as u128 * k1 + k0);
        if h > u32::MAX as u128 || k > u32::MAX as u128 {
            break;
        }
        if h > 0 {
            best = Some(Rational { num: h as u32, denom: k as u32 });
            if h as f64 / k as f64 == t {
                break;
            }
        }
        let frac = x - a;
        if frac <= 0.0 {
            break;
        }
        x = 1.0 / frac;
        (h0, h1, k0, k1) = (h1, h, k1, k);
    }
    best
}

/// The ExposureTime field of `time` seconds, or why it cannot be written.
pub fn exposure_field(time: f64) -> Result<Field, String> {
    let r = rational(time).ok_or_else(|| format!("exposure time {time} s cannot be written as EXIF"))?;
    Ok(Field { tag: Tag::ExposureTime, ifd_num: In::PRIMARY, value: Value::Rational(vec![r]) })
}

/// An EXIF block (a little-endian TIFF structure) holding only the ExposureTime of `time` seconds.
pub fn block(time: f64) -> Result<Vec<u8>, String> {
    let field = exposure_field(time)?;
    let mut writer = ::exif::experimental::Writer::new();
    writer.push_field(&field);
    let mut out = Cursor::new(Vec::new());
    writer.write(&mut out, true).map_err(|e| format!("writing EXIF: {e}"))?;
    Ok(out.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn photographers_times_are_exact_fractions() {
        for (t, num, denom) in [(1.0 / 250.0, 1, 250), (1.0 / 3.0, 1, 3), (0.016, 2, 125), (30.0, 30, 1), (2.5, 5, 2)] {
            let r = rational(t).unwrap();
            assert_eq!((r.num, r.denom), (num, denom), "{t}");
            assert_eq!(r.to_f64(), t);
        }
        // Not a small fraction: the closest one within 32 bits, to about 1e-18 relative.
        let t = std::f64::consts::PI / 1000.0;
        assert!((rational(t).unwrap().to_f64() / t - 1.0).abs() < 1e-15);
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e10] {
            assert!(rational(bad).is_none(), "{bad}");
        }
    }

    #[test]
    fn a_written_block_reads_back_and_garbage_reads_as_nothing() {
        let b = block(1.0 / 4000.0).unwrap();
        assert!(b.starts_with(b"II*\0"));
        let e = Reader::new().read_raw(b).unwrap();
        let f = e.get_field(Tag::ExposureTime, In::PRIMARY).unwrap();
        let Value::Rational(r) = &f.value else { panic!("{:?}", f.value) };
        assert_eq!((r.len(), r[0].num, r[0].denom), (1, 1, 4000));
        assert_eq!(read(b"not an image at all"), Exif::default());
        assert_eq!(read(&[]), Exif::default());
    }
}
