//! Node keys: `BLAKE3(domain, op name, op version, canonical params, input keys, content)`.
//!
//! Canonical parameter encoding: each field in the operator's declared order, as its name
//! (length-prefixed) then a tag byte and the value: floats as the 8 bytes of `f64::to_bits`
//! (integers given to float fields were converted to f64 by validation, so `1` and `1.0` hash
//! alike), integers as i64, strings length-prefixed. Inputs contribute their field name and the
//! 32-byte key of the node wired in. A loader (an operator with `content_key`) leaves its `Path`
//! fields out and adds the bytes its `content_key` returns (the file's BLAKE3 hash) instead.

use std::collections::BTreeMap;

use crate::engine::graph::Node;
use crate::engine::op::{FieldKind, ParamValue};

pub type Key = [u8; 32];

/// Version of the key layout itself: bump it to invalidate every cache entry.
const DOMAIN: &[u8] = b"hdrflow.node-key.v1\0";

fn put_str(h: &mut blake3::Hasher, s: &str) {
    h.update(&(s.len() as u64).to_le_bytes());
    h.update(s.as_bytes());
}

/// The key of `node`, given the keys of its inputs and its content bytes (for loaders).
pub fn node_key(node: &Node, input_keys: &BTreeMap<&'static str, Key>, content: Option<&[u8]>) -> Key {
    let spec = node.spec;
    let mut h = blake3::Hasher::new();
    h.update(DOMAIN);
    put_str(&mut h, spec.name);
    h.update(&spec.version.to_le_bytes());
    for field in spec.fields {
        if let FieldKind::Input(_) = field.kind {
            put_str(&mut h, field.name);
            h.update(b"I");
            h.update(&input_keys[field.name]);
            continue;
        }
        if matches!(field.kind, FieldKind::Path) && spec.content_key.is_some() {
            continue;
        }
        let Some(value) = node.params.values.get(field.name) else { continue };
        put_str(&mut h, field.name);
        match value {
            ParamValue::Float(v) => {
                h.update(b"f");
                h.update(&v.to_bits().to_le_bytes());
            }
            ParamValue::Int(v) => {
                h.update(b"i");
                h.update(&v.to_le_bytes());
            }
            ParamValue::Bool(v) => {
                h.update(&[b'b', u8::from(*v)]);
            }
            ParamValue::Text(s) => {
                h.update(b"s");
                put_str(&mut h, s);
            }
            ParamValue::Choice(s) => {
                h.update(b"c");
                put_str(&mut h, s);
            }
            ParamValue::Tuple(v) => {
                h.update(b"t");
                h.update(&(v.len() as u64).to_le_bytes());
                for x in v {
                    h.update(&x.to_bits().to_le_bytes());
                }
            }
        }
    }
    if let Some(bytes) = content {
        h.update(b"C");
        h.update(&(bytes.len() as u64).to_le_bytes());
        h.update(bytes);
    }
    *h.finalize().as_bytes()
}

/// Lower-case hex of a key.
pub fn key_hex(key: &Key) -> String {
    key.iter().map(|b| format!("{b:02x}")).collect()
}
