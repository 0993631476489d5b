//! `formats::pfm::decode` on arbitrary bytes: `Ok` or `Err`, never a panic; a decoded image is
//! well formed (values are returned as stored, NaN included, by design).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(img) = hdrflow::formats::pfm::decode(data) {
        assert!(img.width > 0 && img.height > 0 && (img.channels == 1 || img.channels == 3));
        assert_eq!(img.data.len(), img.width * img.height * img.channels);
    }
});
