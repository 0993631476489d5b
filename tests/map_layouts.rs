//! Map layouts (issue 26) end to end, through RON pipelines: the mirror ball both ways (closed
//! forms on `f(d) = d.y + 2`, a single bright texel landing at the predicted pixel, the ball's
//! back direction on its rim, masks and `ball_fraction`), the angular probe's round trip, the
//! sky hemispheres (bit-exact sky lat-long round trip, sky-angular orientation and fill), and
//! every bad input as a pipeline error naming the node. The expected values are computed here
//! from the formulas of docs/src/guides/toolkit/map_layouts.md, not from the library's mapping code.

mod common;

use std::collections::BTreeMap;
use std::f64::consts::PI;

use glam::DVec3;
use hdrflow::engine::value::Value;
use hdrflow::geometry::latlong;
use hdrflow::geometry::rotation::Rotation;
use hdrflow::values::Image;

fn run(text: &str, targets: &[&str]) -> Result<BTreeMap<String, Value>, String> {
    common::run_text(text, targets)
}

fn image<'a>(v: &'a BTreeMap<String, Value>, node: &str) -> &'a Image {
    v[node].get::<Image>().unwrap_or_else(|| panic!("{node} is not an image"))
}

/// A W x H RGB lat-long map, every texel `f` of its centre direction.
fn latlong_of(w: usize, h: usize, f: impl Fn(DVec3) -> f64) -> Image {
    Image::from_fn_rgb(w, h, |x, y| [f(DVec3::from(latlong::texel_direction(x, y, w, h))) as f32; 3])
}

/// An N x N RGB disc image, every pixel `f` of its centre (u, v) (v up).
fn disc_of(n: usize, f: impl Fn(f64, f64) -> f64) -> Image {
    Image::from_fn_rgb(n, n, |x, y| {
        let (u, v) = (2.0 * (x as f64 + 0.5) / n as f64 - 1.0, 1.0 - 2.0 * (y as f64 + 0.5) / n as f64);
        [f(u, v) as f32; 3]
    })
}

/// Writes `img` as a PFM in the sandbox; returns its path as a RON string.
fn save(sb: &common::Sandbox, name: &str, img: &Image) -> String {
    common::ron_path(&sb.write(name, hdrflow::formats::pfm::encode(img)))
}

/// The camera frame (right, up, towards the camera) of yaw and pitch, R = R_y(yaw) R_x(pitch).
fn camera(yaw: f64, pitch: f64) -> (DVec3, DVec3, DVec3) {
    let r = Rotation::from_yaw_pitch_roll(yaw, pitch, 0.0);
    (r.apply(DVec3::X), r.apply(DVec3::Y), r.apply(DVec3::Z))
}

/// The brief's reflection: n = (u, v, sqrt(1 - u^2 - v^2)) in the camera frame, r = 2 (n.c) n - c.
fn ball_reflection(frame: (DVec3, DVec3, DVec3), u: f64, v: f64) -> DVec3 {
    let (right, up, c) = frame;
    let n = right * u + up * v + c * (1.0 - u * u - v * v).max(0.0).sqrt();
    n * (2.0 * n.dot(c)) - c
}

/// The ball's (u, v) of direction d: the half vector between d and c.
fn ball_uv(frame: (DVec3, DVec3, DVec3), d: DVec3) -> (f64, f64) {
    let n = (d + frame.2).normalize();
    (n.dot(frame.0), n.dot(frame.1))
}

/// The brightest pixel of channel 0.
fn argmax(img: &Image) -> (usize, usize) {
    let mut best = (f32::MIN, (0, 0));
    for y in 0..img.height {
        for x in 0..img.width {
            if img.pixel(x, y)[0] > best.0 {
                best = (img.pixel(x, y)[0], (x, y));
            }
        }
    }
    best.1
}

#[test]
fn the_mirror_ball_matches_its_closed_form_and_round_trips_away_from_the_silhouette() {
    let sb = common::Sandbox::new();
    let env = latlong_of(1024, 512, |d| d.y + 2.0);
    let text = format!(
        r#"(nodes: {{
        "env":  LoadHdr(path: {}),
        "ball": LatLongToMirrorBall(env: "env", size: 256, yaw: 90),
        "look": LatLongToMirrorBall(env: "env", size: 256, look: (-2, 0, 0)),
        "back": MirrorBallToLatLong(image: "ball", yaw: 90, width: 1024, height: 512),
    }})"#,
        save(&sb, "env.pfm", &env)
    );
    let v = run(&text, &["ball", "look", "back", "back.mask"]).expect("runs");
    let (ball, look) = (image(&v, "ball"), image(&v, "look"));
    // The camera looks along -X: c = +X, right = -Z, up = +Y.
    let frame = camera(90.0, 0.0);
    let mut worst = 0.0f64;
    for y in 0..256 {
        for x in 0..256 {
            let (u, w) = (2.0 * (x as f64 + 0.5) / 256.0 - 1.0, 1.0 - 2.0 * (y as f64 + 0.5) / 256.0);
            let got = ball.pixel(x, y)[0] as f64;
            assert!((got - look.pixel(x, y)[0] as f64).abs() < 1e-5, "look differs from yaw at ({x}, {y})");
            if u * u + w * w > 1.0 {
                assert_eq!(got, 0.0, "outside the disc ({x}, {y})");
            } else if u * u + w * w < 0.95 * 0.95 {
                worst = worst.max((got - (ball_reflection(frame, u, w).y + 2.0)).abs());
            }
        }
    }
    // The source is piecewise constant: a texel holds f at its centre, which differs from f on
    // a pixel's footprint by up to |grad f| (1 per radian) times half a texel's diagonal (4.3e-3
    // rad at 1024 x 512), hence 5e-3; a layout off by one pixel would be off by about
    // |grad f| 4 / N = 1.6e-2 near the ball's centre.
    eprintln!("ball vs closed form: worst {worst:.2e}");
    assert!(worst < 5e-3, "{worst}");
    // Back to lat-long: the same map away from the back direction -c = -X.
    let back = image(&v, "back");
    let mask = image(&v, "back.mask");
    let mut worst = 0.0f64;
    for y in 0..512 {
        for x in 0..1024 {
            assert_eq!(mask.pixel(x, y)[0], 1.0, "unseen texel ({x}, {y})");
            let d = DVec3::from(latlong::texel_direction(x, y, 1024, 512));
            if d.angle_between(DVec3::NEG_X) > 30f64.to_radians() {
                worst = worst.max((back.pixel(x, y)[0] - env.pixel(x, y)[0]).abs() as f64);
            }
        }
    }
    eprintln!("ball round trip beyond 30 degrees of the back direction: worst {worst:.2e}");
    assert!(worst < 1e-2, "{worst}");
}

#[test]
fn a_bright_texel_lands_at_the_predicted_pixel_in_every_disc_layout() {
    let sb = common::Sandbox::new();
    let (w, h) = (256, 128);
    let (x0, y0) = (40, 30);
    let mut env = Image::new(w, h, 3);
    env.pixel_mut(x0, y0).copy_from_slice(&[1000.0; 3]);
    let d = DVec3::from(latlong::texel_direction(x0, y0, w, h));
    let power = 1000.0 * latlong::texel_solid_angle(y0, w, h);
    let text = format!(
        r#"(nodes: {{
        "env":     LoadHdr(path: {}),
        "ball":    LatLongToMirrorBall(env: "env", size: 128, yaw: -35, pitch: 20),
        "angular": LatLongToAngular(env: "env", size: 128),
        "sky":     LatLongToSkyAngular(env: "env", size: 128),
    }})"#,
        save(&sb, "env.pfm", &env)
    );
    let v = run(&text, &["ball", "angular", "sky"]).expect("runs");
    let n = 128.0;
    let r_ang = (-d.z).acos() / PI;
    let s = (d.x * d.x + d.y * d.y).sqrt();
    let theta = d.y.acos();
    let s_sky = (d.x * d.x + d.z * d.z).sqrt();
    let r_sky = theta / (PI / 2.0);
    let predicted = [
        ("ball", ball_uv(camera(-35.0, 20.0), d), 4.0),
        ("angular", (d.x / s * r_ang, d.y / s * r_ang), 0.0),
        // Sky angular: +X right, +Z up in the image (-Z at the bottom).
        ("sky", (d.x / s_sky * r_sky, d.z / s_sky * r_sky), 0.0),
    ];
    for (node, (u, vv), density) in predicted {
        let img = image(&v, node);
        let (px, py) = ((u + 1.0) * 0.5 * n - 0.5, (1.0 - vv) * 0.5 * n - 0.5);
        let (ax, ay) = argmax(img);
        eprintln!("{node}: brightest ({ax}, {ay}), predicted ({px:.2}, {py:.2})");
        assert!((ax as f64 - px).abs() <= 1.0 && (ay as f64 - py).abs() <= 1.0, "{node}");
        if density > 0.0 {
            // The ball is equal-area: every pixel is 16 / N^2 sr, so the texel's power is kept.
            let sum: f64 = img.data.iter().step_by(3).map(|&p| p as f64).sum::<f64>() * density * (2.0 / n).powi(2);
            eprintln!("{node}: power {sum:.6} vs {power:.6}");
            assert!((sum - power).abs() < 1e-3 * power, "{sum} vs {power}");
        }
    }
}

#[test]
fn the_ball_rim_shows_the_back_direction_and_the_mask_follows_ball_fraction() {
    let sb = common::Sandbox::new();
    // 1 within 30 degrees of -Z (behind the ball for the default camera), 0 elsewhere.
    let cap = latlong_of(512, 256, |d| if d.angle_between(DVec3::NEG_Z) < 30f64.to_radians() { 1.0 } else { 0.0 });
    // A ball photograph: 1 on the ring r >= sin(75 deg) (reflecting the 30-degree cap around
    // -Z), 0 inside it, 1000 nowhere; and one 1 inside r <= 0.9, 1000 beyond.
    let rim = (75f64).to_radians().sin();
    let ring = disc_of(256, |u, v| if (u * u + v * v).sqrt() >= rim { 1.0 } else { 0.0 });
    let hot_rim = disc_of(256, |u, v| if u * u + v * v <= 0.81 { 1.0 } else { 1000.0 });
    let text = format!(
        r#"(nodes: {{
        "cap":    LoadHdr(path: {}),
        "ring":   LoadHdr(path: {}),
        "hot":    LoadHdr(path: {}),
        "ball":   LatLongToMirrorBall(env: "cap", size: 256),
        "unwrap": MirrorBallToLatLong(image: "ring", width: 512, height: 256),
        "part":   MirrorBallToLatLong(image: "hot", ball_fraction: 0.9, width: 512, height: 256),
    }})"#,
        save(&sb, "cap.pfm", &cap),
        save(&sb, "ring.pfm", &ring),
        save(&sb, "hot.pfm", &hot_rim)
    );
    let v = run(&text, &["ball", "unwrap", "part", "part.mask"]).expect("runs");
    let ball = image(&v, "ball");
    let px = 2.0 / 256.0;
    for y in 0..256 {
        for x in 0..256 {
            let (u, w) = (2.0 * (x as f64 + 0.5) / 256.0 - 1.0, 1.0 - 2.0 * (y as f64 + 0.5) / 256.0);
            let r = (u * u + w * w).sqrt();
            let got = ball.pixel(x, y)[0];
            if r < rim - 2.0 * px {
                assert_eq!(got, 0.0, "({x}, {y}) r {r}");
            } else if r > rim + 2.0 * px && r <= 1.0 {
                assert!((got - 1.0).abs() < 1e-6, "({x}, {y}) r {r}: {got}");
            }
        }
    }
    let unwrap = image(&v, "unwrap");
    for y in 0..256 {
        for x in 0..512 {
            let a = DVec3::from(latlong::texel_direction(x, y, 512, 256)).angle_between(DVec3::NEG_Z).to_degrees();
            let got = unwrap.pixel(x, y)[0];
            // Near the rim one ball pixel spans dalpha = 2 dr / sqrt(1 - r^2), 3.4 degrees at the
            // ring's r = 0.966 on a 256 ball: the bilinear taps reach 2 pixels either side.
            if a < 22.0 {
                assert_eq!(got, 1.0, "({x}, {y}) at {a} degrees from -Z");
            } else if a > 38.0 {
                assert_eq!(got, 0.0, "({x}, {y}) at {a} degrees from -Z");
            }
        }
    }
    // ball_fraction 0.9: seen exactly where d.c >= 1 - 2 f^2 (c = +Z), give or take the pixels
    // along that circle; nothing from beyond it.
    let (part, mask) = (image(&v, "part"), image(&v, "part.mask"));
    let (inner, outer) = (1.0 - 2.0 * 0.9f64.powi(2), 1.0 - 2.0 * (0.9 - 2.0 * px).powi(2));
    let mut seen = 0.0;
    for y in 0..256 {
        for x in 0..512 {
            let dz = latlong::texel_direction(x, y, 512, 256)[2];
            let (m, val) = (mask.pixel(x, y)[0], part.pixel(x, y)[0]);
            assert!(m == 0.0 || m == 1.0);
            if m == 1.0 {
                assert!(dz >= inner, "({x}, {y}) seen at d.c {dz}");
                assert_eq!(val, 1.0, "({x}, {y}) mixed in pixels beyond ball_fraction");
                seen += latlong::texel_solid_angle(y, 512, 256);
            } else {
                assert!(dz < outer, "({x}, {y}) unseen at d.c {dz}");
                assert_eq!(val, 0.0);
            }
        }
    }
    // The ball is equal-area, so the fraction f of its radius sees the share f^2 of the sphere
    // (the cap d.c >= 1 - 2 f^2), up to the texels along the cap's edge.
    let share = seen / (4.0 * PI);
    eprintln!("ball_fraction 0.9: {share:.5} of the sphere seen (f^2 = 0.81)");
    assert!((share - 0.81).abs() < 5e-3, "{share}");
}

#[test]
fn the_angular_probe_round_trips_and_matches_its_closed_form() {
    let sb = common::Sandbox::new();
    let env = latlong_of(1024, 512, |d| d.y + 2.0);
    let text = format!(
        r#"(nodes: {{
        "env":     LoadHdr(path: {}),
        "angular": LatLongToAngular(env: "env", size: 512),
        "back":    AngularToLatLong(image: "angular", width: 1024, height: 512),
    }})"#,
        save(&sb, "env.pfm", &env)
    );
    let v = run(&text, &["angular", "back"]).expect("runs");
    let angular = image(&v, "angular");
    let mut worst = 0.0f64;
    for y in 0..512 {
        for x in 0..512 {
            let (u, w) = (2.0 * (x as f64 + 0.5) / 512.0 - 1.0, 1.0 - 2.0 * (y as f64 + 0.5) / 512.0);
            let r = (u * u + w * w).sqrt();
            let got = angular.pixel(x, y)[0] as f64;
            if r > 1.0 {
                assert_eq!(got, 0.0);
            } else if r < 0.95 {
                // d = (sin(pi r) u / r, sin(pi r) v / r, -cos(pi r)): f = 2 + sin(pi r) v / r.
                worst = worst.max((got - (2.0 + (PI * r).sin() * w / r)).abs());
            }
        }
    }
    eprintln!("angular vs closed form: worst {worst:.2e}");
    assert!(worst < 5e-3, "{worst}");
    let back = image(&v, "back");
    let mut worst = 0.0f64;
    for y in 0..512 {
        for x in 0..1024 {
            let d = DVec3::from(latlong::texel_direction(x, y, 1024, 512));
            if d.angle_between(DVec3::Z) > 20f64.to_radians() {
                worst = worst.max((back.pixel(x, y)[0] - env.pixel(x, y)[0]).abs() as f64);
            }
        }
    }
    eprintln!("angular round trip beyond 20 degrees of +Z: worst {worst:.2e}");
    assert!(worst < 1e-2, "{worst}");
}

#[test]
fn sky_lat_long_round_trips_bit_exactly_and_sky_angular_puts_minus_z_at_the_bottom() {
    let sb = common::Sandbox::new();
    let f = |d: DVec3| 2.0 - d.z + 0.5 * d.y;
    let env = latlong_of(1024, 512, f);
    let text = format!(
        r#"(nodes: {{
        "park":  LoadHdr(path: "assets/maps/rooitou_park_1k.hdr"),
        "sky":   LatLongToSkyLatLong(env: "park"),
        "full":  SkyLatLongToLatLong(image: "sky", fill: [0.25]),
        "rgb":   SkyLatLongToLatLong(image: "sky", fill: (1, 2, 3)),
        "env":   LoadHdr(path: {}),
        "disc":  LatLongToSkyAngular(env: "env", size: 256),
        "back":  SkyAngularToLatLong(image: "disc", width: 1024, height: 512, fill: [7]),
    }})"#,
        save(&sb, "env.pfm", &env)
    );
    let v = run(&text, &["park", "sky", "full", "full.mask", "rgb", "disc", "back", "back.mask"]).expect("runs");
    let (park, sky, full, mask) = (image(&v, "park"), image(&v, "sky"), image(&v, "full"), image(&v, "full.mask"));
    let (w, h) = (park.width, park.height);
    assert_eq!((sky.width, sky.height, full.width, full.height), (w, h / 2, w, h));
    let half = w * (h / 2) * 3;
    assert_eq!(sky.data, park.data[..half], "sky lat-long is not the upper half rows");
    assert_eq!(full.data[..half], park.data[..half], "the round trip changed the sky");
    assert!(full.data[half..].iter().all(|&x| x == 0.25));
    assert!(mask.data.iter().enumerate().all(|(i, &m)| m == if i < w * h / 2 { 1.0 } else { 0.0 }));
    let rgb = image(&v, "rgb");
    assert!(rgb.data[half..].chunks(3).all(|p| p == [1.0, 2.0, 3.0]));

    // Sky angular: d = (sin a u / r, cos a, sin a v / r), a = (pi / 2) r: +X right, -Z at the bottom.
    let disc = image(&v, "disc");
    let mut worst = 0.0f64;
    for y in 0..256 {
        for x in 0..256 {
            let (u, vv) = (2.0 * (x as f64 + 0.5) / 256.0 - 1.0, 1.0 - 2.0 * (y as f64 + 0.5) / 256.0);
            let r = (u * u + vv * vv).sqrt();
            let got = disc.pixel(x, y)[0] as f64;
            if r > 1.0 {
                assert_eq!(got, 0.0);
            } else if r < 0.97 {
                let a = PI / 2.0 * r;
                let d = if r == 0.0 { DVec3::Y } else { DVec3::new(a.sin() * u / r, a.cos(), a.sin() * vv / r) };
                worst = worst.max((got - f(d)).abs());
            }
        }
    }
    eprintln!("sky angular vs closed form: worst {worst:.2e}");
    assert!(worst < 5e-3, "{worst}");
    // The bottom of the disc is brighter (2 - d.z largest at -Z) than its top.
    assert!(disc.pixel(128, 250)[0] > disc.pixel(128, 5)[0] + 1.5);
    let (back, bmask) = (image(&v, "back"), image(&v, "back.mask"));
    let mut worst = 0.0f64;
    for y in 0..512 {
        for x in 0..1024 {
            let m = bmask.pixel(x, y)[0];
            assert_eq!(m, if y < 256 { 1.0 } else { 0.0 }, "mask ({x}, {y})");
            if y >= 256 {
                assert_eq!(back.pixel(x, y), [7.0; 3]);
            } else if y < 248 {
                worst = worst.max((back.pixel(x, y)[0] - env.pixel(x, y)[0]).abs() as f64);
            }
        }
    }
    eprintln!("sky angular round trip above 3 degrees of elevation: worst {worst:.2e}");
    assert!(worst < 1e-2, "{worst}");
}

#[test]
fn bad_inputs_are_pipeline_errors_naming_the_node() {
    let sb = common::Sandbox::new();
    let wide = save(&sb, "wide.pfm", &Image::new(64, 48, 3));
    let square = save(&sb, "square.pfm", &Image::new(64, 64, 3));
    let cases = [
        (r#""b": MirrorBallToLatLong(image: "in"),"#, wide.as_str(), "must be square"),
        (r#""b": SkyAngularToLatLong(image: "in"),"#, wide.as_str(), "must be square"),
        (r#""b": MirrorBallToLatLong(image: "in", ball_fraction: 0),"#, square.as_str(), "(0, 1]"),
        (r#""b": MirrorBallToLatLong(image: "in", ball_fraction: 1.5),"#, square.as_str(), "ball_fraction"),
        (r#""b": MirrorBallToLatLong(image: "in", yaw: 5, look: (0, 0, -1)),"#, square.as_str(), "not both"),
        (r#""b": LatLongToMirrorBall(env: "in", look: (0, 0, 0)),"#, square.as_str(), "non-zero"),
        (r#""b": LatLongToSkyLatLong(env: "odd"),"#, square.as_str(), "odd height"),
    ];
    for (node, input, needle) in cases {
        let text = format!(
            "(nodes: {{\n    \"in\": LoadHdr(path: {input}),\n    \"odd\": Constant(width: 8, height: 5, color: 1),\n    {node}\n}})"
        );
        let e = run(&text, &["b"]).unwrap_err();
        eprintln!("{e}");
        assert!(e.contains("4:") && e.contains("\"b\"") && e.contains(needle), "{needle}: {e}");
    }
    // Known only when it runs: a port of unknown size, and a fill of the wrong length.
    let text = format!(
        r#"(nodes: {{
        "in":  LoadHdr(path: {wide}),
        "sun": SunExtract(env: "in"),
        "b":   MirrorBallToLatLong(image: "sun.residual"),
    }})"#
    );
    let e = run(&text, &["b"]).unwrap_err();
    eprintln!("{e}");
    assert!(e.contains("\"b\"") && e.contains("64x48") && e.contains("must be square"), "{e}");
    let text = r#"(nodes: {
        "env": LoadHdr(path: "builtin:constant"),
        "sky": LatLongToSkyLatLong(env: "env"),
        "b":   SkyLatLongToLatLong(image: "sky", fill: (1, 2)),
    })"#;
    let e = run(text, &["b"]).unwrap_err();
    eprintln!("{e}");
    assert!(e.contains("\"b\"") && e.contains("fill has 2 values"), "{e}");
}

/// The documented example, `graphs/map_layouts.ron`, run by the binary on the bundled park map:
/// it writes every file, the ball keeps the map's integral (its 69,000 sun included), and the
/// unwrapped ball's mask covers the share 0.95^2 of the sphere.
#[test]
fn the_documented_pipeline_runs_on_the_park() {
    let sb = common::Sandbox::new();
    let graph = std::path::Path::new(common::MANIFEST_DIR).join("graphs/map_layouts.ron");
    let started = std::time::Instant::now();
    let (_, report) = sb.run_ok(&graph, &[]);
    eprintln!("graphs/map_layouts.ron: {:.2?}", started.elapsed());
    assert_eq!(report.status_of("s_ball"), "computed");
    let load = |name: &str| {
        let bytes = common::read_file(&sb.out().join(name));
        hdrflow::formats::decode_by_extension(&bytes, name.rsplit('.').next().unwrap()).expect("decodes")
    };
    for f in ["unwrap_mask.exr", "sky_angular.png", "angular.exr", "sky_latlong.exr", "sky_full.exr"] {
        assert!(sb.out().join(f).is_file(), "{f} not written");
    }
    let park = load_park();
    let ball = load("ball.exr");
    let want = hdrflow::maths::resample::layouts::latlong_integral(&park);
    let map = hdrflow::geometry::azimuthal::DiscMap::mirror_ball(DVec3::X, DVec3::Y, DVec3::Z);
    let got = hdrflow::maths::resample::disc_image::disc_integral(&ball, &map);
    let rel = (0..3).map(|k| ((got[k] - want[k]) / want[k]).abs()).fold(0.0, f64::max);
    eprintln!("park: ball integral {got:?} vs {want:?} ({rel:.1e})");
    assert!(rel < 2e-3, "{rel}");
    let mask = load("unwrap_mask.exr");
    let (w, h) = (mask.width, mask.height);
    let mut seen = 0.0;
    for y in 0..h {
        for x in 0..w {
            let m = mask.pixel(x, y)[0];
            assert!(m == 0.0 || m == 1.0, "{m}");
            seen += m as f64 * latlong::texel_solid_angle(y, w, h);
        }
    }
    let share = seen / (4.0 * PI);
    eprintln!("park: the unwrapped ball saw {share:.5} of the sphere (0.95^2 = 0.9025)");
    assert!((share - 0.9025).abs() < 5e-3, "{share}");
}

fn load_park() -> Image {
    let path = std::path::Path::new(common::MANIFEST_DIR).join("assets/maps/rooitou_park_1k.hdr");
    hdrflow::formats::decode_by_extension(&common::read_file(&path), "hdr").expect("the park decodes")
}
