//! `hdrflow-bevy-render --diffuse D.ktx2 --specular S.ktx2 --intensity X --out frame.exr
//! [--width 768 --height 256] [--geometry scene.json] [--timeout SECONDS] [--skybox X,Y,Z]
//! [--sun README.txt] [--default-exposure]`
//!
//! With `--sun README.txt`, the README's sun lines (what follows "The sun:", written by `hdrflow
//! bake --for bevy --sun extract`) are read by [`sun_lines`], a strict reader of exactly the Rust
//! they use, and the `DirectionalLight` they spawn is spawned in the scene (issue 36): the lines a
//! user pastes, run in Bevy. With `--default-exposure` the camera has Bevy's default `Exposure`
//! (EV100 9.7, `Exposure::BLENDER`), as the README's loading code's camera, which sets none, so
//! that `--intensity 998.0957` (the README's) renders the map 1:1 and the sun at the README's
//! illuminance; the factor Bevy computes is written to the geometry file.
//!
//! With `--skybox X,Y,Z`, no spheres: the specular map is Bevy's `Skybox` (brightness
//! `intensity`), seen from the origin by a perspective camera looking along (X, Y, Z) with +Y up
//! and a vertical field of view of 90 degrees (`scene::SKYBOX_FOV_Y_DEG`): the panorama as a
//! 360-degree viewer shows it, for the orientation test. Bevy's skybox shader samples the cube at
//! `(x, y, -z)` of the world direction too (`bevy_core_pipeline/src/skybox/skybox.wgsl`), so it
//! shows the map in the frame the lighting reads it in.
//!
//! Renders six spheres (`scene`) lit only by an `EnvironmentMapLight` made of the two KTX2 cube
//! maps, in Bevy 0.19.1, windowless (on Mesa's lavapipe in CI: `WGPU_BACKEND=vulkan`), reads the
//! frame back as RGBA32F and writes it as EXR. No other light: no directional light but
//! `--sun`'s, no point light, ambient brightness 0, no skybox (the background stays black, alpha
//! 0), no bloom (Bevy's post-processing is not even compiled in), no tonemapping, no deband
//! dithering, no MSAA (`Msaa::Off`, so edge pixels are not blends), an HDR camera (its
//! Rgba16Float main texture is the one lossy step: 11-bit mantissas, 5e-4 relative), and exposure
//! `ev100 = -log2(1.2)` (unless `--default-exposure`), which makes Bevy's factor `2^-ev100 / 1.2`
//! equal to 1 (to f32 rounding; the factor Bevy computes is written to the geometry file), so that
//! a pixel is `intensity x` what the shader reads from the maps.
//!
//! The KTX2 files are decoded by Bevy's own loader (`Image::from_buffer`, the code its asset
//! server runs for `.ktx2`), Zstandard supercompression and rgb9e5 included.
//!
//! Exit status: 0 when the frame is written, 1 on a render or I/O failure, 2 on bad arguments.

mod capture;
mod scene;
mod sun_lines;

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use bevy::app::{AppExit, ScheduleRunnerPlugin};
use bevy::asset::RenderAssetUsages;
use bevy::camera::{Exposure, Hdr, RenderTarget, ScalingMode};
use bevy::core_pipeline::Skybox;
use bevy::core_pipeline::tonemapping::{DebandDither, Tonemapping};
use bevy::image::{CompressedImageFormats, ImageSampler, ImageType};
use bevy::light::{AmbientLight, DirectionalLight, EnvironmentMapLight, GlobalAmbientLight};
use bevy::prelude::*;
use bevy::render::RenderPlugin;
use bevy::render::gpu_readback::Readback;
use bevy::render::render_resource::{TextureFormat, TextureUsages};
use bevy::window::ExitCondition;

use capture::{FrameSize, Frames};
use scene::{RADIUS, SPHERES};

/// The command line.
#[derive(Resource, Clone)]
struct Args {
    diffuse: PathBuf,
    specular: PathBuf,
    intensity: f32,
    out: PathBuf,
    geometry: Option<PathBuf>,
    width: u32,
    height: u32,
    timeout: Duration,
    /// `--skybox`: the camera's forward direction
    skybox: Option<Vec3>,
    /// `--sun`: the README whose sun lines are run
    sun: Option<PathBuf>,
    /// `--default-exposure`: Bevy's default `Exposure` instead of the unit one
    default_exposure: bool,
}

const USAGE: &str = "usage: hdrflow-bevy-render --diffuse D.ktx2 --specular S.ktx2 --intensity X --out frame.exr \
                     [--width 768 --height 256] [--geometry scene.json] [--timeout 600] [--skybox X,Y,Z] \
                     [--sun README.txt] [--default-exposure]";

fn parse_args(mut it: impl Iterator<Item = String>) -> Result<Args, String> {
    let (mut diffuse, mut specular, mut intensity, mut out, mut geometry) = (None, None, None, None, None);
    let (mut width, mut height, mut timeout, mut skybox) = (768u32, 256u32, 600.0f64, None);
    let (mut sun, mut default_exposure) = (None, false);
    while let Some(flag) = it.next() {
        if flag == "--help" || flag == "-h" {
            return Err(USAGE.to_string());
        }
        if flag == "--default-exposure" {
            default_exposure = true;
            continue;
        }
        let value = it.next().ok_or_else(|| format!("{flag} needs a value\n{USAGE}"))?;
        let number = |what: &str| value.parse::<f64>().map_err(|_| format!("{what} must be a number, not {value:?}"));
        match flag.as_str() {
            "--diffuse" => diffuse = Some(PathBuf::from(&value)),
            "--specular" => specular = Some(PathBuf::from(&value)),
            "--out" => out = Some(PathBuf::from(&value)),
            "--geometry" => geometry = Some(PathBuf::from(&value)),
            "--intensity" => intensity = Some(number("--intensity")? as f32),
            "--width" => width = value.parse().map_err(|_| format!("--width must be a whole number, not {value:?}"))?,
            "--height" => {
                height = value.parse().map_err(|_| format!("--height must be a whole number, not {value:?}"))?
            }
            "--timeout" => timeout = number("--timeout")?,
            "--skybox" => skybox = Some(parse_direction(&value)?),
            "--sun" => sun = Some(PathBuf::from(&value)),
            _ => return Err(format!("unknown option {flag}\n{USAGE}")),
        }
    }
    let need = |v: Option<PathBuf>, what: &str| v.ok_or_else(|| format!("{what} is required\n{USAGE}"));
    let intensity = intensity.ok_or_else(|| format!("--intensity is required\n{USAGE}"))?;
    if !(intensity.is_finite() && intensity >= 0.0) {
        return Err(format!("--intensity must be finite and non-negative, not {intensity}"));
    }
    if !(1..=8192).contains(&width) || !(1..=8192).contains(&height) {
        return Err(format!("--width and --height must be in 1..=8192, not {width}x{height}"));
    }
    if !(timeout.is_finite() && timeout > 0.0) {
        return Err(format!("--timeout must be a positive number of seconds, not {timeout}"));
    }
    Ok(Args {
        diffuse: need(diffuse, "--diffuse")?,
        specular: need(specular, "--specular")?,
        intensity,
        out: need(out, "--out")?,
        geometry,
        width,
        height,
        timeout: Duration::from_secs_f64(timeout),
        skybox,
        sun,
        default_exposure,
    })
}

/// `X,Y,Z`: a direction the camera can look along with +Y up (not along the Y axis).
fn parse_direction(value: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = value
        .split(',')
        .map(|c| c.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("--skybox takes a direction X,Y,Z, not {value:?}"))?;
    let d = match v[..] {
        [x, y, z] if x.is_finite() && y.is_finite() && z.is_finite() => Vec3::new(x, y, z),
        _ => return Err(format!("--skybox takes a direction X,Y,Z of three finite numbers, not {value:?}")),
    };
    if d.x.hypot(d.z) < 1e-3 * d.length() || d.length() == 0.0 {
        return Err(format!("--skybox {value}: a camera with +Y up cannot look along the Y axis"));
    }
    Ok(d.normalize())
}

/// Bevy's `ev100` for which `2^-ev100 / 1.2 = 1` (`Exposure::exposure`).
fn unit_ev100() -> f32 {
    -(1.2f32).log2()
}

/// The camera's exposure: Bevy's default with `--default-exposure` (the README's camera), else
/// the unit one.
fn camera_exposure(args: &Args) -> Exposure {
    if args.default_exposure { Exposure::default() } else { Exposure { ev100: unit_ev100() } }
}

/// The lights the README's sun lines spawn (`--sun`), as Bevy components: the fields the lines
/// give, `DirectionalLight::default()`'s for the rest (their `..default()`).
fn sun_lights(readme: &std::path::Path) -> Result<Vec<(DirectionalLight, Transform)>, String> {
    let text = std::fs::read_to_string(readme).map_err(|e| format!("cannot read {}: {e}", readme.display()))?;
    let lights = sun_lines::read_readme(&text).map_err(|e| format!("{}: {e}", readme.display()))?;
    let light = |l: &sun_lines::SunLight| {
        let d = DirectionalLight::default();
        let light = DirectionalLight {
            illuminance: l.illuminance.unwrap_or(d.illuminance),
            color: l.color.map_or(d.color, |[r, g, b]| Color::linear_rgb(r, g, b)),
            shadow_maps_enabled: l.shadow_maps_enabled.unwrap_or(d.shadow_maps_enabled),
            ..d
        };
        (light, Transform::default().looking_to(Vec3::from_array(l.forward), Vec3::from_array(l.up)))
    };
    Ok(lights.iter().map(light).collect())
}

/// A cube map decoded by Bevy's KTX2 loader.
fn load_ktx2(path: &std::path::Path) -> Result<Image, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let image = Image::from_buffer(
        &bytes,
        ImageType::Extension("ktx2"),
        CompressedImageFormats::NONE,
        false,
        ImageSampler::Default,
        RenderAssetUsages::RENDER_WORLD,
    )
    .map_err(|e| format!("Bevy cannot load {}: {e}", path.display()))?;
    if image.texture_descriptor.size.depth_or_array_layers != 6 {
        return Err(format!(
            "{} is not a cube map (Bevy sees {} layers)",
            path.display(),
            image.texture_descriptor.size.depth_or_array_layers
        ));
    }
    Ok(image)
}

/// When the run started, for `--timeout`.
#[derive(Resource)]
struct Started(Instant);

fn main() -> ExitCode {
    let args = match parse_args(std::env::args().skip(1)) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    // Decoded before Bevy starts, so a bad file is reported without a renderer.
    let maps = load_ktx2(&args.diffuse).and_then(|d| Ok((d, load_ktx2(&args.specular)?)));
    let (diffuse, specular) = match maps {
        Ok(m) => m,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    // Read before Bevy starts too: lines the reader refuses are an error without a renderer.
    let suns = match args.sun.as_deref().map(sun_lights).transpose() {
        Ok(s) => s.unwrap_or_default(),
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    if args.skybox.is_some() && !suns.is_empty() {
        eprintln!("error: --sun lights the spheres; the --skybox view has none\n{USAGE}");
        return ExitCode::from(2);
    }
    let ev100 = camera_exposure(&args).ev100;
    let exposure = camera_exposure(&args).exposure();
    let geometry = match args.skybox {
        Some(forward) => scene::skybox_json(args.width, args.height, args.intensity, ev100, exposure, forward),
        None => scene::geometry_json(args.width, args.height, args.intensity, ev100, exposure, &suns),
    };
    if let Some(path) = &args.geometry {
        if let Err(e) = std::fs::write(path, &geometry) {
            eprintln!("error: cannot write {}: {e}", path.display());
            return ExitCode::from(1);
        }
    }

    let mut app = App::new();
    app.add_plugins(
        DefaultPlugins
            .set(WindowPlugin { primary_window: None, exit_condition: ExitCondition::DontExit, ..default() })
            // Pipelines compile before the frame that needs them: fewer frames without the spheres.
            .set(RenderPlugin { synchronous_pipeline_compilation: true, ..default() }),
    )
    // With a window plugin in the build, the default plugins hold no runner: frames as fast as they come.
    .add_plugins(ScheduleRunnerPlugin::run_loop(Duration::ZERO))
    .insert_resource(GlobalAmbientLight::NONE)
    .insert_resource(FrameSize { width: args.width, height: args.height })
    .insert_resource(Frames::default())
    .insert_resource(Started(Instant::now()))
    .insert_resource(MapsToLoad(Some((diffuse, specular))))
    .insert_resource(SunsToSpawn(suns))
    .insert_resource(args)
    .add_systems(Startup, setup)
    .add_systems(Update, finish);
    match app.run() {
        AppExit::Success => ExitCode::SUCCESS,
        AppExit::Error(code) => ExitCode::from(code.get()),
    }
}

/// The decoded cube maps, taken by `setup`.
#[derive(Resource)]
struct MapsToLoad(Option<(Image, Image)>);

/// The README's sun lights (`--sun`), spawned by `setup`.
#[derive(Resource)]
struct SunsToSpawn(Vec<(DirectionalLight, Transform)>);

fn setup(
    mut commands: Commands,
    args: Res<Args>,
    mut maps: ResMut<MapsToLoad>,
    suns: Res<SunsToSpawn>,
    mut images: ResMut<Assets<Image>>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let Some((diffuse, specular)) = maps.0.take() else { return };
    let mut target = Image::new_target_texture(args.width, args.height, TextureFormat::Rgba32Float, None);
    target.texture_descriptor.usage |= TextureUsages::COPY_SRC;
    let target = images.add(target);
    if let Some(forward) = args.skybox {
        commands.spawn((
            Camera3d::default(),
            Camera { clear_color: ClearColorConfig::Custom(Color::NONE), ..default() },
            RenderTarget::Image(target.clone().into()),
            Projection::Perspective(PerspectiveProjection {
                fov: scene::SKYBOX_FOV_Y_DEG.to_radians(),
                aspect_ratio: args.width as f32 / args.height as f32,
                ..default()
            }),
            Transform::default().looking_to(forward, Vec3::Y),
            Hdr,
            Tonemapping::None,
            DebandDither::Disabled,
            Msaa::Off,
            camera_exposure(&args),
            Skybox { image: Some(images.add(specular)), brightness: args.intensity, rotation: Quat::IDENTITY },
        ));
        commands.spawn(Readback::texture(target)).observe(capture::on_readback);
        return;
    }

    // A fine UV sphere: 256 x 128 quads, vertex normals 1.4 degrees apart (interpolated normals
    // are then within ~0.01 degree of the true sphere's).
    let mesh = meshes.add(Sphere::new(RADIUS).mesh().uv(256, 128));
    for (k, s) in SPHERES.iter().enumerate() {
        let material = materials.add(StandardMaterial {
            base_color: Color::WHITE,
            metallic: s.metallic,
            perceptual_roughness: s.perceptual_roughness,
            reflectance: s.reflectance,
            ..default()
        });
        commands.spawn((
            Mesh3d(mesh.clone()),
            MeshMaterial3d(material),
            Transform::from_xyz(scene::centre_x(k), 0.0, 0.0),
        ));
    }

    let view_height = scene::VIEW_WIDTH * args.height as f32 / args.width as f32;
    commands.spawn((
        Camera3d::default(),
        Camera { clear_color: ClearColorConfig::Custom(Color::NONE), ..default() },
        RenderTarget::Image(target.clone().into()),
        Projection::Orthographic(OrthographicProjection {
            scaling_mode: ScalingMode::Fixed { width: scene::VIEW_WIDTH, height: view_height },
            near: 0.0,
            far: 2.0 * scene::CAMERA_Z,
            ..OrthographicProjection::default_3d()
        }),
        Transform::from_xyz(0.0, 0.0, scene::CAMERA_Z).looking_at(Vec3::ZERO, Vec3::Y),
        Hdr,
        Tonemapping::None,
        DebandDither::Disabled,
        Msaa::Off,
        camera_exposure(&args),
        AmbientLight { brightness: 0.0, ..default() },
        EnvironmentMapLight {
            diffuse_map: images.add(diffuse),
            specular_map: images.add(specular),
            intensity: args.intensity,
            ..default()
        },
    ));
    for sun in &suns.0 {
        commands.spawn(*sun);
    }
    commands.spawn(Readback::texture(target)).observe(capture::on_readback);
}

/// Writes the settled frame and exits, or gives up after `--timeout`.
fn finish(
    args: Res<Args>,
    frames: Res<Frames>,
    size: Res<FrameSize>,
    started: Res<Started>,
    mut exit: MessageWriter<AppExit>,
) {
    if let Some(pixels) = capture::settled(&frames, *size, args.skybox.is_some()) {
        match capture::write_exr(&args.out, pixels, *size) {
            Ok(()) => {
                info!(
                    "wrote {} after {} readbacks in {:.1} s",
                    args.out.display(),
                    frames.count,
                    started.0.elapsed().as_secs_f64()
                );
                exit.write(AppExit::Success);
            }
            Err(e) => {
                error!("{e}");
                exit.write(AppExit::from_code(1));
            }
        }
    } else if started.0.elapsed() > args.timeout {
        error!(
            "no settled frame after {:.0} s ({} readbacks): the renderer is too slow or the spheres never appeared",
            args.timeout.as_secs_f64(),
            frames.count
        );
        exit.write(AppExit::from_code(1));
    }
}
