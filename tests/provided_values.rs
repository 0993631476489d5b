//! `Pipeline::provide`: a value supplied in place of a node's output is used as that node's
//! value without evaluating it, keyed by its content, so its consumers are cached when the same
//! value comes again and recomputed when it changes. (What the Python bindings' `inputs=` uses.)

use std::path::Path;

use hdrflow::engine::cache::CacheStore;
use hdrflow::engine::scheduler::{self, NodeStatus, RunOptions, RunOutcome, Silent};
use hdrflow::engine::value::Value;
use hdrflow::values::Image;
use hdrflow::Pipeline;

const GRAPH: &str = r#"(nodes: {
    "env": LoadHdr(path: "does-not-exist.hdr"),
    "exp": Exposure(image: "env", stops: 1.0),
})"#;

fn pipeline_with(env: Image) -> Pipeline {
    let registry = hdrflow::builtin_registry();
    let mut p =
        Pipeline::parse_providing(GRAPH, "test.ron", Path::new("."), &registry, &[], &["env"]).expect("validates");
    p.provide("env", Value::new(env)).expect("an image for an image node");
    p
}

fn run(p: &Pipeline, cache: &Path) -> RunOutcome {
    let options = RunOptions {
        targets: vec!["exp".into()],
        out_dir: cache.join("out"),
        cache: Some(CacheStore::new(cache, 1 << 30)),
        jobs: Some(2),
        observer: &Silent,
    };
    scheduler::run(p, &options).expect("runs")
}

fn image(scale: f32) -> Image {
    Image::from_vec(3, 2, 3, (0..18).map(|v| v as f32 * scale).collect())
}

#[test]
fn a_provided_value_replaces_the_node_and_keys_its_consumers_by_content() {
    let dir = tempfile::tempdir().unwrap();
    // The loader's file does not exist: it is never opened, not even for its content key.
    let first = run(&pipeline_with(image(1.0)), dir.path());
    assert_eq!(first.report.status_of("env"), Some(NodeStatus::Provided));
    assert_eq!(first.report.status_of("exp"), Some(NodeStatus::Computed));
    let out = first.values["exp"].get::<Image>().unwrap();
    assert_eq!(out.data, (0..18).map(|v| v as f32 * 2.0).collect::<Vec<_>>());

    // The same content again (a new allocation): its consumer comes from the cache.
    let again = run(&pipeline_with(image(1.0)), dir.path());
    assert_eq!(again.report.status_of("exp"), Some(NodeStatus::Cached));
    assert_eq!(again.values["exp"].get::<Image>().unwrap(), out);
    let key = |o: &RunOutcome, n: &str| o.report.nodes.iter().find(|r| r.name == n).unwrap().key.clone();
    assert_eq!(key(&first, "env"), key(&again, "env"));

    // Other content: another key, and its consumer is computed.
    let changed = run(&pipeline_with(image(0.5)), dir.path());
    assert_ne!(key(&changed, "env"), key(&first, "env"));
    assert_eq!(changed.report.status_of("exp"), Some(NodeStatus::Computed));
    assert_eq!(changed.values["exp"].get::<Image>().unwrap().data[2], 2.0);
}

#[test]
fn a_provided_value_must_have_the_node_s_output_type() {
    let registry = hdrflow::builtin_registry();
    let mut p = Pipeline::parse_providing(GRAPH, "test.ron", Path::new("."), &registry, &[], &["env"]).unwrap();
    let err = p.provide("env", Value::new(Image::new(2, 2, 1))).unwrap_err();
    assert!(err.contains("outputs `image`, but the value provided is `scalar field`"), "{err}");
    let err = p.provide("nope", Value::new(image(1.0))).unwrap_err();
    assert!(err.starts_with("no node \"nope\""), "{err}");
}

/// Validation looks for the loader's file unless the caller says it will provide the node's
/// value: then the file is never read, and need not exist.
#[test]
fn a_missing_file_is_a_pipeline_error_unless_its_node_is_provided() {
    let registry = hdrflow::builtin_registry();
    let err = Pipeline::parse(GRAPH, "test.ron", Path::new("."), &registry, &[]).unwrap_err().to_string();
    assert!(
        err.contains(r#"test.ron:2:26: node "env": field "path": input file "does-not-exist.hdr" does not exist"#),
        "{err}"
    );
    assert!(Pipeline::parse_providing(GRAPH, "test.ron", Path::new("."), &registry, &[], &["exp"]).is_err());
    assert!(Pipeline::parse_providing(GRAPH, "test.ron", Path::new("."), &registry, &[], &["env"]).is_ok());
}
