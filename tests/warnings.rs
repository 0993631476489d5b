//! What hdrflow accepts but a user should hear about (issue 25): each case runs a real pipeline
//! through the CLI and checks the one warning line, and that the run still succeeds.

mod common;

use common::Sandbox;

fn run(graph: &str) -> common::Output {
    let sandbox = Sandbox::new();
    let path = sandbox.write("graph.ron", graph);
    let (output, _) = sandbox.run(&path, &[]);
    output
}

#[test]
fn a_square_map_read_as_lat_long_is_warned_once_per_node() {
    let output = run(r#"(
    nodes: {
        "probe": Constant(width: 64, height: 64, color: 1),
        "lum": Luminance(image: "probe"),
        "cdf": BuildCdf(luminance: "lum"),
        "cube": LatLongToCubemap(image: "probe", size: 8),
        "a": Save(input: "cdf", path: "pdf.exr"),
        "b": Save(input: "cube", path: "cube.exr"),
    },
)"#);
    output
        .assert_code(0)
        .assert_stderr_contains(
            "warning: node \"cdf\": field \"luminance\" is 64 x 64, not 2:1, but is read as a lat-long map",
        )
        .assert_stderr_contains("warning: node \"cube\": field \"image\" is 64 x 64, not 2:1")
        .assert_stderr_contains("AngularToLatLong");
    assert_eq!(output.stderr.matches("not 2:1").count(), 2, "{}", output.describe());
}

#[test]
fn a_lat_long_map_gives_no_warning() {
    let output = run(r#"(
    nodes: {
        "env": LoadHdr(path: "builtin:sky"),
        "lum": Luminance(image: "env"),
        "cdf": BuildCdf(luminance: "lum"),
        "a": Save(input: "cdf", path: "pdf.exr"),
    },
)"#);
    output.assert_code(0);
    assert!(!output.stderr.contains("warning"), "{}", output.describe());
}

#[test]
fn half_float_ktx2_says_how_many_texels_it_clamps() {
    let map = format!("{}/assets/maps/rooitou_park_1k.hdr", common::MANIFEST_DIR);
    let output = run(&format!(
        r#"(
    nodes: {{
        "env": LoadHdr(path: "{map}"),
        "half": Save(input: "env", path: "env.ktx2"),
        "full": Save(input: "env", path: "env32.ktx2", ktx_format: Rgba32f),
    }},
)"#
    ));
    output.assert_code(0).assert_stderr_contains("warning: node \"half\": env.ktx2: ");
    let line = output.stderr.lines().find(|l| l.contains("node \"half\"")).expect("the warning line");
    assert!(line.contains("exceed the half-float maximum 65504 (the largest: 69120)"), "{line}");
    assert!(line.contains("ktx_format: Rgba32f keeps them"), "{line}");
    let count: usize =
        line.split(": ").nth(3).and_then(|r| r.split(' ').next()).and_then(|n| n.parse().ok()).expect(line);
    assert!(count > 0, "{line}");
    assert!(!output.stderr.contains("node \"full\""), "{}", output.describe());
}

#[test]
fn a_two_channel_table_saved_as_rgb_keeps_both_channels_and_says_so() {
    let sandbox = Sandbox::new();
    let path = sandbox.write(
        "graph.ron",
        r#"(
    nodes: {
        "lut": BrdfLut(size: 8, samples: 64),
        "pfm": Save(input: "lut", path: "lut.pfm"),
        "exr": Save(input: "lut", path: "lut.exr"),
    },
)"#,
    );
    let (output, _) = sandbox.run(&path, &[]);
    output.assert_code(0).assert_stderr_contains(
        "warning: node \"pfm\": lut.pfm: .pfm holds RGB: the two channels R and G are written as R and G, with B = 0",
    );
    assert!(!output.stderr.contains("node \"exr\""), "{}", output.describe());
    let pfm =
        hdrflow::formats::decode_by_extension(&std::fs::read(sandbox.out().join("lut.pfm")).unwrap(), "pfm").unwrap();
    let exr =
        hdrflow::formats::decode_by_extension(&std::fs::read(sandbox.out().join("lut.exr")).unwrap(), "exr").unwrap();
    assert!(exr.channels >= 2);
    for y in 0..8 {
        for x in 0..8 {
            let (p, e) = (pfm.pixel(x, y), exr.pixel(x, y));
            assert_eq!([p[0], p[1], p[2]], [e[0], e[1], 0.0], "texel ({x}, {y})");
        }
    }
}
