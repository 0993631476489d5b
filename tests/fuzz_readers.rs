//! Hostile-input properties for the file readers and the pipeline parser: whatever the bytes,
//! `formats::rgbe::decode`, `formats::pfm::decode`, `formats::exr::decode` and
//! `engine::graph::Pipeline::parse` return `Ok` or `Err`, and never panic.
//!
//! Every call runs under `std::panic::catch_unwind`; a panic fails the property with the input
//! that caused it (proptest then shrinks it). Inputs come from four families:
//! - arbitrary bytes / strings;
//! - structured files whose header fields are drawn from "interesting" values (0, 1, widths
//!   around the RLE limits 8 and 32767, `MAX_PIXELS` = 2^28 and 2^28 + 1, 2^32, `u64::MAX`,
//!   more digits than any integer type, NaN, inf, negative numbers) followed by payloads biased
//!   towards the codecs' control bytes (`02 02` RLE markers, run counts, `1 1 1 n` repeat codes);
//! - valid files (a random small image encoded by our own writers) with byte flips, overwrites,
//!   truncations, insertions, deletions and duplications, and with header numbers replaced by
//!   huge values (for EXR: attribute sizes, `dataWindow` corners, offset-table entries and
//!   version flags);
//! - for the parser: random RON-like token soup, mutations of `graphs/example.ron` and
//!   `graphs/seed.ron`, deep nesting around the parser's `MAX_DEPTH`, and random `--set`
//!   overrides.
//!
//! The case counts are sized so that the whole file runs in well under 30 s in a dev build
//! (dependencies optimised). To fuzz for longer outside CI, set `HDRFLOW_FUZZ_CASES` to the
//! number of cases *per property*, e.g.
//!
//! ```text
//! HDRFLOW_FUZZ_CASES=200000 cargo test --release --test fuzz_readers
//! ```
//!
//! For coverage-guided fuzzing, see `fuzz/` (cargo-fuzz targets for the same four entry points).
//!
//! Crashes found by this file are kept below as `regression_*` tests with the input inline.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;
use std::sync::OnceLock;

use hdrflow::engine::graph::{Override, Pipeline};
use hdrflow::formats::{exr, pfm, rgbe, FormatError};
use hdrflow::values::Image;
use hdrflow::Registry;
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

// -------------------------------------------------------------------------------------------------
// Harness
// -------------------------------------------------------------------------------------------------

/// Cases per property: `HDRFLOW_FUZZ_CASES` if set (and a positive integer), else `ci`.
fn cases(ci: u32) -> u32 {
    std::env::var("HDRFLOW_FUZZ_CASES").ok().and_then(|s| s.trim().parse().ok()).filter(|&n| n > 0).unwrap_or(ci)
}

/// A proptest configuration with `cases(ci)` cases and no regression files written into the
/// source tree (crashes are kept as the `regression_*` tests below instead).
fn config(ci: u32) -> ProptestConfig {
    ProptestConfig { cases: cases(ci), failure_persistence: None, max_shrink_iters: 4096, ..ProptestConfig::default() }
}

fn registry() -> &'static Registry {
    static R: OnceLock<Registry> = OnceLock::new();
    R.get_or_init(hdrflow::builtin_registry)
}

/// Records, per thread, the largest single allocation request, so that a test can check that a
/// decoder does not allocate in proportion to a size it was merely *told* (see
/// `regression_rgbe_truncated_wide_row_allocates_the_whole_row`). Otherwise the system allocator.
struct TrackLargest;

thread_local! {
    static LARGEST_ALLOCATION: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

fn note_allocation(size: usize) {
    let _ = LARGEST_ALLOCATION.try_with(|m| m.set(m.get().max(size)));
}

// SAFETY: every call is forwarded unchanged to the system allocator; the bookkeeping touches only
// a const-initialised thread-local `Cell<usize>` (no allocation, no destructor).
unsafe impl std::alloc::GlobalAlloc for TrackLargest {
    unsafe fn alloc(&self, layout: std::alloc::Layout) -> *mut u8 {
        note_allocation(layout.size());
        std::alloc::System.alloc(layout)
    }
    unsafe fn alloc_zeroed(&self, layout: std::alloc::Layout) -> *mut u8 {
        note_allocation(layout.size());
        std::alloc::System.alloc_zeroed(layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: std::alloc::Layout, new_size: usize) -> *mut u8 {
        note_allocation(new_size);
        std::alloc::System.realloc(ptr, layout, new_size)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: std::alloc::Layout) {
        std::alloc::System.dealloc(ptr, layout)
    }
}

#[global_allocator]
static ALLOCATOR: TrackLargest = TrackLargest;

/// Runs `f` and returns its result with the largest single allocation it made on this thread.
fn largest_allocation_of<T>(f: impl FnOnce() -> T) -> (T, usize) {
    LARGEST_ALLOCATION.with(|m| m.set(0));
    let r = f();
    (r, LARGEST_ALLOCATION.with(|m| m.get()))
}

/// Known bug, kept visible by `regression_rgbe_truncated_wide_row_allocates_the_whole_row`: a
/// Radiance header claiming a very wide row makes `rgbe::decode` allocate (and zero) the whole
/// row, up to 3 GiB, before it finds the data truncated. The properties skip such headers (width
/// above 2^22 and at most 2^28 pixels in all) so that one unlucky case cannot cost seconds and
/// gigabytes in CI; remove this filter once the decoder allocates rows as it decodes them.
fn rgbe_claims_huge_row(bytes: &[u8]) -> bool {
    let head = &bytes[..bytes.len().min(4096)];
    head.split(|&b| b == b'\n').any(|line| {
        let Ok(text) = std::str::from_utf8(line) else { return false };
        let t: Vec<&str> = text.split_ascii_whitespace().collect();
        if t.len() != 4 {
            return false;
        }
        match (t[1].parse::<u64>(), t[3].parse::<u64>()) {
            (Ok(h), Ok(w)) => w > 1 << 22 && h.checked_mul(w).is_some_and(|p| p <= 1 << 28),
            _ => false,
        }
    })
}

/// Known bug, kept visible by `regression_rgbe_small_exposure_gives_nan_and_inf`: an `EXPOSURE`
/// product below 2^-8 overflows the exponent table to +Inf, so mantissa 0 gives NaN. Outputs of
/// headers with an `EXPOSURE=` line are not checked for finiteness by the properties.
fn rgbe_has_exposure(bytes: &[u8]) -> bool {
    bytes.windows(9).any(|w| w == b"EXPOSURE=")
}

/// RGBE can represent neither negatives nor NaN nor infinities: a decoded image must not hold any.
fn check_rgbe_values(img: &Image, bytes: &[u8]) -> Result<(), TestCaseError> {
    if let Some(v) = img.data.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
        return Err(TestCaseError::fail(format!("rgbe::decode produced {v} from {}", show(bytes))));
    }
    Ok(())
}

fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "non-string panic payload".to_string()
    }
}

/// A short printable rendering of an input for failure messages: a Rust byte-string literal of
/// at most 512 bytes.
fn show(bytes: &[u8]) -> String {
    let head: String = bytes.iter().take(512).flat_map(|b| std::ascii::escape_default(*b)).map(char::from).collect();
    if bytes.len() > 512 {
        format!("b\"{head}\"... ({} bytes)", bytes.len())
    } else {
        format!("b\"{head}\"")
    }
}

/// Runs a decoder on `bytes` under `catch_unwind`: its result, or a test failure naming the input
/// on a panic, a malformed image, or a panic of the `exr` crate that the EXR reader caught
/// ([`FormatError::DecoderPanicked`], rejected as the fuzz target rejects it).
fn decode_no_panic(
    name: &str,
    decode: fn(&[u8]) -> Result<Image, FormatError>,
    bytes: &[u8],
) -> Result<Result<Image, FormatError>, TestCaseError> {
    match catch_unwind(AssertUnwindSafe(|| decode(bytes))) {
        Ok(r) => {
            if let Ok(img) = &r {
                // A successful decode must be a well-formed image.
                if img.width == 0 || img.height == 0 || !(img.channels == 1 || img.channels == 3) {
                    return Err(TestCaseError::fail(format!(
                        "{name} returned a malformed {}x{}x{} image for {}",
                        img.width,
                        img.height,
                        img.channels,
                        show(bytes)
                    )));
                }
                if img.data.len() != img.width * img.height * img.channels {
                    return Err(TestCaseError::fail(format!(
                        "{name} returned {} samples for {}x{}x{} on {}",
                        img.data.len(),
                        img.width,
                        img.height,
                        img.channels,
                        show(bytes)
                    )));
                }
            }
            if let Err(e @ FormatError::DecoderPanicked(_)) = &r {
                return Err(TestCaseError::fail(format!("{name}: {e} on {}", show(bytes))));
            }
            Ok(r)
        }
        Err(p) => Err(TestCaseError::fail(format!("{name} panicked ({}) on {}", panic_text(&*p), show(bytes)))),
    }
}

/// `Pipeline::parse` under `catch_unwind`; a panic is a test failure naming the text.
fn parse_no_panic(text: &str, overrides: &[Override]) -> Result<bool, TestCaseError> {
    match catch_unwind(AssertUnwindSafe(|| {
        Pipeline::parse(text, "fuzz.ron", Path::new("."), registry(), overrides).is_ok()
    })) {
        Ok(ok) => Ok(ok),
        Err(p) => Err(TestCaseError::fail(format!(
            "Pipeline::parse panicked ({}) on {:?} with overrides {:?}",
            panic_text(&*p),
            text,
            overrides
        ))),
    }
}

// -------------------------------------------------------------------------------------------------
// Valid images and mutations
// -------------------------------------------------------------------------------------------------

/// A deterministic stream (SplitMix64), so that an image is a function of its seed.
struct Mix(u64);
impl Mix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A small image with values from a mix of the ordinary and the hostile: zeros, sky-like values,
/// suns past the half-float maximum, 1e30, f32::MAX, subnormals, negatives, NaN, +-Inf.
fn image_from(w: usize, h: usize, c: usize, seed: u64) -> Image {
    let mut r = Mix(seed);
    let data = (0..w * h * c)
        .map(|_| match r.next() % 16 {
            0 => 0.0,
            1 => 69120.0,
            2 => 1e30,
            3 => f32::MAX,
            4 => 1e-40,
            5 => -1.0,
            6 => f32::NAN,
            7 => f32::INFINITY,
            8 => f32::NEG_INFINITY,
            _ => (r.unit() * 4.0) as f32,
        })
        .collect();
    Image::from_vec(w, h, c, data)
}

fn small_image() -> impl Strategy<Value = Image> {
    (1usize..40, 1usize..12, prop_oneof![Just(1usize), Just(3usize)], any::<u64>())
        .prop_map(|(w, h, c, seed)| image_from(w, h, c, seed))
}

#[derive(Clone, Debug)]
enum Mutation {
    Flip { at: usize, mask: u8 },
    Set { at: usize, byte: u8 },
    Truncate { at: usize },
    Insert { at: usize, bytes: Vec<u8> },
    Delete { at: usize, len: usize },
    Duplicate { at: usize, len: usize },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        4 => (any::<usize>(), 1u8..=255).prop_map(|(at, mask)| Mutation::Flip { at, mask }),
        3 => (any::<usize>(), prop_oneof![Just(0u8), Just(1), Just(2), Just(0x7f), Just(0x80), Just(0x81), Just(0xff), any::<u8>()])
            .prop_map(|(at, byte)| Mutation::Set { at, byte }),
        1 => any::<usize>().prop_map(|at| Mutation::Truncate { at }),
        2 => (any::<usize>(), prop::collection::vec(any::<u8>(), 1..16)).prop_map(|(at, bytes)| Mutation::Insert { at, bytes }),
        1 => (any::<usize>(), 1usize..32).prop_map(|(at, len)| Mutation::Delete { at, len }),
        1 => (any::<usize>(), 1usize..64).prop_map(|(at, len)| Mutation::Duplicate { at, len }),
    ]
}

fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    let n = bytes.len();
    match m {
        Mutation::Flip { at, mask } if n > 0 => bytes[at % n] ^= mask,
        Mutation::Set { at, byte } if n > 0 => bytes[at % n] = *byte,
        Mutation::Truncate { at } => bytes.truncate(at % (n + 1)),
        Mutation::Insert { at, bytes: ins } => {
            let at = at % (n + 1);
            bytes.splice(at..at, ins.iter().copied());
        }
        Mutation::Delete { at, len } if n > 0 => {
            let at = at % n;
            let end = (at + len).min(n);
            bytes.drain(at..end);
        }
        Mutation::Duplicate { at, len } if n > 0 => {
            let at = at % n;
            let end = (at + len).min(n);
            let copy: Vec<u8> = bytes[at..end].to_vec();
            bytes.splice(at..at, copy);
        }
        _ => {}
    }
}

/// Positions of the first byte of a mutation: biased towards the header (first 64 bytes).
fn mutations() -> impl Strategy<Value = Vec<Mutation>> {
    prop::collection::vec(mutation(), 1..6)
}

/// Integers that stress header parsing and size arithmetic, as text.
fn interesting_number() -> impl Strategy<Value = String> {
    prop_oneof![
        prop::sample::select(vec![
            "0",
            "1",
            "-1",
            "-0",
            "+5",
            "2",
            "7",
            "8",
            "9",
            "127",
            "128",
            "255",
            "256",
            "32767",
            "32768",
            "65535",
            "65536",
            "16384",
            "16385",
            "268435456",
            "268435457",
            "134217728",
            "2147483647",
            "2147483648",
            "4294967295",
            "4294967296",
            "9223372036854775807",
            "18446744073709551615",
            "18446744073709551616",
            "99999999999999999999999999999999",
            "1e9",
            "1.5",
            "NaN",
            "inf",
            "-inf",
            "0x10",
            "",
            " ",
            "00000000000000000000000001",
        ])
        .prop_map(str::to_string),
        (0u32..70).prop_map(|v| v.to_string()),
        any::<u64>().prop_map(|v| v.to_string()),
    ]
}

/// Replaces the `k`-th run of ASCII digits that starts within the first `header_len` bytes.
fn replace_header_number(bytes: &mut Vec<u8>, header_len: usize, k: usize, with: &str) {
    let limit = header_len.min(bytes.len());
    let mut runs = Vec::new();
    let mut i = 0;
    while i < limit {
        if bytes[i].is_ascii_digit() {
            let start = i;
            while i < bytes.len() && bytes[i].is_ascii_digit() {
                i += 1;
            }
            runs.push((start, i));
        } else {
            i += 1;
        }
    }
    if runs.is_empty() {
        return;
    }
    let (s, e) = runs[k % runs.len()];
    bytes.splice(s..e, with.bytes());
}

/// Length of a PFM header (three whitespace-separated tokens after the magic, plus one byte).
fn pfm_header_len(bytes: &[u8]) -> usize {
    let mut tokens = 0;
    let mut i = 2;
    while i < bytes.len() && tokens < 3 {
        while i < bytes.len() && bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        while i < bytes.len() && !bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        tokens += 1;
    }
    i + 1
}

/// Length of a Radiance header up to and including the resolution line.
fn rgbe_header_len(bytes: &[u8]) -> usize {
    bytes.windows(2).position(|w| w == b"\n\n").map_or(bytes.len(), |p| {
        let rest = &bytes[p + 2..];
        p + 2 + rest.iter().position(|&b| b == b'\n').map_or(rest.len(), |q| q + 1)
    })
}

// -------------------------------------------------------------------------------------------------
// Structured hostile files
// -------------------------------------------------------------------------------------------------

/// Payload bytes biased towards the RGBE codecs' control values.
fn rgbe_payload() -> impl Strategy<Value = Vec<u8>> {
    prop::collection::vec(
        prop_oneof![
            3 => any::<u8>().prop_map(|b| vec![b]),
            1 => (0u8..128, any::<u8>()).prop_map(|(hi, lo)| vec![2, 2, hi, lo]),
            1 => any::<u8>().prop_map(|n| vec![1, 1, 1, n]),
            1 => (129u8..=255, any::<u8>()).prop_map(|(c, v)| vec![c, v]),
            1 => (1u8..=128).prop_map(|c| vec![c]),
            1 => Just(vec![0u8]),
        ],
        0..200,
    )
    .prop_map(|chunks| chunks.concat())
}

fn rgbe_structured() -> impl Strategy<Value = Vec<u8>> {
    let magic = prop::sample::select(vec!["#?RADIANCE", "#?RGBE", "#?RADIANCE\r", "#?RADIANCEjunk", "#?RGB"]);
    let line = prop_oneof![
        Just("FORMAT=32-bit_rle_rgbe".to_string()),
        Just("FORMAT=32-bit_rle_xyze".to_string()),
        Just("FORMAT=".to_string()),
        interesting_number().prop_map(|n| format!("EXPOSURE={n}")),
        Just("EXPOSURE=1e308".to_string()),
        Just("EXPOSURE=1e-308".to_string()),
        Just("# comment".to_string()),
        Just("#?RADIANCE".to_string()),
        Just("GAMMA=2.2".to_string()),
        "[ -~]{0,20}",
    ];
    let axis = prop::sample::select(vec!["-Y", "+Y", "-X", "+X", "Y", "-Z", "--Y"]);
    let resolution = (axis.clone(), interesting_number(), axis, interesting_number())
        .prop_map(|(a, n1, b, n2)| format!("{a} {n1} {b} {n2}"));
    (magic, prop::collection::vec(line, 0..4), any::<bool>(), resolution, rgbe_payload()).prop_map(
        |(magic, lines, blank, res, payload)| {
            let mut s = format!("{magic}\n");
            for l in lines {
                s.push_str(&l);
                s.push('\n');
            }
            if blank {
                s.push('\n');
            }
            s.push_str(&res);
            s.push('\n');
            let mut bytes = s.into_bytes();
            bytes.extend_from_slice(&payload);
            bytes
        },
    )
}

fn pfm_structured() -> impl Strategy<Value = Vec<u8>> {
    let magic = prop::sample::select(vec!["PF", "Pf", "PF\r", "PF5", "pf"]);
    let sep = prop::sample::select(vec!["\n", " ", "\t", "\r\n", "\n\n", ""]);
    let scale = prop_oneof![
        prop::sample::select(vec![
            "-1.0", "1.0", "-1", "4.0", "0", "-0.0", "NaN", "inf", "-inf", "1e400", "-1e-400", "x"
        ])
        .prop_map(str::to_string),
        interesting_number(),
    ];
    (
        magic,
        sep.clone(),
        interesting_number(),
        sep.clone(),
        interesting_number(),
        sep.clone(),
        scale,
        sep,
        0usize..300,
        any::<u8>(),
    )
        .prop_map(|(m, s1, w, s2, h, s3, scale, s4, payload_len, fill)| {
            let mut bytes = format!("{m}{s1}{w}{s2}{h}{s3}{scale}{s4}").into_bytes();
            bytes.resize(bytes.len() + payload_len, fill);
            bytes
        })
}

/// EXR header attributes whose values decide sizes and layout.
const EXR_ATTRIBUTES: &[&[u8]] = &[
    b"channels\0chlist\0",
    b"compression\0compression\0",
    b"dataWindow\0box2i\0",
    b"displayWindow\0box2i\0",
    b"lineOrder\0lineOrder\0",
    b"pixelAspectRatio\0float\0",
    b"screenWindowCenter\0v2f\0",
    b"screenWindowWidth\0float\0",
];

#[derive(Clone, Debug)]
enum ExrEdit {
    /// Overwrite the 4-byte size of attribute `attr`.
    AttrSize { attr: usize, value: i32 },
    /// Overwrite 4-byte word `word` of attribute `attr`'s value.
    AttrWord { attr: usize, word: usize, value: i32 },
    /// Overwrite the `k`-th 8-byte entry after the header's end (the offset table).
    Offset { k: usize, value: u64 },
    /// XOR the version/flags word (bytes 4..8: version 2, tiled 0x200, long names 0x400,
    /// non-image 0x800, multipart 0x1000).
    Flags { xor: u32 },
}

fn interesting_i32() -> impl Strategy<Value = i32> {
    prop_oneof![
        prop::sample::select(vec![
            0,
            1,
            -1,
            2,
            3,
            4,
            15,
            16,
            255,
            65535,
            65536,
            16383,
            16384,
            1 << 20,
            1 << 28,
            i32::MAX,
            i32::MIN,
            i32::MAX - 1,
            -(1 << 20)
        ]),
        any::<i32>(),
    ]
}

fn exr_edit() -> impl Strategy<Value = ExrEdit> {
    prop_oneof![
        1 => (0..EXR_ATTRIBUTES.len(), interesting_i32()).prop_map(|(attr, value)| ExrEdit::AttrSize { attr, value }),
        3 => (0..EXR_ATTRIBUTES.len(), 0usize..8, interesting_i32()).prop_map(|(attr, word, value)| ExrEdit::AttrWord { attr, word, value }),
        1 => (0usize..8, prop_oneof![Just(0u64), Just(1), Just(u64::MAX), Just(1 << 40), Just(i64::MAX as u64), any::<u64>()])
            .prop_map(|(k, value)| ExrEdit::Offset { k, value }),
        1 => prop::sample::select(vec![0x200u32, 0x400, 0x800, 0x1000, 0x1, 0xff, 0x1800, 0x600]).prop_map(|xor| ExrEdit::Flags { xor }),
    ]
}

fn apply_exr(bytes: &mut [u8], e: &ExrEdit) {
    let find = |bytes: &[u8], key: &[u8]| bytes.windows(key.len()).position(|w| w == key).map(|p| p + key.len());
    match *e {
        ExrEdit::AttrSize { attr, value } => {
            if let Some(at) = find(bytes, EXR_ATTRIBUTES[attr]) {
                if at + 4 <= bytes.len() {
                    bytes[at..at + 4].copy_from_slice(&value.to_le_bytes());
                }
            }
        }
        ExrEdit::AttrWord { attr, word, value } => {
            if let Some(at) = find(bytes, EXR_ATTRIBUTES[attr]) {
                let at = at + 4 + 4 * word;
                if at + 4 <= bytes.len() {
                    bytes[at..at + 4].copy_from_slice(&value.to_le_bytes());
                }
            }
        }
        ExrEdit::Offset { k, value } => {
            // The header ends with a null byte after the last attribute; our writer's last
            // attribute is screenWindowWidth (a 4-byte float).
            if let Some(at) = find(bytes, EXR_ATTRIBUTES[7]) {
                let at = at + 4 + 4 + 1 + 8 * k;
                if at + 8 <= bytes.len() {
                    bytes[at..at + 8].copy_from_slice(&value.to_le_bytes());
                }
            }
        }
        ExrEdit::Flags { xor } => {
            if bytes.len() >= 8 {
                let v = u32::from_le_bytes([bytes[4], bytes[5], bytes[6], bytes[7]]) ^ xor;
                bytes[4..8].copy_from_slice(&v.to_le_bytes());
            }
        }
    }
}

// -------------------------------------------------------------------------------------------------
// Reader properties
// -------------------------------------------------------------------------------------------------

proptest! {
    #![proptest_config(config(4000))]

    #[test]
    fn rgbe_arbitrary_bytes(bytes in prop::collection::vec(any::<u8>(), 0..1024)) {
        let _ = decode_no_panic("rgbe::decode", rgbe::decode, &bytes)?;
        // The same bytes behind a valid magic line, so that the header parser is exercised.
        let mut with_magic = b"#?RADIANCE\n".to_vec();
        with_magic.extend_from_slice(&bytes);
        if rgbe_claims_huge_row(&with_magic) {
            return Ok(());
        }
        let _ = decode_no_panic("rgbe::decode", rgbe::decode, &with_magic)?;
    }

    #[test]
    fn pfm_arbitrary_bytes(bytes in prop::collection::vec(any::<u8>(), 0..1024)) {
        let _ = decode_no_panic("pfm::decode", pfm::decode, &bytes)?;
        let mut with_magic = b"PF\n".to_vec();
        with_magic.extend_from_slice(&bytes);
        let _ = decode_no_panic("pfm::decode", pfm::decode, &with_magic)?;
    }

    #[test]
    fn exr_arbitrary_bytes(bytes in prop::collection::vec(any::<u8>(), 0..1024)) {
        let _ = decode_no_panic("exr::decode", exr::decode, &bytes)?;
        // Behind the EXR magic number and a version-2 scanline flags word.
        let mut with_magic = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
        with_magic.extend_from_slice(&bytes);
        let _ = decode_no_panic("exr::decode", exr::decode, &with_magic)?;
    }

    #[test]
    fn rgbe_structured_headers(bytes in rgbe_structured()) {
        if rgbe_claims_huge_row(&bytes) {
            return Ok(());
        }
        if let Ok(img) = decode_no_panic("rgbe::decode", rgbe::decode, &bytes)? {
            if !rgbe_has_exposure(&bytes) {
                check_rgbe_values(&img, &bytes)?;
            }
        }
    }

    #[test]
    fn pfm_structured_headers(bytes in pfm_structured()) {
        let _ = decode_no_panic("pfm::decode", pfm::decode, &bytes)?;
    }
}

proptest! {
    #![proptest_config(config(3000))]

    #[test]
    fn rgbe_mutated_valid_files(img in small_image(), ms in mutations(), number in interesting_number(), k in any::<usize>(), edit_header in any::<bool>()) {
        let mut bytes = rgbe::encode(&img);
        // The unmutated file decodes.
        let clean = decode_no_panic("rgbe::decode", rgbe::decode, &bytes)?;
        prop_assert!(clean.is_ok(), "our own RGBE file does not decode: {:?}", clean.err());
        if edit_header {
            let hl = rgbe_header_len(&bytes);
            replace_header_number(&mut bytes, hl, k, &number);
        }
        for m in &ms {
            apply(&mut bytes, m);
        }
        if rgbe_claims_huge_row(&bytes) {
            return Ok(());
        }
        if let Ok(img) = decode_no_panic("rgbe::decode", rgbe::decode, &bytes)? {
            if !rgbe_has_exposure(&bytes) {
                check_rgbe_values(&img, &bytes)?;
            }
        }
    }

    #[test]
    fn pfm_mutated_valid_files(img in small_image(), ms in mutations(), number in interesting_number(), k in any::<usize>(), edit_header in any::<bool>()) {
        let mut bytes = pfm::encode(&img);
        let clean = decode_no_panic("pfm::decode", pfm::decode, &bytes)?;
        prop_assert!(clean.is_ok(), "our own PFM file does not decode: {:?}", clean.err());
        if edit_header {
            let hl = pfm_header_len(&bytes);
            replace_header_number(&mut bytes, hl, k, &number);
        }
        for m in &ms {
            apply(&mut bytes, m);
        }
        let _ = decode_no_panic("pfm::decode", pfm::decode, &bytes)?;
    }

    #[test]
    fn exr_mutated_valid_files(img in small_image(), ms in prop::collection::vec(mutation(), 0..4), edits in prop::collection::vec(exr_edit(), 0..3)) {
        let mut bytes = exr::encode(&img).map_err(|e| TestCaseError::fail(format!("exr::encode: {e}")))?;
        let clean = decode_no_panic("exr::decode", exr::decode, &bytes)?;
        prop_assert!(clean.is_ok(), "our own EXR file does not decode: {:?}", clean.err());
        for e in &edits {
            apply_exr(&mut bytes, e);
        }
        for m in &ms {
            apply(&mut bytes, m);
        }
        let _ = decode_no_panic("exr::decode", exr::decode, &bytes)?;
    }
}

// -------------------------------------------------------------------------------------------------
// Pipeline parser properties
// -------------------------------------------------------------------------------------------------

const EXAMPLE: &str = include_str!("../graphs/example.ron");
const SEED: &str = include_str!("../graphs/seed.ron");

/// Tokens of the pipeline syntax (and near misses), for token-soup inputs.
const TOKENS: &[&str] = &[
    "(",
    ")",
    "{",
    "}",
    "[",
    "]",
    ":",
    "::",
    ",",
    "\"",
    "'",
    "r\"",
    "r#\"",
    "\"#",
    "r#",
    "#![enable(implicit_some)]",
    "#!",
    "//",
    "/*",
    "*/",
    "\n",
    " ",
    "\t",
    "\\",
    "\\u{",
    "\\u{110000}",
    "\\u{d800}",
    "\\x",
    "0x",
    "0b",
    "0o",
    "-",
    "+",
    ".",
    "e",
    "E",
    "_",
    "1",
    "0",
    "9223372036854775807",
    "9223372036854775808",
    "-9223372036854775808",
    "18446744073709551616",
    "1e999",
    "1e-999",
    "inf",
    "-inf",
    "NaN",
    "true",
    "false",
    "nodes",
    "Pipeline",
    "\"env\"",
    "\"lum\"",
    "\"save\"",
    "\"\"",
    "LoadHdr",
    "Luminance",
    "Save",
    "BuildCdf",
    "Sample",
    "RelightSphere",
    "PhongSample",
    "Fresnel",
    "Constant",
    "Overlay",
    "path",
    "input",
    "image",
    "cdf",
    "count",
    "seed",
    "size",
    "exponent",
    "eta_i",
    "\"builtin:sky\"",
    "\"../x.png\"",
    "\"/abs.png\"",
    "\"a.exr\"",
    "\"a.csv\"",
    "Rec709",
    "r#ident",
    "\u{feff}",
    "é",
    "\u{0}",
    "\r",
];

fn token_soup() -> impl Strategy<Value = String> {
    prop::collection::vec(prop::sample::select(TOKENS), 0..120).prop_map(|t| t.concat())
}

/// A token inserted into a valid pipeline at a character position.
fn token_insertions(base: &'static str) -> impl Strategy<Value = String> {
    prop::collection::vec((any::<usize>(), prop::sample::select(TOKENS)), 1..6).prop_map(move |ins| {
        let mut chars: Vec<char> = base.chars().collect();
        for (at, tok) in ins {
            let at = at % (chars.len() + 1);
            chars.splice(at..at, tok.chars());
        }
        chars.into_iter().collect()
    })
}

/// Byte-level mutations of a valid pipeline (the result made valid UTF-8 with replacement chars).
fn byte_mutations(base: &'static str) -> impl Strategy<Value = String> {
    mutations().prop_map(move |ms| {
        let mut bytes = base.as_bytes().to_vec();
        for m in &ms {
            apply(&mut bytes, m);
        }
        String::from_utf8_lossy(&bytes).into_owned()
    })
}

/// `--set NODE.FIELD=VALUE` strings: real node and field names with random values.
fn override_text() -> impl Strategy<Value = String> {
    let node = prop::sample::select(vec!["env", "lum", "save", "nope", "", "env.x"]);
    let field = prop::sample::select(vec!["path", "image", "input", "weights", "flip_vertical", "nope", ""]);
    let value =
        prop_oneof![token_soup(), Just("\"builtin:sky\"".to_string()), Just("Rec2020".to_string()), "\\PC{0,20}"];
    (node, field, value).prop_map(|(n, f, v)| format!("{n}.{f}={v}"))
}

proptest! {
    #![proptest_config(config(4000))]

    #[test]
    fn pipeline_arbitrary_strings(text in "\\PC{0,400}") {
        parse_no_panic(&text, &[])?;
    }

    #[test]
    fn pipeline_arbitrary_chars(chars in prop::collection::vec(any::<char>(), 0..300)) {
        let text: String = chars.into_iter().collect();
        parse_no_panic(&text, &[])?;
    }

    #[test]
    fn pipeline_token_soup(text in token_soup()) {
        parse_no_panic(&text, &[])?;
        // The same soup inside a plausible skeleton reaches the validator.
        parse_no_panic(&format!("( nodes: {{ \"a\": {text} }} )"), &[])?;
        parse_no_panic(&format!("( nodes: {{ \"env\": LoadHdr(path: \"builtin:sky\"), \"s\": Save(input: \"env\", {text}) }} )"), &[])?;
    }

    #[test]
    fn pipeline_example_byte_mutations(text in byte_mutations(EXAMPLE)) {
        parse_no_panic(&text, &[])?;
    }

    #[test]
    fn pipeline_example_token_insertions(text in token_insertions(EXAMPLE)) {
        parse_no_panic(&text, &[])?;
    }

    #[test]
    fn pipeline_example_truncations(at in any::<usize>(), seed_file in any::<bool>()) {
        let base = if seed_file { SEED } else { EXAMPLE };
        let mut cut = at % (base.len() + 1);
        while !base.is_char_boundary(cut) {
            cut -= 1;
        }
        parse_no_panic(&base[..cut], &[])?;
    }

    #[test]
    fn pipeline_seed_mutations(text in prop_oneof![byte_mutations(SEED), token_insertions(SEED)]) {
        parse_no_panic(&text, &[])?;
    }

    #[test]
    fn pipeline_overrides(sets in prop::collection::vec(override_text(), 1..4)) {
        for s in &sets {
            let _ = catch_unwind(|| Override::parse(s)).map_err(|p| TestCaseError::fail(format!(
                "Override::parse panicked ({}) on {s:?}", panic_text(&*p))))?;
        }
        let overrides: Vec<Override> = sets.iter().filter_map(|s| Override::parse(s).ok()).collect();
        parse_no_panic(EXAMPLE, &overrides)?;
    }
}

/// Nesting around the parser's depth limit (128) with every kind of bracket, closed and not:
/// an error (or success), never a stack overflow or a panic.
#[test]
fn pipeline_deep_nesting() {
    let opens: &[(&str, &str)] =
        &[("[", "]"), ("(", ")"), ("{\"k\": ", "}"), ("A(", ")"), ("(f: ", ")"), ("Name(x: ", ")")];
    for &(open, close) in opens {
        for depth in [1usize, 64, 127, 128, 129, 200, 5000, 100_000] {
            let closed = format!("{}1{}", open.repeat(depth), close.repeat(depth));
            parse_no_panic(&closed, &[]).unwrap();
            let unclosed = open.repeat(depth);
            parse_no_panic(&unclosed, &[]).unwrap();
            let inside = format!("( nodes: {{ \"a\": Constant(color: {closed}) }} )");
            parse_no_panic(&inside, &[]).unwrap();
        }
    }
    // Long flat inputs are fine too (no recursion per element).
    let long_list = format!("[{}]", "1,".repeat(200_000));
    parse_no_panic(&long_list, &[]).unwrap();
    let comments = "/*".repeat(50_000);
    parse_no_panic(&comments, &[]).unwrap();
}

/// The valid pipelines themselves parse: the mutation properties start from real inputs.
#[test]
fn valid_pipelines_parse() {
    assert!(parse_no_panic(EXAMPLE, &[]).unwrap(), "graphs/example.ron does not validate");
    assert!(parse_no_panic(SEED, &[]).unwrap(), "graphs/seed.ron does not validate");
}

// -------------------------------------------------------------------------------------------------
// Regressions: minimised crashes and resource problems found by the properties above
// -------------------------------------------------------------------------------------------------

/// BUG (found by `rgbe_structured_headers`): `formats::rgbe::decode` divides by the header's
/// `EXPOSURE` product in `exponent_table`, in f32. A product below 2^-8 overflows the table entry
/// for exponent byte 255 (2^119 / 0.001 > f32::MAX) to +Inf, and a mantissa byte 0 then gives
/// 0 * Inf = NaN. RGBE cannot represent NaN, infinities or negatives, so a decoded image must be
/// finite (or the header refused with an error). Minimal input: a 1x1 image, EXPOSURE=0.001,
/// pixel (R, G, B, E) = (0, 128, 0, 255) decodes to [NaN, inf, NaN].
#[test]
fn regression_rgbe_small_exposure_gives_nan_and_inf() {
    let bytes: &[u8] = b"#?RADIANCE\nEXPOSURE=0.001\n\n-Y 1 +X 1\n\x00\x80\x00\xff";
    match rgbe::decode(bytes) {
        Err(e) => assert!(!e.to_string().is_empty()),
        Ok(img) => assert!(
            img.data.iter().all(|v| v.is_finite() && *v >= 0.0),
            "rgbe::decode of {} gave non-finite values {:?}",
            show(bytes),
            img.data
        ),
    }
}

/// BUG (found by `rgbe_mutated_valid_files`, a header number replaced by 2^28): a 38-byte
/// Radiance file claiming one row of 2^28 pixels (= `MAX_PIXELS`, so accepted),
/// `b"#?RADIANCE\n\n-Y 1 +X 268435456\n"` + 8 bytes `0x80`, passes the "smallest possible
/// encoding" check (8 bytes: one pixel plus one `1 1 1 n` repeat code), and `rgbe::decode` then
/// resizes its output by the whole row (`out.resize(base + row_len, 0.0)`: 3 * 2^28 f32 = 3 GiB,
/// written with zeros) *before* decoding the row, only to fail with "truncated pixel data in
/// scanline 0". Measured: 7.5 s and 3.1 GB peak RSS for 38 bytes. The module documentation
/// promises that "a truncated file fails before it has allocated more than what it actually
/// decoded". This test uses a 2^24-pixel row (a 192 MiB allocation, so that it stays cheap while
/// the bug exists) and expects an error with no allocation above 64 MiB.
#[test]
fn regression_rgbe_truncated_wide_row_allocates_the_whole_row() {
    let bytes: &[u8] = b"#?RADIANCE\n\n-Y 1 +X 16777216\n\x80\x80\x80\x80\x80\x80\x80\x80";
    let (result, largest) = largest_allocation_of(|| rgbe::decode(bytes));
    assert!(
        matches!(&result, Err(FormatError::Invalid(m)) if m == "truncated pixel data in scanline 0"),
        "a 1-row image of 2^24 pixels cannot fit in 8 bytes: {:?}",
        result.as_ref().err()
    );
    assert!(
        largest <= 64 << 20,
        "rgbe::decode allocated {} MiB at once for the {}-byte input {} (then: {:?})",
        largest >> 20,
        bytes.len(),
        show(bytes),
        result.err()
    );
}
