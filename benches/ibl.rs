//! Image-based lighting measurements (numbers recorded in docs/src/benchmarks/ibl.md, "Image-based lighting"):
//!
//!     cargo bench --bench ibl            # HDRFLOW_IBL_MAP=path.hdr to choose the map
//!     HDRFLOW_IBL_ONLY=sh cargo bench --bench ibl          # section 4 alone
//!     HDRFLOW_IBL_ONLY=prefilter cargo bench --bench ibl   # section 5 alone
//!     HDRFLOW_IBL_ONLY=sun cargo bench --bench ibl         # section 6 alone
//!
//! 1. energy kept by lat-long -> cube -> lat-long resampling, per map;
//! 2. `PrefilterSpecular` error against `exact: true` as the sample count grows (a 64 cube, 5
//!    levels), with the time of each;
//! 3. wall times of the default-size bakes of a 1024x512 map: the 256 cube, the 256 chain
//!    (5 levels, 1024 samples), the irradiance (SH and exact), the BRDF texture;
//! 4. SH irradiance against the exact irradiance, per map, order and window (a 16 cube);
//! 5. `PrefilterSpecular` against `exact: true` on every map, time against error as a log-log
//!    chart (`docs/src/benchmarks/data/prefilter_time_error.svg`);
//! 6. what `SunExtract` does to the prefilter's error: sampled residual plus the sun's exact
//!    part, against sampling the whole map, at equal samples.
//!
//! A plain program (no criterion: one bake takes seconds); each time is the median of 3 runs.

use std::path::Path;
use std::time::Instant;

use hdrflow::maths::brdf::ggx::LobeSequence;
use hdrflow::maths::ibl::irradiance_cube::{exact, from_sh, project_latlong, ShWindow, Texels};
use hdrflow::maths::ibl::luts::brdf_lut;
use hdrflow::maths::ibl::prefilter::prefilter;
use hdrflow::maths::resample::layouts::{
    cube_integral, latlong_integral, to_cube, to_latlong, CubeSource, LatLongSource,
};
use hdrflow::values::{Cubemap, Image};

fn median<T>(mut f: impl FnMut() -> T) -> (f64, T) {
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..3 {
        let t = Instant::now();
        last = Some(f());
        times.push(t.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    (times[1], last.expect("ran"))
}

fn load(path: &Path) -> Option<Image> {
    let bytes = std::fs::read(path).ok()?;
    let ext = path.extension()?.to_string_lossy().to_lowercase();
    hdrflow::formats::decode_by_extension(&bytes, &ext).ok()
}

fn rel(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| ((a[k] - b[k]) / b[k]).abs()).fold(0.0, f64::max)
}

fn main() {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/envmaps");
    let mut maps: Vec<(String, Image)> =
        vec![("builtin:sky".into(), hdrflow::formats::builtin::builtin("sky").expect("built-in"))];
    for name in ["rooitou_park_1k.hdr", "st_fagans_interior_1k.hdr", "studio_small_03_1k.hdr", "grace-new_256x128.hdr"]
    {
        // The maps that ship in assets/maps/ are read from there, the others from ../shared/data.
        let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/maps").join(name);
        if let Some(img) = load(&if shipped.is_file() { shipped } else { shared.join(name) }) {
            maps.push((name.into(), img));
        }
    }
    match std::env::var("HDRFLOW_IBL_ONLY").as_deref() {
        Ok("sh") => return sh_table(&maps),
        Ok("prefilter") => return prefilter_all_maps(&maps),
        Ok("sun") => return sun_split(&maps),
        _ => {}
    }
    println!("## 1. energy (max over RGB of the relative error of the sphere integral)\n");
    println!("| map | size | cube 64 | cube 256 | back to lat-long from 256 | time to cube 256 |");
    println!("|---|---|---|---|---|---|");
    for (name, img) in &maps {
        let want = latlong_integral(img);
        let c64 = to_cube(&LatLongSource::new(img), 64);
        let (t, c256) = median(|| to_cube(&LatLongSource::new(img), 256));
        let back = to_latlong(&CubeSource::new(&c256), img.width, img.height);
        println!(
            "| {name} | {}x{} | {:.1e} | {:.1e} | {:.1e} | {:.2} s |",
            img.width,
            img.height,
            rel(cube_integral(&c64), want),
            rel(cube_integral(&c256), want),
            rel(latlong_integral(&back), want),
            t
        );
    }

    let env: Image = std::env::var("HDRFLOW_IBL_MAP")
        .ok()
        .and_then(|p| load(Path::new(&p)))
        .or_else(|| load(&shared.join("rooitou_park_1k.hdr")))
        .unwrap_or_else(|| maps[0].1.clone());
    println!(
        "\n## 2. PrefilterSpecular error against exact (64 cube, 5 levels, Sobol), map {}x{}\n",
        env.width, env.height
    );
    let src = to_cube(&LatLongSource::new(&env), 64);
    let t = Instant::now();
    let reference = prefilter(&src, 5, 1, LobeSequence::Sobol, true);
    let t_exact = t.elapsed().as_secs_f64();
    println!("exact: {t_exact:.2} s\n");
    println!("| samples | RMS relative error, level 1 (r 0.25) | level 2 | level 3 | level 4 | all levels | time |");
    println!("|---|---|---|---|---|---|---|");
    for n in [16, 64, 256, 1024, 4096] {
        let (t, chain) = median(|| prefilter(&src, 5, n, LobeSequence::Sobol, false));
        let mut cells = Vec::new();
        let (mut all, mut count) = (0.0, 0.0);
        for (a, b) in chain.levels.iter().zip(&reference.levels).skip(1) {
            let (mut s, mut c) = (0.0, 0.0);
            for (x, y) in a.data.iter().zip(&b.data) {
                let e = (*x as f64 - *y as f64) / (*y as f64).abs().max(1e-6);
                s += e * e;
                c += 1.0;
            }
            all += s;
            count += c;
            cells.push(format!("{:.4}", (s / c).sqrt()));
        }
        println!("| {n} | {} | {:.4} | {t:.3} s |", cells.join(" | "), (all / count).sqrt());
    }

    println!("\n## 3. bake times, {}x{} map\n", env.width, env.height);
    let (t_cube, cube256): (f64, Cubemap) = median(|| to_cube(&LatLongSource::new(&env), 256));
    println!("| step | time |\n|---|---|");
    println!("| lat-long to 256 cube | {t_cube:.2} s |");
    let (t, _) = median(|| prefilter(&cube256, 5, 1024, LobeSequence::Sobol, false));
    println!("| PrefilterSpecular, 256 cube, 5 levels, 1024 samples (from the cube) | {t:.2} s |");
    let (t, _) = median(|| from_sh(&project_latlong(&env, 2), 2, ShWindow::Deringing, 32));
    println!("| IrradianceCubemap Sh order 2 Deringing, 32 cube | {t:.3} s |");
    let (t, _) = median(|| exact(&Texels::from_latlong(&env), 16));
    println!("| IrradianceCubemap Exact, 16 cube | {t:.2} s |");
    let (t, lut) = median(|| brdf_lut(128, 1024, LobeSequence::Hammersley, false));
    println!("| BrdfLut 128, 1024 samples | {t:.3} s |");
    let multi = brdf_lut(128, 1024, LobeSequence::Hammersley, true);
    let top = lut.data.chunks(2).map(|p| p[0] + p[1]).fold(0.0f32, f32::max);
    let top_multi = multi.data.chunks(2).map(|p| p[1]).fold(0.0f32, f32::max);
    let low_multi = multi.data.chunks(2).map(|p| p[1]).fold(1.0f32, f32::min);
    prefilter_all_maps(&maps);
    sun_split(&maps);
    sh_table(&maps);
    println!(
        "\nBrdfLut 128: largest scale + bias {top:.6}; multiscatter E[Gv] in [{low_multi:.4}, {top_multi:.6}] \
         (1 - E[Gv] is the energy multiple scattering adds back)"
    );
}

/// Section 4: `IrradianceCubemap` `Sh` against `Exact` on a 16 cube, for every map, SH order 1 to
/// 6 and every window: the RMS error over texels and channels relative to the mean exact
/// irradiance, and the most negative value relative to that mean (ringing).
fn sh_table(maps: &[(String, Image)]) {
    const SIZE: usize = 16;
    let windows = [ShWindow::None, ShWindow::Hann, ShWindow::Lanczos, ShWindow::Deringing];
    println!("\n## 4. SH irradiance against exact ({SIZE} cube): RMS error / mean, most negative value / mean\n");
    for (name, img) in maps {
        let truth = exact(&Texels::from_latlong(img), SIZE);
        let mean: f64 = truth.data.iter().map(|&v| v as f64).sum::<f64>() / truth.data.len() as f64;
        println!("{name}:\n\n| order | None | Hann | Lanczos | Deringing (strength) |\n|---|---|---|---|---|");
        for order in 1..=6 {
            let coeffs = project_latlong(img, order);
            let mut cells = Vec::new();
            for w in windows {
                let (cube, report) = from_sh(&coeffs, order, w, SIZE);
                let mut sq = 0.0;
                let mut lowest = 0.0f64;
                for (got, want) in cube.data.chunks(3).zip(truth.data.chunks(3)) {
                    let mut e = 0.0;
                    for k in 0..3 {
                        e += ((got[k] - want[k]) as f64).powi(2) / 3.0;
                        lowest = lowest.min(got[k] as f64 / mean);
                    }
                    sq += e;
                }
                let rms = (sq / (cube.data.len() / 3) as f64).sqrt() / mean;
                let strength =
                    if w == ShWindow::Deringing { format!(" ({:.3})", report.strength) } else { String::new() };
                cells.push(format!("{rms:.3} / {lowest:.3}{strength}"));
            }
            println!("| {order} | {} |", cells.join(" | "));
        }
        println!();
    }
}

/// The RMS over texels of levels 1.. of the relative error of `chain` against `reference`.
fn chain_error(chain: &hdrflow::values::MipChain, reference: &hdrflow::values::MipChain) -> f64 {
    let (mut sum, mut count) = (0.0f64, 0.0f64);
    for (a, b) in chain.levels.iter().zip(&reference.levels).skip(1) {
        for (x, y) in a.data.iter().zip(&b.data) {
            let y = *y as f64;
            if y > 0.0 {
                sum += ((*x as f64 - y) / y).powi(2);
                count += 1.0;
            }
        }
    }
    (sum / count.max(1.0)).sqrt()
}

/// Section 5: every map as a 64 cube, 5 levels, Sobol, 16 to 4096 samples: the RMS relative
/// error of levels 1-4 against `exact: true` and the time, as a table and a log-log chart.
fn prefilter_all_maps(maps: &[(String, Image)]) {
    use hdrflow::plotting::time_error::{plot_svg, Line};
    let counts = [16, 64, 256, 1024, 4096];
    println!("\n## 5. PrefilterSpecular against exact on every map (64 cube, levels 1-4): RMS relative error (time)\n");
    println!("| map | exact | {} |", counts.map(|n| format!("{n} samples")).join(" | "));
    println!("|---|---|{}", "---|".repeat(counts.len()));
    let mut lines = Vec::new();
    for (name, img) in maps {
        let src = to_cube(&LatLongSource::new(img), 64);
        let t = Instant::now();
        let reference = prefilter(&src, 5, 1, LobeSequence::Sobol, true);
        let t_exact = t.elapsed().as_secs_f64();
        let mut cells = Vec::new();
        let mut points = Vec::new();
        for n in counts {
            let (t, chain) = median(|| prefilter(&src, 5, n, LobeSequence::Sobol, false));
            let e = chain_error(&chain, &reference);
            cells.push(format!("{e:.3} ({t:.2} s)"));
            points.push((t * 1e3, e));
        }
        println!("| {name} | {t_exact:.2} s | {} |", cells.join(" | "));
        lines.push(Line { name: name.clone(), points, ci: Vec::new() });
    }
    let out = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/src/benchmarks/data/prefilter_time_error.svg");
    match plot_svg("PrefilterSpecular, 64 cube: time (ms) against RMS relative error", &lines, 900, 600) {
        Ok(svg) => match std::fs::write(&out, svg) {
            Ok(()) => println!("\nchart: {}", out.display()),
            Err(e) => eprintln!("writing {}: {e}", out.display()),
        },
        Err(e) => eprintln!("chart: {e}"),
    }
}

/// Section 6: the prefilter is a fixed weighted average of the map, so it is linear: exact(map) =
/// exact(residual) + exact(sun), where `sun = map - residual` is zero outside the sun's texels.
/// Sampling only the residual and adding the sun's part exactly (what a renderer does with an
/// analytic light; here through `exact: true` on the sun-only map) is compared with sampling the
/// whole map, at equal samples, against the exact chain of the whole map.
fn sun_split(maps: &[(String, Image)]) {
    let counts = [64, 256, 1024];
    println!("\n## 6. PrefilterSpecular with SunExtract (64 cube, levels 1-4, RMS relative error against exact)\n");
    println!("| map | sun share | {} |", counts.map(|n| format!("{n}: whole map / residual + exact sun")).join(" | "));
    println!("|---|---|{}", "---|".repeat(counts.len()));
    for (name, img) in maps {
        let split = hdrflow::maths::fit::sun::extract_sun(img, 8.0);
        let mut sun_only = img.clone();
        for (s, r) in sun_only.data.iter_mut().zip(&split.residual.data) {
            *s -= r;
        }
        let whole = to_cube(&LatLongSource::new(img), 64);
        let residual = to_cube(&LatLongSource::new(&split.residual), 64);
        let sun = to_cube(&LatLongSource::new(&sun_only), 64);
        let reference = prefilter(&whole, 5, 1, LobeSequence::Sobol, true);
        let sun_exact = prefilter(&sun, 5, 1, LobeSequence::Sobol, true);
        let total = hdrflow::maths::fit::sun::integral(img);
        let [wr, wg, wb] = hdrflow::colour::REC709;
        let lum = |c: [f64; 3]| wr * c[0] + wg * c[1] + wb * c[2];
        let share = 1.0 - lum(hdrflow::maths::fit::sun::integral(&split.residual)) / lum(total);
        let mut cells = Vec::new();
        for n in counts {
            let plain = prefilter(&whole, 5, n, LobeSequence::Sobol, false);
            let mut split_chain = prefilter(&residual, 5, n, LobeSequence::Sobol, false);
            for (level, sun_level) in split_chain.levels.iter_mut().zip(&sun_exact.levels) {
                for (v, s) in level.data.iter_mut().zip(&sun_level.data) {
                    *v += s;
                }
            }
            cells.push(format!(
                "{:.3} / {:.3}",
                chain_error(&plain, &reference),
                chain_error(&split_chain, &reference)
            ));
        }
        println!("| {name} | {:.1}% | {} |", 100.0 * share, cells.join(" | "));
    }
}
