//! Golden cache keys of a small pipeline of built-in operators: an accidental change of a key
//! (the key layout, how validation canonicalises an operator's parameters and fills in its
//! defaults, how a loader's content or an input list enters, how a provided value is keyed)
//! fails here, where it would otherwise silently make every cache miss, or worse, hit.
//!
//! What is fixed, so that the golden does not move with every edit:
//! - the **engine salt** (`ENGINE_SALT`, a hash of every source but the operators' own files
//!   and the layers above them: `build.rs`, `tests/cache_salt.rs`) is
//!   replaced by `SALT`, and every operator's **code hash** (a hash of its own file) by
//!   `CODE_HASH`, through `node_key_with` / `provided_key_with`. The real ones change on every
//!   source edit by design (so that a shared cache never serves a value computed by other
//!   code) and are not pinned;
//! - the inputs: `LoadHdr` reads a built-in map, whose content key (`builtin:NAME:vN`) does not
//!   depend on any file; the provided value is a fixed 2x1 image.
//!
//! The keys here are computed by walking the pipeline as the scheduler does (inputs first, each
//! input field's wired ports in order, with their port names; loaders' content bytes from their
//! `content_key`), and `keys_follow_the_schedulers_wiring` checks that this walk, with the real
//! salt and code hashes, gives exactly `scheduler::compute_keys`' keys: so the golden pins what
//! a run uses.
//!
//! What still moves the golden, deliberately: an operator's version, a parameter added to,
//! removed from or renamed in one of these operators, a changed default, `DOMAIN` or the
//! `LoadHdr` built-in version, a value type's cache payload (a provided value is keyed by it:
//! the images' zero runs, codec version 3, moved `probe`'s). Such a change updates `GOLDEN` (run the test: the message prints
//! the new keys) in the same commit, which makes the key change visible in review.

use std::collections::BTreeMap;
use std::path::Path;

use hdrflow::engine::cache::{key_hex, node_key, node_key_with, provided_key, provided_key_with, Key};
use hdrflow::engine::context::CheckContext;
use hdrflow::engine::scheduler::compute_keys;
use hdrflow::values::Image;
use hdrflow::{Pipeline, Value};

/// Stands for the engine salt.
const SALT: [u8; 32] = [0x5a; 32];
/// Stands for every operator's code hash.
const CODE_HASH: [u8; 32] = [0xc0; 32];

/// One operator of each kind of field: a loader (its path left out of the key, its content in),
/// bools, choices, an optional tuple, a list input of three open ports, a list of strings, a
/// list of numbers, an output path, an unwired optional input, and a provided value.
const PIPELINE: &str = r#"(nodes: {
    "env":   LoadHdr(path: "builtin:sky", flip_vertical: true),
    "lum":   Luminance(image: "env", weights: Rec2020),
    "cdf":   BuildCdf(luminance: "lum", sanitize: true),
    "split": SplitChannels(image: "env"),
    "bgr":   MergeChannels(channels: ["split.B", "split.G", "split.R"], names: ["b", "g", "r"]),
    "exp":   Exposure(image: "bgr", match_percentile: (99.0, 1.0)),
    "stats": Statistics(image: "env", percentiles: (5.0, 95.0)),
    "math":  Math(a: "env", op: Mul, value: 0.5),
    "save":  Save(input: "exp", path: "bgr.exr", half: true),
    "probe": LoadHdr(path: "builtin:constant"),
    "probe_lum": Luminance(image: "probe"),
})"#;

fn pipeline() -> Pipeline {
    let registry = hdrflow::builtin_registry();
    let mut p =
        Pipeline::parse(PIPELINE, "golden.ron", Path::new("."), &registry, &[]).expect("the pipeline validates");
    let probe = Image::from_vec(2, 1, 3, vec![0.25, 0.5, 1.0, 2.0, 4.0, 8.0]);
    p.provide("probe", Value::new(probe)).expect("an image for a LoadHdr");
    p
}

/// Every node's key, inputs first, as the scheduler makes them: `node_key_with(salt, code hash)`
/// or `provided_key_with(salt)`, where `real` keeps each operator's own code hash (then `salt`
/// must be the engine's for the keys to be a run's).
fn keys(
    p: &Pipeline,
    node: impl Fn(&hdrflow::engine::graph::Node, &[Vec<(Key, &str)>], Option<&[u8]>) -> Key,
    provided: impl Fn(&Value) -> Key,
) -> BTreeMap<String, Key> {
    let mut keys: Vec<Option<Key>> = vec![None; p.nodes.len()];
    for &i in &p.topo_order {
        let n = &p.nodes[i];
        if let Some(value) = p.provided.get(&i) {
            keys[i] = Some(provided(value));
            continue;
        }
        let content = n.spec.content_key.as_ref().map(|f| {
            let (input_types, input_sizes) = p.input_shapes(i);
            let ctx = CheckContext {
                params: &n.params,
                input_types: &input_types,
                input_sizes: &input_sizes,
                base_dir: &p.base_dir,
                savers: p.registry.savers(),
            };
            f(&ctx).expect("a built-in map's content key")
        });
        let inputs: Vec<Vec<(Key, &str)>> = n
            .inputs
            .iter()
            .map(|w| {
                w.sources
                    .iter()
                    .map(|s| (keys[s.node].expect("inputs first"), p.nodes[s.node].ports[s.port].name.as_ref()))
                    .collect()
            })
            .collect();
        keys[i] = Some(node(n, &inputs, content.as_deref()));
    }
    p.nodes.iter().zip(keys).map(|(n, k)| (n.name.clone(), k.expect("every node keyed"))).collect()
}

#[test]
fn keys_follow_the_schedulers_wiring() {
    let p = pipeline();
    let ours = keys(&p, node_key, provided_key);
    let all: Vec<usize> = (0..p.nodes.len()).collect();
    let run = compute_keys(&p, &all).expect("keys");
    for (n, k) in p.nodes.iter().zip(run) {
        assert_eq!(Some(ours[&n.name]), k, "{}: the golden's walk differs from the scheduler's", n.name);
    }
}

#[test]
fn golden_keys_with_the_salt_and_code_hashes_fixed() {
    let p = pipeline();
    let got: Vec<(String, String)> = keys(
        &p,
        |n, inputs, content| node_key_with(&SALT, &CODE_HASH, n, inputs, content),
        |v| provided_key_with(&SALT, v),
    )
    .into_iter()
    .map(|(name, k)| (name, key_hex(&k)))
    .collect();
    let want: Vec<(String, String)> = GOLDEN.iter().map(|(n, k)| (n.to_string(), k.to_string())).collect();
    assert_eq!(got, want, "a cache key changed: if on purpose, update GOLDEN (and see the module docs)");
    // The fixed hashes are what the golden pins: changing either changes every key.
    let other = keys(&p, |n, i, c| node_key_with(&SALT, &[0xc1; 32], n, i, c), |v| provided_key_with(&SALT, v));
    let fixed = keys(&p, |n, i, c| node_key_with(&SALT, &CODE_HASH, n, i, c), |v| provided_key_with(&SALT, v));
    assert!(other.iter().all(|(name, k)| name == "probe" || *k != fixed[name]));
}

/// Name -> hex key, in name order (the map's order).
const GOLDEN: [(&str, &str); 11] = [
    ("bgr", "a64af86482c65602a3591fb92835b756bb08ec53366dbfbc190dd5f46129ca97"),
    ("cdf", "0440cf28e35e71856b921cc7b43fc49d512b5cc5fdcd5ba45725eab537424487"),
    ("env", "8ccdbbb4fde8b8c929a97adb30c2f9e86a9680197e1ce9dc98d15a4424680b42"),
    ("exp", "1d73aa6fb371d40a8886d55ef11ed0c5706cde4a8b28d1edc7df6882eb2f606e"),
    ("lum", "6a0505711c82b40cffba6faa875838882e18debf6f2b2db5f14ce7fa7ad1d52f"),
    ("math", "78d5e7718df7c50ea6c3e3bfa19d1ac4a74b54c858b0bb9e975aaf01780d0559"),
    ("probe", "4fea2bb221d4a6cf69f34e82f7f72d7ad4ba1111f2b0344c0c48993fc3680197"),
    ("probe_lum", "3739998ad23c35e3b21c3f1ca852470151f6df7f84531db3cee75b7a0af7dc9b"),
    ("save", "832f22363fe5463f691aaa915d0e13175deaa62a26810d089802c48320deff89"),
    ("split", "89c5e41a27509d2e1b1678a4ea5533ec67f62af4cf8d6242c35aa1015eaa0f40"),
    ("stats", "89f109480b4fd091a35d44cc9b9ebff58b601109b37f126554086e6cf99f8dfc"),
];
