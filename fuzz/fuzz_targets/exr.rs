//! `formats::exr::decode` on arbitrary bytes: `Ok` or `Err`, never a panic. `decode` already
//! turns a panic inside the `exr` crate into an `Err("exr decoder panicked: ...")`; such an
//! error is reported here as a crash too, since it is a bug worth knowing about (in hdrflow's
//! use of the crate or in the crate itself).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    match hdrflow::formats::exr::decode(data) {
        Ok(img) => {
            assert!(img.width > 0 && img.height > 0 && (img.channels == 1 || img.channels == 3));
            assert_eq!(img.data.len(), img.width * img.height * img.channels);
        }
        Err(e) => assert!(!e.0.starts_with("exr decoder panicked"), "{}", e.0),
    }
});
