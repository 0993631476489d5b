//! Node keys: `BLAKE3(domain, engine salt, op name, op version, op code hash, canonical params,
//! inputs, content)`.
//!
//! - The **engine salt** is a hash of every source a result can depend on but the operators'
//!   own files (computed by `build.rs`: all of `src/` below the command line, the files it
//!   embeds, the vendored EXR decoder, the locked versions of the crates it uses; listed in
//!   `SALTED_SOURCES` and `SALTED_CRATES`) and the **op code hash** one of the operator's own
//!   file (`OpSpec::code`), both with comments and blank space removed: a code change that may
//!   alter results changes every key it could affect, even when nobody bumped a version, so a
//!   cache shared between machines and builds never serves a stale value
//!   (`tests/cache_salt.rs` checks that no source escapes both).
//! - **Parameters**: each field in the operator's declared order, as its name (length-prefixed)
//!   then a tag byte and the value: floats as the 8 bytes of `f64::to_bits` (integers given to
//!   float fields were converted to f64 by validation, so `1` and `1.0` hash alike), integers as
//!   i64, strings length-prefixed.
//! - **Inputs**: each input field's name, the number of nodes wired into it (0 for an unwired
//!   optional input), then in order each one's 32-byte key and the name of the port taken.
//! - A loader (an operator with `content_key`) leaves its `Path` fields out and adds the bytes
//!   its `content_key` returns (the file's BLAKE3 hash) instead.
//!
//! Keys never contain paths, times, thread counts or RON text, so they are portable.

use crate::engine::graph::Node;
use crate::engine::params::{FieldKind, ParamValue};

include!(concat!(env!("OUT_DIR"), "/engine_salt.rs"));

pub type Key = [u8; 32];

/// Version of the key layout itself: bump it to invalidate every cache entry.
const DOMAIN: &[u8] = b"hdrflow.node-key.v2\0";

fn put_str(h: &mut blake3::Hasher, s: &str) {
    h.update(&(s.len() as u64).to_le_bytes());
    h.update(s.as_bytes());
}

/// The key of `node`, given the key and port name of every port wired into it (per input
/// field, in order) and its content bytes (for loaders).
pub fn node_key(node: &Node, inputs: &[Vec<(Key, &str)>], content: Option<&[u8]>) -> Key {
    node_key_with(&ENGINE_SALT, &node.spec.code_hash, node, inputs, content)
}

/// [`node_key`] under a given engine salt and operator code hash in place of [`ENGINE_SALT`]
/// and `node.spec.code_hash`. Both are hashes of source text, so they change with every edit
/// of the code they cover; the golden tests (here and `tests/cache_key_golden.rs`) pin keys
/// under fixed ones, so that what they pin is the key layout and the operators' canonical
/// parameters and wiring, not the source.
pub fn node_key_with(
    salt: &[u8; 32],
    code_hash: &[u8; 32],
    node: &Node,
    inputs: &[Vec<(Key, &str)>],
    content: Option<&[u8]>,
) -> Key {
    let spec = &node.spec;
    let mut h = blake3::Hasher::new();
    h.update(DOMAIN);
    h.update(salt);
    put_str(&mut h, spec.name);
    h.update(&spec.version.to_le_bytes());
    h.update(code_hash);
    let mut next_input = 0;
    for field in &spec.fields {
        if let FieldKind::Input { .. } = field.kind {
            put_str(&mut h, field.name);
            h.update(b"I");
            let wired = &inputs[next_input];
            next_input += 1;
            h.update(&(wired.len() as u64).to_le_bytes());
            for (key, port) in wired {
                h.update(key);
                put_str(&mut h, port);
            }
            continue;
        }
        if matches!(field.kind, FieldKind::Path | FieldKind::InputPattern) && spec.content_key.is_some() {
            continue;
        }
        let Some(value) = node.params.values.get(field.name) else { continue };
        put_str(&mut h, field.name);
        put_param(&mut h, value);
    }
    if let Some(bytes) = content {
        h.update(b"C");
        h.update(&(bytes.len() as u64).to_le_bytes());
        h.update(bytes);
    }
    *h.finalize().as_bytes()
}

/// The key of an operator's own data named `name` (`engine::context::AuxStore`): its domain, the
/// engine salt, the operator's name, version and code hash, and the name.
pub fn aux_key(op: &str, version: u32, code_hash: &[u8; 32], name: &str) -> Key {
    let mut h = blake3::Hasher::new();
    h.update(b"hdrflow.aux-key.v1\0");
    h.update(&ENGINE_SALT);
    put_str(&mut h, op);
    h.update(&version.to_le_bytes());
    h.update(code_hash);
    put_str(&mut h, name);
    *h.finalize().as_bytes()
}

/// The key of a value supplied in place of a node's output (`Pipeline::provide`): the value's
/// type name and its cache payload (for an image: width, height, channel names, then the f32
/// samples), so the same content gets the same key whatever node or run supplies it.
pub fn provided_key(value: &crate::engine::value::Value) -> Key {
    provided_key_with(&ENGINE_SALT, value)
}

/// [`provided_key`] under a given engine salt (see [`node_key_with`]).
pub fn provided_key_with(salt: &[u8; 32], value: &crate::engine::value::Value) -> Key {
    let mut payload = Vec::with_capacity(value.approx_bytes() + 64);
    value.encode(&mut payload);
    let mut h = blake3::Hasher::new();
    h.update(b"hdrflow.provided-value.v1\0");
    h.update(salt);
    put_str(&mut h, value.value_type().name());
    h.update(&(payload.len() as u64).to_le_bytes());
    h.update(&payload);
    *h.finalize().as_bytes()
}

fn put_param(h: &mut blake3::Hasher, value: &ParamValue) {
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
            put_str(h, s);
        }
        ParamValue::Choice(s) => {
            h.update(b"c");
            put_str(h, s);
        }
        ParamValue::TextList(v) => {
            h.update(b"l");
            h.update(&(v.len() as u64).to_le_bytes());
            for s in v {
                put_str(h, s);
            }
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

/// Lower-case hex of a key (a table lookup per nibble: reports format one per node).
pub fn key_hex(key: &Key) -> String {
    const DIGITS: &[u8; 16] = b"0123456789abcdef";
    let mut out = String::with_capacity(64);
    for &b in key {
        out.push(DIGITS[(b >> 4) as usize] as char);
        out.push(DIGITS[(b & 15) as usize] as char);
    }
    out
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::engine::fields::Input;
    use crate::engine::graph::Pipeline;
    use crate::engine::op::{OpSpec, OutputType};
    use crate::engine::registry::Registry;
    use crate::engine::value::Value;
    use crate::values::ty::IMAGE_T;
    use crate::values::Image;

    crate::choice! { enum Mode { Fast, Exact } }

    crate::params! {
        struct KeyedParams {
            /// an optional input
            #[input(&[IMAGE_T])]
            image: Option<Input<Image>>,
            /// a float
            x: f64 = 0.5,
            /// an integer
            n: u32 = 3,
            /// a choice
            mode: Mode = Mode::Fast,
            /// text
            label: String = String::new(),
            /// an optional tuple
            pair: Option<[f64; 2]>,
        }
    }

    fn registry() -> Registry {
        let mut r = Registry::empty();
        crate::values::register_all(&mut r);
        r.register(
            OpSpec::new("Keyed", "test", 7, "pins keys")
                .output("image", OutputType::Fixed(IMAGE_T), "an image")
                .code("a fixed source text")
                .eval(|_, _: KeyedParams| Ok(Value::new(Image::new(1, 1, 3)))),
        )
        .unwrap();
        r
    }

    /// Keys of a handful of nodes under a fixed salt, pinned: an accidental change of the key
    /// layout (field order, tags, float bits, how an absent optional is hashed, input wiring)
    /// fails here. A deliberate one updates these values and bumps `DOMAIN`, so that old caches
    /// are not read under the new layout.
    #[test]
    fn golden_keys_under_a_fixed_salt() {
        let text = r#"(nodes: {
            "a": Keyed(),
            "b": Keyed(x: 1, n: 4, mode: Exact, label: "l", pair: (0.25, -0.0)),
            "c": Keyed(image: "a", x: -0.0),
            "d": Keyed(image: "b"),
        })"#;
        let p = Pipeline::parse(text, "t.ron", Path::new("."), &registry(), &[]).expect("validates");
        let salt = [7u8; 32];
        let key = |name: &str, inputs: &[Vec<(Key, &str)>]| {
            let node = p.nodes.iter().find(|n| n.name == name).unwrap();
            node_key_with(&salt, &node.spec.code_hash, node, inputs, None)
        };
        let (a, b) = (key("a", &[vec![]]), key("b", &[vec![]]));
        let c = key("c", &[vec![(a, "image")]]);
        let d = key("d", &[vec![(b, "image")]]);
        assert_eq!([a, b, c, d].map(|k| key_hex(&k)), GOLDEN.map(String::from), "the cache key layout changed");
        // `1` and `1.0` hash alike; -0.0 and 0.0 do not (floats by bits).
        let one = Pipeline::parse(r#"(nodes: {"k": Keyed(x: 1.0)})"#, "t.ron", Path::new("."), &registry(), &[]);
        let one = one.unwrap();
        let int = Pipeline::parse(r#"(nodes: {"k": Keyed(x: 1)})"#, "t.ron", Path::new("."), &registry(), &[]).unwrap();
        let k = |p: &Pipeline| node_key_with(&salt, &p.nodes[0].spec.code_hash, &p.nodes[0], &[vec![]], None);
        assert_eq!(k(&one), k(&int));
        let neg = Pipeline::parse(r#"(nodes: {"k": Keyed(x: -0.0)})"#, "t.ron", Path::new("."), &registry(), &[]);
        let pos = Pipeline::parse(r#"(nodes: {"k": Keyed(x: 0.0)})"#, "t.ron", Path::new("."), &registry(), &[]);
        assert_ne!(k(&neg.unwrap()), k(&pos.unwrap()));
    }

    const GOLDEN: [&str; 4] = [
        "19dc441a774704fcf6a9e0ee8e55f6933c86b09a18bcdf429aefa3181ad79f1e",
        "19ab191c387211fecfeaa536d4db794beb4956735efcdbd2f0d4be883d749ae5",
        "21b726d55a9b19c83319c7d8d8356ed18d850ba9b5ebda7721d39ef7042549fb",
        "48cc7477daaaf1d3798d9e2a99bd2ba7891ddb83d85a92683c5b863d77c7ec3c",
    ];

    #[test]
    fn hex_is_lower_case_two_digits_per_byte() {
        let mut key = [0u8; 32];
        key[0] = 0x0a;
        key[31] = 0xff;
        let hex = super::key_hex(&key);
        assert_eq!(hex.len(), 64);
        assert!(hex.starts_with("0a00") && hex.ends_with("00ff"));
    }
}
