//! Filament's own baker as a peer, in the same run (issue 36): `cmgen` 1.9.25 (Debian's
//! `libfilament-tools`, installed by `.ci/run`) and `hdrflow bake MAP --for filament --sun keep
//! --yaw 180` on two maps, the coloured markers of tests/common/markers.rs and the park
//! (assets/maps/rooitou_park_1k.hdr):
//!
//! - Orientation: both skyboxes (`*_skybox.ktx`, level 0, read back from the KTX1 files by the
//!   small reader below) put every marker on the same face (+Z), hdrflow's within 0.25 texel of
//!   the exact position (measured 0.05), cmgen's within 2 (measured 1.0 to 1.75: its lookup is
//!   shifted down and left); the faces without markers are equal, the median texel differs by
//!   under 6% (park: 3.3%). The bake without `--yaw 180` puts the centre marker on another face,
//!   so the check can fail.
//! - Irradiance: both `sh.txt` against the exact projection of the map, computed here
//!   independently of hdrflow's SH code (Filament's polynomials, each texel integrated with a 4 x 4
//!   Gauss-Legendre rule): hdrflow's error is at most cmgen's. cmgen runs with `--sh-window=no`,
//!   since its default window changes the coefficients on purpose (hdrflow writes them
//!   unwindowed); cmgen point-samples its cube, which is where its error comes from.
//! - The wall time of each (cmgen at its defaults, 256 cube, 1024 samples; hdrflow at
//!   `--quality default`, the same sizes), printed as a ratio, not asserted (speed belongs to
//!   the benchmarks: docs/src/benchmarks/ibl.md).
//!
//! Without `cmgen` on PATH the test skips visibly, and fails under `HDRFLOW_REQUIRE_CMGEN=1`.
//! Run: `cargo test --release --test cmgen_peer -- --nocapture` (prints the numbers).

mod common;
#[allow(dead_code)]
#[path = "common/markers.rs"]
mod markers;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use common::{run_command, Sandbox, MANIFEST_DIR};
use hdrflow::formats::packed_float::decode_b10g11r11;
use hdrflow::values::Image;

const REQUIRE: &str = "HDRFLOW_REQUIRE_CMGEN";
const TIMEOUT: Duration = Duration::from_secs(900);

/// `cmgen` on PATH, or `None` after a visible skip.
fn cmgen() -> Option<PathBuf> {
    let found = std::env::var_os("PATH")
        .and_then(|paths| std::env::split_paths(&paths).map(|p| p.join("cmgen")).find(|p| p.is_file()));
    if found.is_none() {
        common::skip(REQUIRE, "cmgen is not on PATH (Debian: apt-get install libfilament-tools)");
    }
    found
}

/// The six faces (+X, -X, +Y, -Y, +Z, -Z) of level 0 of a KTX1 cube map in R11F_G11F_B10F, as
/// both cmgen and hdrflow write them: the 64-byte header, the key/value data, then per level a
/// u32 image size (one face's bytes) and the faces.
fn skybox_faces(path: &Path) -> (usize, Vec<Vec<[f32; 3]>>) {
    let b = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(&b[..12], b"\xABKTX 11\xBB\r\n\x1A\n", "{}", path.display());
    let word = |i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]) as usize;
    assert_eq!(word(28), 0x8C3A, "{}: glInternalFormat R11F_G11F_B10F", path.display());
    let (size, faces, kv) = (word(36), word(52), word(60));
    assert_eq!((word(40), faces), (size, 6), "{}: a square cube", path.display());
    let face_bytes = word(64 + kv);
    assert_eq!(face_bytes, size * size * 4, "{}", path.display());
    let start = 64 + kv + 4;
    let faces = (0..6)
        .map(|f| {
            let face = &b[start + f * face_bytes..start + (f + 1) * face_bytes];
            face.chunks_exact(4).map(|w| decode_b10g11r11(u32::from_le_bytes([w[0], w[1], w[2], w[3]]))).collect()
        })
        .collect();
    (size, faces)
}

/// Where a marker is brightest on a cube: (face, x, y). The score is the marker's colour over
/// the others (red: R - max(G, B); white: min(R, G, B)), so the grey background scores 0.
fn marker_texel(faces: &[Vec<[f32; 3]>], size: usize, colour: [f32; 3]) -> (usize, usize, usize) {
    let score = |p: [f32; 3]| {
        let on: Vec<f32> = (0..3).filter(|&c| colour[c] > 0.0).map(|c| p[c]).collect();
        let off = (0..3).filter(|&c| colour[c] == 0.0).map(|c| p[c]).fold(0.0f32, f32::max);
        on.iter().copied().fold(f32::INFINITY, f32::min) - off
    };
    let mut best = (0, 0, 0, f32::NEG_INFINITY);
    for (f, face) in faces.iter().enumerate() {
        for (i, &p) in face.iter().enumerate() {
            if score(p) > best.3 {
                best = (f, i % size, i / size, score(p));
            }
        }
    }
    (best.0, best.1, best.2)
}

/// The marker's centre on face `face` of a cube: the centroid, weighted by the score of
/// [`marker_texel`] above half its peak, within 8 texels of the peak (x, y in texels, centres at
/// half-integers).
fn marker_centroid(faces: &[Vec<[f32; 3]>], size: usize, colour: [f32; 3]) -> (usize, f64, f64) {
    let (f, px, py) = marker_texel(faces, size, colour);
    let score = |p: [f32; 3]| {
        let on = (0..3).filter(|&c| colour[c] > 0.0).map(|c| p[c]).fold(f32::INFINITY, f32::min);
        let off = (0..3).filter(|&c| colour[c] == 0.0).map(|c| p[c]).fold(0.0f32, f32::max);
        (on - off) as f64
    };
    let peak = score(faces[f][py * size + px]);
    let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
    for y in py.saturating_sub(8)..(py + 9).min(size) {
        for x in px.saturating_sub(8)..(px + 9).min(size) {
            let v = score(faces[f][y * size + x]) - 0.5 * peak;
            if v > 0.0 {
                sx += v * (x as f64 + 0.5);
                sy += v * (y as f64 + 0.5);
                sw += v;
            }
        }
    }
    (f, sx / sw, sy / sw)
}

/// The median over texels and channels of `|a - b| / b`: what the two skyboxes differ by away
/// from edges, which a texel's shift makes large in the RMS.
fn median_relative(a: &[Vec<[f32; 3]>], b: &[Vec<[f32; 3]>]) -> f64 {
    let mut d: Vec<f64> = a
        .iter()
        .flatten()
        .zip(b.iter().flatten())
        .flat_map(|(pa, pb)| (0..3).map(move |c| ((pa[c] - pb[c]).abs() / pb[c].abs().max(1e-6)) as f64))
        .collect();
    let k = d.len() / 2;
    *d.select_nth_unstable_by(k, f64::total_cmp).1
}

/// RMS of the texel differences over RMS of the texels, over every face and channel.
fn relative_rms(a: &[Vec<[f32; 3]>], b: &[Vec<[f32; 3]>]) -> f64 {
    let (mut d, mut n) = (0.0f64, 0.0f64);
    for (fa, fb) in a.iter().zip(b) {
        for (pa, pb) in fa.iter().zip(fb) {
            for c in 0..3 {
                d += (pa[c] as f64 - pb[c] as f64).powi(2);
                n += (pb[c] as f64).powi(2);
            }
        }
    }
    (d / n).sqrt()
}

/// Filament's 9 pre-scaled irradiance coefficients of `map` turned 180 degrees about +Y, exactly:
/// `sh[i] = (A_l / pi) k_i^2 int L(d) P_i(R d) dOmega` with Filament's polynomials `P_i`
/// (shaders/src/surface_light_indirect.fs), `k_i` their orthonormal constants, `A_l` = pi,
/// 2 pi / 3, pi / 4, and `R (x, y, z) = (-x, y, -z)`; each texel (constant radiance over its
/// cell of the lat-long grid) integrated with a 4 x 4 Gauss-Legendre rule in (theta, phi) with
/// the `sin theta` measure.
fn exact_filament_sh(map: &Image) -> [[f64; 3]; 9] {
    use std::f64::consts::PI;
    let (w, h) = (map.width, map.height);
    let nodes = [-0.861_136_311_594_052_6, -0.339_981_043_584_856_3, 0.339_981_043_584_856_3, 0.861_136_311_594_052_6];
    let weights = [0.347_854_845_137_453_9, 0.652_145_154_862_546_1, 0.652_145_154_862_546_1, 0.347_854_845_137_453_9];
    let s = PI.sqrt();
    let (k1, k2) = (3f64.sqrt() / (2.0 * s), 15f64.sqrt() / (2.0 * s));
    let k = [1.0 / (2.0 * s), k1, k1, k1, k2, k2, 5f64.sqrt() / (4.0 * s), k2, 15f64.sqrt() / (4.0 * s)];
    let band = [PI, 2.0 * PI / 3.0, 2.0 * PI / 3.0, 2.0 * PI / 3.0, PI / 4.0, PI / 4.0, PI / 4.0, PI / 4.0, PI / 4.0];
    let (dt, dp) = (PI / h as f64, 2.0 * PI / w as f64);
    // Per row: the integral of each P_i over each column's cell is the same function of the
    // column's phi offset, so integrate per texel directly (1024 x 512 x 16 points: fast enough).
    let mut sum = [[0.0f64; 3]; 9];
    for y in 0..h {
        for x in 0..w {
            let l = map.rgb(x, y);
            let mut cell = [0.0f64; 9];
            for (a, wa) in nodes.iter().zip(weights) {
                let theta = (y as f64 + 0.5 + 0.5 * a) * dt;
                for (b, wb) in nodes.iter().zip(weights) {
                    let phi = (x as f64 + 0.5 + 0.5 * b) * dp;
                    // hdrflow's lat-long: d = (-sin t sin p, cos t, sin t cos p); turned: (-x, y, -z).
                    let (st, ct) = theta.sin_cos();
                    let (sp, cp) = phi.sin_cos();
                    let (dx, dy, dz) = (st * sp, ct, -st * cp);
                    let p = [1.0, dy, dz, dx, dy * dx, dy * dz, 3.0 * dz * dz - 1.0, dz * dx, dx * dx - dy * dy];
                    let m = wa * wb * 0.25 * dt * dp * st;
                    for i in 0..9 {
                        cell[i] += m * p[i];
                    }
                }
            }
            for i in 0..9 {
                for c in 0..3 {
                    sum[i][c] += l[c] as f64 * cell[i];
                }
            }
        }
    }
    std::array::from_fn(|i| sum[i].map(|v| v * band[i] / PI * k[i] * k[i]))
}

/// The 9 RGB triples of a `sh.txt` (cmgen's layout, which hdrflow writes too).
fn read_sh(path: &Path) -> [[f64; 3]; 9] {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let rows: Vec<[f64; 3]> = text
        .lines()
        .filter_map(|l| {
            let inner = l.split_once('(')?.1.split_once(')')?.0;
            let v: Vec<f64> = inner.split(',').map(|t| t.trim().parse().unwrap()).collect();
            Some([v[0], v[1], v[2]])
        })
        .collect();
    rows.try_into().unwrap_or_else(|r: Vec<_>| panic!("{}: {} rows", path.display(), r.len()))
}

/// The largest coefficient error relative to the L00 term (per channel), the error that
/// decides the irradiance's scale and shape.
fn sh_error(got: &[[f64; 3]; 9], exact: &[[f64; 3]; 9]) -> f64 {
    let mut worst = 0.0f64;
    for i in 0..9 {
        for c in 0..3 {
            worst = worst.max((got[i][c] - exact[i][c]).abs() / exact[0][c].abs());
        }
    }
    worst
}

/// Runs `cmd`, asserting success; its wall time in seconds.
fn timed(cmd: Command) -> f64 {
    let t0 = Instant::now();
    run_command(cmd, TIMEOUT).assert_success();
    t0.elapsed().as_secs_f64()
}

/// cmgen's deployment of `map` into `dir` (it names the files after the folder): the
/// skybox, the reflections and `sh.txt`. Its wall time.
fn run_cmgen(cmgen: &Path, map: &Path, dir: &Path) -> f64 {
    let mut cmd = Command::new(cmgen);
    cmd.args(["--quiet", "--format=ktx", "--size=256", "--sh-window=no"]).arg(format!("--deploy={}", dir.display()));
    cmd.arg(map);
    timed(cmd)
}

/// `hdrflow bake MAP --for filament --sun keep` plus `extra`, into `dir`, without the cache.
fn run_bake(sb: &Sandbox, map: &Path, dir: &Path, extra: &[&str]) -> f64 {
    let mut cmd = common::hdrflow_command(["bake"]);
    cmd.arg(map).args(["--for", "filament", "--sun", "keep", "--no-cache", "-q", "--out"]).arg(dir);
    cmd.args(extra).current_dir(sb.path());
    timed(cmd)
}

#[test]
fn cmgen_and_hdrflow_agree_on_orientation_and_hdrflows_sh_are_closer() {
    let Some(cmgen) = cmgen() else { return };
    let sb = Sandbox::new();
    let markers_map =
        common::write_file(&sb.join("markers.hdr"), hdrflow::formats::rgbe::encode(&markers::orientation_map()));
    let park = Path::new(MANIFEST_DIR).join("assets/maps/rooitou_park_1k.hdr");
    eprintln!(
        "| map | skybox: median texel difference | skybox: relative RMS | SH error: hdrflow | SH error: cmgen | cmgen s | hdrflow s | time ratio |"
    );
    eprintln!("|---|---|---|---|---|---|---|---|");
    for (name, map) in [("markers", markers_map.as_path()), ("park", park.as_path())] {
        let peer = sb.join(format!("cmgen_{name}"));
        let cmgen_s = run_cmgen(&cmgen, map, &peer);
        let stem = peer.file_name().unwrap().to_string_lossy().into_owned();
        let ours = sb.join(format!("hdrflow_{name}"));
        let hdrflow_s = run_bake(&sb, map, &ours, &["--yaw", "180"]);
        let map_stem = map.file_stem().unwrap().to_string_lossy().into_owned();

        let (size, theirs) = skybox_faces(&peer.join(format!("{stem}_skybox.ktx")));
        let (our_size, mine) = skybox_faces(&ours.join(format!("{map_stem}_skybox.ktx")));
        assert_eq!(size, our_size, "{name}: skybox sizes");
        let (median, rms) = (median_relative(&mine, &theirs), relative_rms(&mine, &theirs));

        let image = hdrflow::formats::decode_by_extension(&std::fs::read(map).unwrap(), "hdr").unwrap();
        let exact = exact_filament_sh(&image);
        let (ours_sh, theirs_sh) = (read_sh(&ours.join("sh.txt")), read_sh(&peer.join("sh.txt")));
        let (e_ours, e_theirs) = (sh_error(&ours_sh, &exact), sh_error(&theirs_sh, &exact));
        eprintln!(
            "| {name} | {median:.2e} | {rms:.3} | {e_ours:.2e} | {e_theirs:.2e} | {cmgen_s:.2} | {hdrflow_s:.2} | {:.2} |",
            hdrflow_s / cmgen_s
        );
        assert!(
            e_ours <= e_theirs,
            "{name}: hdrflow's SH {e_ours:.3e} off the exact projection, cmgen's {e_theirs:.3e}"
        );
        assert!(e_ours < 1e-4, "{name}: hdrflow's SH {e_ours:.3e} off the exact projection");

        if name == "markers" {
            for m in markers::markers() {
                let (a, b) = (marker_centroid(&mine, size, m.colour), marker_centroid(&theirs, size, m.colour));
                // Turned 180 degrees about +Y, every marker is on +Z (face 4), where OpenGL's
                // lookup gives u = (x / z + 1) / 2, v = (-y / z + 1) / 2.
                let d = glam::DVec3::new(-m.direction.x, m.direction.y, -m.direction.z);
                let exact = ((d.x / d.z + 1.0) / 2.0 * size as f64, (-d.y / d.z + 1.0) / 2.0 * size as f64);
                let off = |c: (usize, f64, f64)| ((c.1 - exact.0).powi(2) + (c.2 - exact.1).powi(2)).sqrt();
                eprintln!(
                    "{}: exact (+Z) ({:.2}, {:.2}); hdrflow face {} ({:.2}, {:.2}), {:.2} texels off; cmgen face {} ({:.2}, {:.2}), {:.2} texels off",
                    m.name, exact.0, exact.1, a.0, a.1, a.2, off(a), b.0, b.1, b.2, off(b)
                );
                assert_eq!((a.0, b.0), (4, 4), "{}: on another face", m.name);
                assert!(off(a) < 0.25, "{}: hdrflow's marker {:.2} texels off", m.name, off(a));
                // cmgen's own sampling puts the markers up to 1.4 texels off (down and left).
                assert!(off(b) < 2.0, "{}: cmgen's marker {:.2} texels off", m.name, off(b));
            }
            // Without the yaw, the centre marker is on the opposite face: the check can fail.
            let unturned = sb.join("hdrflow_markers_unturned");
            run_bake(&sb, map, &unturned, &[]);
            let (_, plain) = skybox_faces(&unturned.join(format!("{map_stem}_skybox.ktx")));
            let centre = &markers::markers()[0];
            let (a, b) = (marker_texel(&plain, size, centre.colour), marker_texel(&theirs, size, centre.colour));
            assert_ne!(a.0, b.0, "without --yaw 180 the centre marker must not be on cmgen's face");
            eprintln!("without --yaw 180: skybox relative RMS {:.3}", relative_rms(&plain, &theirs));
        }
        // Measured: 0 on the markers' grey, 3.3% on the park (cmgen's bilinear lookup, shifted by
        // a texel, against hdrflow's footprint means).
        assert!(median < 0.06, "{name}: the skyboxes' median texel difference {median}");
        // Away from the markers the two skyboxes are equal (the other faces: 0 difference).
        if name == "markers" {
            for f in [0, 1, 2, 3, 5] {
                let rms = relative_rms(&mine[f..f + 1], &theirs[f..f + 1]);
                assert!(rms < 1e-3, "face {f} of the marker map: {rms}");
            }
        }
    }
}
