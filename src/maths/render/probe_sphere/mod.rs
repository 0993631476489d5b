//! The lighting-estimation protocol's probe spheres (DiffusionLight-evaluation's
//! `stylelight/{mirror,matte_silver,diffuse}.py`), computed from the map instead of path traced:
//! the scene's camera, lens, pixel filter and sphere ([`camera`], [`mesh`]), the world lookup of
//! Cycles' Environment Texture ([`environment`]), Principled BSDF v1 as Cycles 3.4 evaluates it
//! ([`principled`]) and the rough lobes summed over the map's texels ([`texel_tree`], [`shading`]).
//! The book page
//! `docs/src/guides/evaluation-protocol.md` states the scene with its sources.
//!
//! **A pixel** `(c, r)` of the `W x H` render (row 0 at the top) is the Cycles film's value: the
//! mean over camera rays whose filter offsets follow the Blackman-Harris pixel filter and whose lens
//! points cover the aperture, each ray carrying the sphere's radiance when it hits it and nothing
//! (transparent film) when it misses. Its alpha is the fraction of rays that hit; its RGB is thus
//! premultiplied by that coverage, as in the protocol's EXR files. The rays are a fixed 4D point set
//! of `samples` points (offsets `x`, `y` through the filter's inverse CDF, lens `u`, `v`
//! through Cycles' polygon mapping; a Halton set, the first coordinate `i / n`), the same in every
//! pixel. A pixel whose rays neither all hit nor all miss is on the silhouette: it is computed
//! again with [`EDGE_FACTOR`] times as many rays, so the coverage is resolved finely where it is
//! fractional.
//!
//! - Mirror: each hitting ray's reflection is looked up, weighted by its Fresnel term
//!   ([`shading::mirror_ray`]), as Cycles does.
//! - Rough materials: the radiance varies over the sphere on the scale of the lobes (degrees of
//!   normal, many pixels), so it is integrated once per pixel, at the hit of the pinhole ray through
//!   the mean filter offset of the hitting rays, and multiplied by the coverage. For a radiance
//!   linear across the pixel's footprint (about 1.3 px across with the lens blur) this is the mean;
//!   the departure is second order in the footprint over the radiance's own scale. A pixel whose
//!   rays all lie within the silhouette of a sphere inside the mesh (its nearest triangle plane's
//!   distance) is not traced: coverage 1, shaded at the pattern's mean offset, the same result.
//!
//! The rough lobes are shaded by tiles of pixels ([`tiles`]): a tile's pixels share one cut of the
//! texel tree, at least as fine as each pixel's own ([`tile_cut`]), and each sums its own lobes over
//! it ([`lobe_kernel`], vectorised). With `interpolate`, only every fourth or every second pixel in
//! each direction is shaded where the lobes turn slowly across pixels, and the others are
//! interpolated ([`interpolation`]).
//!
//! Everything before the map is read (the rays, their hits, the coverage, the mirror's reflections
//! and weights, the rough materials' tiles and lobes) is the frame's [`plan`], made once per
//! process for each frame and shared by the renders of every map; given a
//! [`plan_bytes::PlanStore`] (the run's cache) it is kept there and read back by later processes.
//! Bands of rows run in parallel (rayon); every pixel is a pure function of the inputs and of its
//! tile's pixels, so the image is the same bit for bit whatever the number of threads and whether
//! the plan was kept, stored or read back.

pub mod camera;
pub mod environment;
mod interpolation;
pub mod lobe_kernel;
pub mod mesh;
mod mesh_search;
mod mirror_reads;
mod plan;
pub mod plan_bytes;
pub mod principled;
mod recent;
pub mod shading;
pub mod texel_tree;
pub mod tile_cut;
mod tiles;

use glam::DVec3;
use rayon::prelude::*;

use self::camera::{Camera, FilterTable, Ray, FILTER_WIDTH};
use self::environment::Environment;
use self::mesh::Hit;
use self::principled::{Principled, Smith};
use self::texel_tree::TexelTree;
use crate::maths::sampling::sequences::radical_inverse;
use crate::values::Image;

/// How many times `samples` camera rays a silhouette pixel gets.
pub const EDGE_FACTOR: usize = 4;

crate::choice! {
    /// The protocol's three materials (Principled BSDF v1, base colour 0.8).
    pub enum ProbeMaterial {
        /// mirror.py: metallic 1, specular 0.2, roughness 0 (a perfect mirror)
        Mirror,
        /// matte_silver.py: metallic 1, specular 0, roughness 0.3271 (its glossy mix is not linked)
        MatteSilver,
        /// diffuse.py: metallic 0, specular 0.5, roughness 0.364 (Disney diffuse + a GGX coat)
        Diffuse,
    }
}

crate::choice! {
    /// The sphere's geometry.
    pub enum ProbeShape {
        /// the mesh Blender renders: a 32 x 16 UV sphere, subdivided once, smooth-shaded
        Subdivided,
        /// the unit sphere
        Ideal,
    }
}

impl ProbeMaterial {
    /// The Principled node of the material's script.
    pub fn principled(self, smith: Smith) -> Principled {
        match self {
            ProbeMaterial::Mirror => Principled::new(0.8, 1.0, 0.2, 0.0, smith),
            ProbeMaterial::MatteSilver => Principled::new(0.8, 1.0, 0.0, 0.3271, smith),
            ProbeMaterial::Diffuse => Principled::new(0.8, 0.0, 0.5, 0.364, smith),
        }
    }
}

/// What to render.
#[derive(Clone, Copy, Debug)]
pub struct ProbeSettings {
    pub material: ProbeMaterial,
    pub shape: ProbeShape,
    pub width: usize,
    pub height: usize,
    /// camera rays per pixel (pixel filter and lens)
    pub samples: usize,
    /// the texel sum's refinement ratio (rough materials; [`texel_tree`])
    pub cut: f64,
    pub smith: Smith,
    /// rough materials: shade every fourth or second pixel in each direction where the lobes
    /// allow and interpolate the others ([`interpolation`])
    pub interpolate: bool,
}

/// The render: RGBA (RGB premultiplied by the coverage) and the coverage alone.
pub struct ProbeRender {
    pub image: Image,
    pub mask: Image,
}

/// One camera ray of a pixel: its filter offset in pixels and its aperture point.
struct PixelSample {
    offset: [f64; 2],
    lens: [f64; 2],
}

/// The fixed pattern of `n` rays per pixel: a 4D Halton set whose first coordinate is `(i + 1/2) / n`,
/// through the filter's inverse CDF (x, y) and the aperture polygon (u, v).
fn pattern(n: usize, filter: &FilterTable) -> Vec<PixelSample> {
    (0..n as u64)
        .map(|i| PixelSample {
            offset: [filter.offset((i as f64 + 0.5) / n as f64), filter.offset(radical_inverse(i, 2))],
            lens: camera::lens_point([radical_inverse(i, 3), radical_inverse(i, 5)]),
        })
        .collect()
}

struct Scene {
    camera: Camera,
    bsdf: Principled,
    shape: ProbeShape,
    /// the rays of an ordinary pixel and of a silhouette pixel
    rays: Vec<PixelSample>,
    edge_rays: Vec<PixelSample>,
    /// pixels whose centre is farther than this from the frame's centre see no sphere
    reach: f64,
    /// every ray of a pixel whose centre is nearer than this to the frame's centre hits it
    inside: f64,
    /// the mean filter offset of `rays`
    mean_offset: [f64; 2],
}

impl Scene {
    /// The sphere's hit; `hint` carries the last triangle hit between calls.
    fn hit(&self, ray: &Ray, hint: &mut Option<usize>) -> Option<Hit> {
        match self.shape {
            ProbeShape::Ideal => mesh::hit_ideal(ray),
            ProbeShape::Subdivided => mesh::subdivided().hit_near(ray, hint),
        }
    }

    /// Whether the ray hits the sphere; `hint` as in [`Scene::hit`].
    fn hits(&self, ray: &Ray, hint: &mut Option<usize>) -> bool {
        match self.shape {
            ProbeShape::Ideal => mesh::hit_ideal(ray).is_some(),
            ProbeShape::Subdivided => mesh::subdivided().hits(ray, hint),
        }
    }

    /// Pixel `(c, r)` with the rays of `pattern`: the mirror's reflected rays (pushed to `rays`)
    /// and coverage, or where the rough lobes are to be shaded and the coverage.
    fn pixel(
        &self,
        c: usize,
        r: usize,
        pattern: &[PixelSample],
        hint: &mut Option<usize>,
        rays: &mut Vec<MirrorRay>,
    ) -> Stage {
        let (cf, rf) = (c as f64, r as f64);
        let (dx, dy) = (cf + 0.5 - 0.5 * self.camera.width as f64, rf + 0.5 - 0.5 * self.camera.height as f64);
        let from_centre = dx.hypot(dy);
        if from_centre > self.reach {
            return Stage::Done(0.0);
        }
        if !self.bsdf.is_mirror() && from_centre < self.inside {
            // Every ray hits: the rough lobes at the pattern's mean offset, full coverage.
            let [ox, oy] = self.mean_offset;
            let ray = self.camera.pinhole(cf, rf, ox, oy);
            if let Some(hit) = self.hit(&ray, hint) {
                return Stage::Shade(hit, -ray.dir, 1.0);
            }
        }
        let n = pattern.len();
        let start = rays.len();
        let (mut hits, mut sum_ox, mut sum_oy) = (0usize, 0.0, 0.0);
        let mut first_hit: Option<Ray> = None;
        for s in pattern {
            let [ox, oy] = s.offset;
            let ray = self.camera.ray_through(cf, rf, ox, oy, s.lens);
            if self.bsdf.is_mirror() {
                let Some(hit) = self.hit(&ray, hint) else { continue };
                if let Some((d, f)) = shading::mirror_ray(&self.bsdf, &hit, -ray.dir) {
                    let (u, t) = environment::coordinates(d);
                    rays.push(MirrorRay { u: u as f32, t: t as f32, weight: f as f32 });
                }
            } else {
                // The rough lobes need only whether the ray hits.
                if !self.hits(&ray, hint) {
                    continue;
                }
                sum_ox += ox;
                sum_oy += oy;
                first_hit.get_or_insert(ray);
            }
            hits += 1;
        }
        if hits == 0 {
            return Stage::Done(0.0);
        }
        let coverage = hits as f64 / n as f64;
        if self.bsdf.is_mirror() {
            return Stage::Mirror { rays: (rays.len() - start) as u32, n: n as u32, coverage };
        }
        // The rough lobes once, at the pinhole ray through the hitting rays' mean offset (or the
        // first hitting ray where that one misses).
        let ray = self.camera.pinhole(cf, rf, sum_ox / hits as f64, sum_oy / hits as f64);
        let found = self.hit(&ray, hint).map(|h| (h, ray));
        match found.or_else(|| first_hit.and_then(|f| self.hit(&f, hint).map(|h| (h, f)))) {
            Some((hit, ray)) => Stage::Shade(hit, -ray.dir, coverage),
            None => {
                // `hits` and `hit` search the same candidates: a ray one says hits, the other finds.
                debug_assert!(false, "a ray counted as hitting found no hit at pixel ({c}, {r})");
                Stage::Done(coverage)
            }
        }
    }
}

/// A pixel after its rays, before the map is read: done (no hit: black, its coverage), the
/// mirror's next `rays` reflected rays of the row's list out of `n` (their weighted lookups summed
/// and divided by `n`), or to be shaded with the rough lobes at a hit seen along `v`, then
/// multiplied by the coverage.
#[derive(Clone, Copy)]
enum Stage {
    Done(f64),
    Mirror { rays: u32, n: u32, coverage: f64 },
    Shade(Hit, DVec3, f64),
}

impl Stage {
    fn coverage(&self) -> f64 {
        match *self {
            Stage::Done(a) | Stage::Mirror { coverage: a, .. } | Stage::Shade(_, _, a) => a,
        }
    }
}

/// One reflected ray of a mirror pixel: where it reads the map ([`environment::coordinates`]) and
/// its Fresnel weight (single precision: a 960 x 540 mirror holds about 4.5 million).
#[derive(Clone, Copy, Debug)]
struct MirrorRay {
    u: f32,
    t: f32,
    weight: f32,
}

/// Each pixel's `(rgb premultiplied, coverage)`: a mirror pixel's the next of `mirror` (its
/// row's merged reads, [`mirror_reads`]), a shaded one's from `shaded`.
fn finish<'a>(
    stages: &'a [Stage],
    mut mirror: impl Iterator<Item = [f64; 3]> + 'a,
    shaded: impl IntoIterator<Item = [f64; 3]> + 'a,
) -> impl Iterator<Item = ([f64; 3], f64)> + 'a {
    stages.iter().zip(shaded).map(move |(s, rgb)| match *s {
        Stage::Done(a) => ([0.0; 3], a),
        Stage::Mirror { coverage, .. } => {
            let rgb = mirror.next();
            debug_assert!(rgb.is_some(), "a mirror pixel without its reads");
            (rgb.unwrap_or([0.0; 3]), coverage)
        }
        Stage::Shade(_, _, a) => (rgb, a),
    })
}

/// Renders the protocol's sphere of `settings.material` under `env` (a lat-long map, hdrflow's
/// convention; see [`environment`] for how Blender reads the same file).
pub fn render(env: &Image, settings: &ProbeSettings) -> ProbeRender {
    render_with(env, settings, None)
}

/// [`render`], its frame's plan kept in (and read from) `store` between processes
/// ([`plan_bytes::PlanStore`]): the same image whether the plan was read or made.
pub fn render_with(env: &Image, settings: &ProbeSettings, store: Option<&dyn plan_bytes::PlanStore>) -> ProbeRender {
    // Interpolated, a tile holds a quarter (stride 2) to a sixteenth (stride 4) as many shaded
    // pixels: tiles four times as wide (split where their peaks spread, tiles::MAX_SPREAD) keep
    // the tree walks few, and their finer shared cuts lower the error (the benchmark page).
    render_tiled(env, settings, if settings.interpolate { 4 * tiles::TILE } else { tiles::TILE }, store)
}

/// [`render`] with the rough lobes shaded by tiles of `tile` x `tile` pixels (1: each pixel's own
/// cut of the texel tree, [`texel_tree::TexelTree::sum`]'s).
fn render_tiled(
    env: &Image,
    settings: &ProbeSettings,
    tile: usize,
    store: Option<&dyn plan_bytes::PlanStore>,
) -> ProbeRender {
    let tile = tile.max(1);
    let plan = plan::plan_for(settings, store);
    let environment = Environment::new(env);
    let bsdf = settings.material.principled(settings.smith);
    let (w, h) = (settings.width, settings.height);
    // Row r's span of pixels that are not empty ([`plan::Plan::spans`]), as a range of the frame.
    let span = |r: usize| r * w + plan.spans[r].start..r * w + plan.spans[r].end;
    // The pixels go straight into the image and the mask, a row's span at a time (the rest stay 0).
    let mut rgba = vec![0.0f32; w * h * 4];
    let mut alpha = vec![0.0f32; w * h];
    let put = |r: usize, rgba: &mut [f32], alpha: &mut [f32], pixels: &mut dyn Iterator<Item = ([f64; 3], f64)>| {
        let x = plan.spans[r].clone();
        for ((out, a), (rgb, coverage)) in
            rgba[4 * x.start..4 * x.end].chunks_exact_mut(4).zip(&mut alpha[x]).zip(pixels)
        {
            out.copy_from_slice(&[rgb[0] as f32, rgb[1] as f32, rgb[2] as f32, coverage as f32]);
            *a = coverage as f32;
        }
    };
    let rows = rgba.par_chunks_mut(4 * w.max(1)).zip(alpha.par_chunks_mut(w.max(1))).enumerate();
    if bsdf.is_mirror() {
        let (map_w, map_h) = environment.size();
        let reads = plan.mirror_reads(map_w, map_h, store);
        rows.for_each(|(r, (rgba, alpha))| {
            let stages = &plan.stages[span(r)];
            put(r, rgba, alpha, &mut finish(stages, reads[r].pixels(&environment), std::iter::repeat([0.0; 3])))
        });
    } else {
        // Bands of `tile` rows: their tiles' rough lobes, then the pixels interpolated.
        let tree = TexelTree::new(env, settings.cut, shading::lobe_width(&bsdf));
        let tiles = plan.tiles(&bsdf, tile, settings.interpolate);
        let mut rgb = vec![[0.0; 3]; w * h];
        rgb.par_chunks_mut(tile * w.max(1)).zip(tiles.par_iter()).for_each(|(out, band)| {
            tiles::shade_tiles(&tree, band, out);
        });
        if settings.interpolate {
            interpolation::fill(&plan.spans, &plan.fills(&bsdf), &mut rgb, w);
        }
        rows.for_each(|(r, (rgba, alpha))| {
            put(r, rgba, alpha, &mut finish(&plan.stages[span(r)], std::iter::empty(), rgb[span(r)].iter().copied()))
        });
    }
    ProbeRender { image: Image::from_vec(w, h, 4, rgba), mask: Image::from_vec(w, h, 1, alpha) }
}

/// The scene of `settings` (camera, sphere, ray patterns) that the pixels' rays are traced in.
fn scene(settings: &ProbeSettings) -> Scene {
    let bsdf = settings.material.principled(settings.smith);
    let filter = FilterTable::blackman_harris(FILTER_WIDTH);
    let n = settings.samples.max(1);
    let camera = Camera::new(settings.width, settings.height);
    // The silhouettes of spheres inside and around the shape, widened and narrowed by the filter's
    // reach and a margin for the lens blur (below 0.1 px at the silhouette).
    let silhouette =
        |radius: f64| camera.focal_px() * radius / (camera::POSITION.length_squared() - radius * radius).sqrt();
    let inner = match settings.shape {
        ProbeShape::Ideal => 1.0,
        ProbeShape::Subdivided => mesh::subdivided().inner,
    };
    let reach = silhouette(1.0) + FILTER_WIDTH + 2.0;
    let inside = silhouette(inner) - FILTER_WIDTH - 2.0;
    let rays = pattern(n, &filter);
    let mean_offset = [0, 1].map(|k| rays.iter().map(|s| s.offset[k]).sum::<f64>() / n as f64);
    Scene {
        camera,
        bsdf,
        shape: settings.shape,
        rays,
        edge_rays: pattern(n * EDGE_FACTOR, &filter),
        reach,
        inside,
        mean_offset,
    }
}

/// Row `r`'s pixels after their rays, and the mirror's reflected rays in pixel order; the hint
/// carries along the row. A silhouette pixel is traced again with the edge pattern, its first
/// rays dropped.
fn trace_row(scene: &Scene, r: usize) -> (Vec<Stage>, Vec<MirrorRay>) {
    let mut hint = None;
    let mut rays = Vec::new();
    let stages = (0..scene.camera.width)
        .map(|c| {
            let start = rays.len();
            let first = scene.pixel(c, r, &scene.rays, &mut hint, &mut rays);
            let a = first.coverage();
            if a > 0.0 && a < 1.0 {
                rays.truncate(start);
                scene.pixel(c, r, &scene.edge_rays, &mut hint, &mut rays)
            } else {
                first
            }
        })
        .collect();
    (stages, rays)
}

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tiles_tests;
