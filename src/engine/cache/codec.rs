//! A node's outputs to bytes and back, for the disk cache.
//!
//! An entry holds every port of one node: a count, then per port its name, its value type's
//! name and the payload that type's `ValueData::encode` wrote (decoded by the type's
//! `TypeSpec::decode`, found in the registry by name). Little-endian, lengths as u64. Every
//! length is checked against the bytes that remain before anything is allocated, so a corrupt
//! entry is an error, never a huge allocation or a panic. Integrity as a whole is checked by the
//! store's BLAKE3 checksum.
//!
//! `Writer` and `Reader` are public so that a value type declared outside the engine can write
//! its payload with the same checked primitives.

use crate::engine::registry::Registry;
use crate::engine::value::Value;

/// Bump when the byte layout of the entry, or of a built-in type's payload, changes: entries of
/// another version are ignored and recomputed. 3: images store their zero runs as counts.
pub const CODEC_VERSION: u32 = 3;

/// Encodes a node's outputs.
pub fn encode(outputs: &[(String, Value)]) -> Vec<u8> {
    let mut buf = Vec::with_capacity(outputs.iter().map(|(_, v)| v.approx_bytes() + 64).sum());
    let mut w = Writer(&mut buf);
    w.u64(outputs.len() as u64);
    for (port, value) in outputs {
        let mut w = Writer(&mut buf);
        w.str(port);
        w.str(value.value_type().name());
        let mut payload = Vec::with_capacity(value.approx_bytes() + 16);
        value.encode(&mut payload);
        Writer(&mut buf).bytes(&payload);
    }
    buf
}

/// Decodes a node's outputs; value types are looked up in `registry`.
pub fn decode(bytes: &[u8], registry: &Registry) -> Result<Vec<(String, Value)>, String> {
    let mut r = Reader::new(bytes);
    let n = r.usize()?;
    r.need(n.saturating_mul(24))?;
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        let port = r.str()?;
        let type_name = r.str()?;
        let ty =
            registry.value_type(&type_name).ok_or_else(|| format!("value type {type_name:?} is not registered"))?;
        let payload = r.bytes()?;
        let value = (ty.spec().decode)(payload)?;
        if value.value_type() != ty {
            return Err(format!("a {type_name} entry decoded to a {}", value.value_type()));
        }
        out.push((port, value));
    }
    r.finish()?;
    Ok(out)
}

pub use crate::bytes::{Reader, Writer};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::value::FileBlob;

    #[test]
    fn entry_round_trip_and_truncation_is_an_error() {
        let registry = Registry::empty();
        let outputs = vec![
            ("a".to_string(), Value::new(FileBlob::new("x.png".into(), vec![1, 2, 3]))),
            ("b".to_string(), Value::new(FileBlob::new("y.png".into(), vec![]))),
        ];
        let bytes = encode(&outputs);
        let back = decode(&bytes, &registry).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!(back[0].0, "a");
        assert_eq!(back[0].1.get::<FileBlob>().unwrap().bytes, vec![1, 2, 3]);
        for cut in [0, 1, 9, bytes.len() - 1] {
            let e = decode(&bytes[..cut], &registry).unwrap_err();
            assert!(e.starts_with("truncated: need"), "cut at {cut}: {e}");
        }
    }

    #[test]
    fn huge_claimed_length_is_refused_without_allocating() {
        let mut bytes = Vec::new();
        for v in [u64::MAX / 2, 1 << 40] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        let e = decode(&bytes, &Registry::empty()).unwrap_err();
        assert!(e.starts_with("truncated: need") && e.ends_with("8 left"), "{e}");
    }

    #[test]
    fn unregistered_types_are_errors() {
        let mut bytes = Vec::new();
        let mut w = Writer(&mut bytes);
        w.u64(1);
        w.str("");
        w.str("no such type");
        w.bytes(&[]);
        assert!(decode(&bytes, &Registry::empty()).unwrap_err().contains("not registered"));
    }
}
