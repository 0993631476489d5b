//! Tests of the RGBE reader and writer: round trips, hand-written scanlines, orientations,
//! hostile input, and agreement with the `image` crate.

use super::encode::max_rgbe_value;
use super::*;
use crate::values::Image;

/// xorshift64*: deterministic test data without a dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn random_image(w: usize, h: usize, seed: u64) -> Image {
    let mut rng = Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
    let data = (0..w * h * 3)
        .map(|_| if rng.unit() < 0.1 { 0.0 } else { (2f64.powf(rng.unit() * 60.0 - 30.0) * (0.5 + rng.unit())) as f32 })
        .collect();
    Image::from_vec(w, h, 3, data)
}

fn assert_close_rgbe(a: &Image, b: &Image) {
    assert_eq!((a.width, a.height, b.channels), (b.width, b.height, 3));
    for y in 0..a.height {
        for x in 0..a.width {
            let p = a.rgb(x, y);
            let q = b.rgb(x, y);
            let v = p[0].max(p[1]).max(p[2]) as f64;
            for k in 0..3 {
                let e = (p[k] as f64 - q[k] as f64).abs();
                assert!(e <= v / 128.0 * (1.0 + 1e-6) + 1e-30, "({x},{y})[{k}]: {} vs {}", p[k], q[k]);
            }
        }
    }
}

fn header(res: &str) -> Vec<u8> {
    format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n{res}\n").into_bytes()
}

#[test]
fn round_trip_various_widths() {
    for (i, &(w, h)) in [(1usize, 3usize), (7, 4), (8, 3), (300, 5), (40000, 1), (37, 2)].iter().enumerate() {
        let img = random_image(w, h, i as u64 + 1);
        let bytes = encode(&img);
        let back = decode(&bytes).unwrap_or_else(|e| panic!("{w}x{h}: {e}"));
        assert_close_rgbe(&img, &back);
    }
}

#[test]
fn rle_compresses_constant_rows_and_round_trips() {
    let img = Image::from_vec(1000, 2, 3, vec![0.75; 6000]);
    let bytes = encode(&img);
    // Header ~70 bytes + per row 4 + 4 planes x 8 runs of 127 x 2 bytes = 68.
    assert!(bytes.len() < 250, "{}", bytes.len());
    let back = decode(&bytes).unwrap();
    assert!(back.data.iter().all(|&v| v == 0.75));
}

#[test]
fn re_encoding_is_lossless() {
    let img = random_image(64, 8, 99);
    let once = decode(&encode(&img)).unwrap();
    let twice = decode(&encode(&once)).unwrap();
    assert_eq!(once, twice);
}

#[test]
fn special_values_and_grey() {
    let img = Image::from_vec(
        4,
        1,
        3,
        vec![
            f32::NAN,
            -1.0,
            1.0, //
            f32::INFINITY,
            0.0,
            0.0, //
            1e-40,
            0.0,
            0.0, //
            -0.0,
            2.0,
            4.0,
        ],
    );
    let back = decode(&encode(&img)).unwrap();
    assert_eq!(&back.data[0..3], &[0.0, 0.0, 1.0]);
    assert_eq!(back.data[3] as f64, max_rgbe_value());
    assert_eq!(&back.data[6..9], &[0.0, 0.0, 0.0]);
    assert_eq!(&back.data[9..12], &[0.0, 2.0, 4.0]);

    let grey = Image::from_vec(3, 1, 1, vec![0.5, 1.0, 8.0]);
    let back = decode(&encode(&grey)).unwrap();
    assert_eq!(back.channels, 3);
    assert_eq!(back.data, vec![0.5, 0.5, 0.5, 1.0, 1.0, 1.0, 8.0, 8.0, 8.0]);
}

#[test]
fn hand_written_flat_scanlines() {
    // 3x2, flat: E = 129 -> 2^(129-136) = 1/128, so byte 128 -> 1.0, 64 -> 0.5, 32 -> 0.25.
    let mut f = header("-Y 2 +X 3");
    for _ in 0..3 {
        f.extend_from_slice(&[128, 64, 32, 129]);
    }
    f.extend_from_slice(&[0, 0, 0, 0, 255, 255, 255, 136, 1, 2, 3, 0]);
    let img = decode(&f).unwrap();
    assert_eq!((img.width, img.height, img.channels), (3, 2, 3));
    assert_eq!(img.rgb(2, 0), [1.0, 0.5, 0.25]);
    assert_eq!(img.rgb(0, 1), [0.0, 0.0, 0.0]);
    assert_eq!(img.rgb(1, 1), [255.0, 255.0, 255.0]);
    assert_eq!(img.rgb(2, 1), [0.0, 0.0, 0.0]); // E = 0 -> 0 whatever the mantissas
}

#[test]
fn old_style_repeat_codes() {
    // Width 10: one pixel then "repeat 9".
    let mut f = header("-Y 1 +X 10");
    f.extend_from_slice(&[128, 0, 0, 129, 1, 1, 1, 9]);
    let img = decode(&f).unwrap();
    for x in 0..10 {
        assert_eq!(img.rgb(x, 0), [1.0, 0.0, 0.0]);
    }
    // Width 302: pixel, repeat 43, repeat 1 << 8 (consecutive: shift 8) = 300 pixels, then
    // a new pixel, then "repeat 1" (shift back to 0).
    let mut f = header("-Y 1 +X 302");
    f.extend_from_slice(&[64, 64, 64, 129, 1, 1, 1, 43, 1, 1, 1, 1, 128, 0, 0, 130, 1, 1, 1, 1]);
    let img = decode(&f).unwrap();
    for x in 0..300 {
        assert_eq!(img.rgb(x, 0), [0.5, 0.5, 0.5], "x = {x}");
    }
    assert_eq!(img.rgb(300, 0), [2.0, 0.0, 0.0]);
    assert_eq!(img.rgb(301, 0), [2.0, 0.0, 0.0]);
    // A repeat past the end of the row is an error naming the scanline.
    let mut f = header("-Y 1 +X 10");
    f.extend_from_slice(&[128, 0, 0, 129, 1, 1, 1, 10]);
    let e = decode(&f).unwrap_err().to_string();
    assert!(e.contains("scanline 0") && e.contains("past the end"), "{e}");
    // A repeat code first in a scanline has no previous pixel.
    let mut f = header("-Y 1 +X 10");
    f.extend_from_slice(&[1, 1, 1, 9, 0, 0, 0, 0]);
    let e = decode(&f).unwrap_err().to_string();
    assert_eq!(e, "scanline 0: old-style repeat code at the start of a scanline");
}

#[test]
fn messy_header_and_exposure() {
    let mut f = b"#?RADIANCE\n#?RADIANCE\n# Made with something\nGAMMA=1\nPRIMARIES=0 0 0 0 0 0 0 0\n\
EXPOSURE=2\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n"
        .to_vec();
    f.extend_from_slice(&[128, 128, 128, 129, 64, 0, 32, 129]);
    let img = decode(&f).unwrap();
    assert_eq!(img.data, vec![0.5, 0.5, 0.5, 0.25, 0.0, 0.125]);
    // Two EXPOSURE lines multiply: 2 * 4 = 8.
    let mut f = b"#?RGBE\nEXPOSURE=2\nEXPOSURE= 4.0\r\n\r\n-Y 1 +X 1\r\n".to_vec();
    f.extend_from_slice(&[128, 128, 128, 129]);
    assert_eq!(decode(&f).unwrap().data, vec![0.125, 0.125, 0.125]);
}

#[test]
fn xyze_and_bad_format_refused() {
    let mut f = b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n".to_vec();
    f.extend_from_slice(&[1, 2, 3, 4]);
    assert!(decode(&f).unwrap_err().to_string().contains("xyze"));
}

#[test]
fn orientations() {
    // 2x2: file pixels in file order a, b / c, d with values 1, 2 / 3, 4 (E = 129 -> /128).
    let px = |v: u8| [v * 32, v * 32, v * 32, 129];
    let body: Vec<u8> = [1u8, 2, 3, 4].iter().flat_map(|&v| px(v)).collect();
    let grey = |img: &Image| -> Vec<f32> { img.data.chunks(3).map(|p| p[0]).collect() };
    for (res, want) in [
        ("-Y 2 +X 2", vec![0.25, 0.5, 0.75, 1.0]),
        ("+Y 2 +X 2", vec![0.75, 1.0, 0.25, 0.5]),
        ("-Y 2 -X 2", vec![0.5, 0.25, 1.0, 0.75]),
        ("+Y 2 -X 2", vec![1.0, 0.75, 0.5, 0.25]),
    ] {
        let mut f = header(res);
        f.extend_from_slice(&body);
        assert_eq!(grey(&decode(&f).unwrap()), want, "{res}");
    }
    // +Y with an odd height and RLE rows.
    let img = random_image(9, 3, 5);
    let bytes = encode(&img);
    let flipped_file = {
        let at = bytes.windows(9).position(|w| w == b"-Y 3 +X 9").unwrap();
        let mut f = bytes.clone();
        f[at] = b'+';
        f
    };
    let a = decode(&bytes).unwrap();
    let b = decode(&flipped_file).unwrap();
    assert_eq!(a.flipped_vertical(), b);
    // Transposed layouts: 3 scanlines (columns) of 2 pixels, file order 1..6.
    let body: Vec<u8> = (1u8..=6).flat_map(px).collect();
    for (res, want) in [
        ("+X 3 -Y 2", [1, 3, 5, 2, 4, 6]),
        ("-X 3 -Y 2", [5, 3, 1, 6, 4, 2]),
        ("+X 3 +Y 2", [2, 4, 6, 1, 3, 5]),
        ("-X 3 +Y 2", [6, 4, 2, 5, 3, 1]),
    ] {
        let mut f = header(res);
        f.extend_from_slice(&body);
        let img = decode(&f).unwrap_or_else(|e| panic!("{res}: {e}"));
        assert_eq!((img.width, img.height), (3, 2), "{res}");
        assert_eq!(header_size(&f).unwrap(), (3, 2), "{res}");
        assert_eq!(grey(&img), want.map(|v| v as f32 / 4.0).to_vec(), "{res}");
    }
    // A transposed RLE file (scanlines of 9 pixels) is the standard one transposed.
    let bytes = encode(&random_image(9, 4, 6));
    let img = decode(&bytes).unwrap();
    let at = bytes.windows(9).position(|w| w == b"-Y 4 +X 9").unwrap();
    let mut f = bytes.clone();
    f[at..at + 9].copy_from_slice(b"+X 4 -Y 9");
    let t = decode(&f).unwrap();
    assert_eq!((t.width, t.height), (4, 9));
    for y in 0..4 {
        for x in 0..9 {
            assert_eq!(t.rgb(y, x), img.rgb(x, y));
        }
    }
}

#[test]
fn files_without_the_signature_line() {
    // Radiance before ~1991: no "#?RADIANCE", the header starts with a command line.
    let mut f = b"oconv -f scene.rad\n\tpfilt -x /2\nEXPOSURE=2\n\n-Y 1 +X 2\n".to_vec();
    f.extend_from_slice(&[128, 128, 128, 129, 64, 0, 32, 129]);
    assert_eq!(decode(&f).unwrap().data, vec![0.5, 0.5, 0.5, 0.25, 0.0, 0.125]);
    assert_eq!(header_size(&f).unwrap(), (2, 1));
    // Without the signature, a header that is not text ending in a resolution line is not a
    // Radiance file.
    for bad in [&b"oconv\n\x01\x02\n\n-Y 1 +X 1\n\x80\x80\x80\x81"[..], b"hello\n\nworld\n1234", b"\x89PNG\r\n\x1a\n"] {
        let e = decode(bad).unwrap_err().to_string();
        assert!(e.starts_with("not a Radiance file (bad magic"), "{e}");
    }
}

#[test]
fn bad_magic() {
    let e = decode(b"P6\n1 1\n255\n\0\0\0").unwrap_err().to_string();
    assert!(e.starts_with("not a Radiance file (bad magic"), "{e}");
    let e = decode(b"").unwrap_err().to_string();
    assert!(e.starts_with("not a Radiance file (bad magic"), "{e}");
}

#[test]
fn truncation_never_panics() {
    let bytes = encode(&random_image(20, 3, 7));
    for n in 0..bytes.len() {
        let e = decode(&bytes[..n]).unwrap_err().to_string();
        assert!(e.contains("truncated"), "prefix of {n} bytes: {e}");
    }
    let flat = encode(&random_image(5, 3, 8));
    for n in 0..flat.len() {
        let e = decode(&flat[..n]).unwrap_err().to_string();
        assert!(e.contains("truncated"), "prefix of {n} bytes: {e}");
    }
}

#[test]
fn garbage_after_a_valid_header_never_panics() {
    let mut rng = Rng(12345);
    for &(w, h) in &[(1usize, 1usize), (8, 2), (10, 3), (40, 2)] {
        for _ in 0..200 {
            let mut f = header(&format!("-Y {h} +X {w}"));
            let n = (rng.next() % 400) as usize;
            for i in 0..n {
                // Bias toward the interesting bytes (RLE markers and repeat codes).
                let b = match rng.next() % 4 {
                    0 => [1u8, 2, 128, 255][(rng.next() % 4) as usize],
                    _ => rng.next() as u8,
                };
                f.push(if i < 2 && w >= 8 && rng.next().is_multiple_of(2) { 2 } else { b });
            }
            let _ = decode(&f);
        }
    }
}

#[test]
fn huge_header_fails_fast() {
    let mut f = header("-Y 200000 +X 200000");
    f.extend_from_slice(&[0u8; 100]);
    let t = std::time::Instant::now();
    let e = decode(&f).unwrap_err().to_string();
    assert_eq!(e, "image too large: 200000x200000 pixels (limit 268435456)");
    // Within MAX_PIXELS but far more than 100 bytes could encode: the lower bound catches it.
    let mut f = header("-Y 10000 +X 10000");
    f.extend_from_slice(&[0u8; 100]);
    let e = decode(&f).unwrap_err().to_string();
    assert!(e.starts_with("truncated: header claims 10000x10000 pixels but only 100 bytes follow"), "{e}");
    assert!(t.elapsed().as_millis() < 500);
    let mut f = header("-Y 0 +X 5");
    f.extend_from_slice(&[0u8; 100]);
    assert_eq!(decode(&f).unwrap_err().to_string(), "empty image: header claims 5x0 pixels");
}

#[test]
fn rle_run_past_end_of_row() {
    let mut f = header("-Y 1 +X 8");
    f.extend_from_slice(&[2, 2, 0, 8, 128 + 9, 7]);
    f.extend_from_slice(&[0u8; 40]);
    let e = decode(&f).unwrap_err().to_string();
    assert!(e.contains("scanline 0") && e.contains("past the end"), "{e}");
    // Literal past the end, and a zero count.
    let mut f = header("-Y 1 +X 8");
    f.extend_from_slice(&[2, 2, 0, 8, 4, 1, 2, 3, 4, 5, 1, 2, 3, 4, 5]);
    f.extend_from_slice(&[0u8; 40]);
    assert!(decode(&f).unwrap_err().to_string().contains("past the end"));
    let mut f = header("-Y 1 +X 8");
    f.extend_from_slice(&[2, 2, 0, 8, 0]);
    f.extend_from_slice(&[0u8; 40]);
    assert!(decode(&f).unwrap_err().to_string().contains("count 0"));
    // Encoded width disagrees with the header.
    let mut f = header("-Y 1 +X 8");
    f.extend_from_slice(&[2, 2, 0, 9]);
    f.extend_from_slice(&[0u8; 40]);
    let e = decode(&f).unwrap_err().to_string();
    assert_eq!(e, "scanline 0: RLE scanline length 9 does not match the image width 8");
}

#[test]
fn matches_image_crate_on_real_files() {
    // Each map from assets/maps/ when it ships there, else from ../shared/data/envmaps/.
    for name in [
        "grace-new_256x128.hdr",
        "st_fagans_interior_1k.hdr",
        "rooitou_park_1k.hdr",
        "studio_small_03_1k.hdr",
        "grace_probe.hdr",
    ] {
        let path = crate::test_skip::real_map(name);
        let Ok(bytes) = std::fs::read(&path) else {
            crate::test_skip::skip_missing_data(&format!("{} is missing", path.display()));
            continue;
        };
        let ours = decode(&bytes).unwrap_or_else(|e| panic!("{name}: {e}"));
        let theirs = image::load_from_memory_with_format(&bytes, image::ImageFormat::Hdr).unwrap().to_rgb32f();
        assert_eq!((ours.width, ours.height), (theirs.width() as usize, theirs.height() as usize));
        let raw = theirs.into_raw();
        assert_eq!(ours.data.len(), raw.len());
        for (i, (a, b)) in ours.data.iter().zip(&raw).enumerate() {
            assert!(a.to_bits() == b.to_bits(), "{name}: sample {i}: {a} vs {b}");
        }
        if name == "grace-new_256x128.hdr" {
            assert_eq!((ours.width, ours.height), (256, 128));
            // Decoding -> encoding -> decoding is exact (m * 2^(E-136) re-encodes to itself).
            assert_eq!(decode(&encode(&ours)).unwrap(), ours);
        }
    }
}
