//! Relighting a diffuse (Lambertian) sphere seen orthographically, from a set of light samples
//! drawn on an environment map. Used by the RelightSphere operator.
//!
//! For a Lambertian surface of albedo `a` and normal `n`, the outgoing radiance is
//! `L_o(n) = (a / pi) * int L(w) max(n.w, 0) dw` (Lambert; pbrt-v4 `DiffuseBxDF`, section 9.2).
//! Two estimators of that integral are supported (see [`Estimator`]):
//!
//! - `Unbiased`, the Monte Carlo estimator with N samples `w_j` of solid-angle pdf `p`
//!   (Veach 1997, eq. 2.7; pbrt-v4 section 2.1.3):
//!   `L_o ~= (a / (pi N)) * sum_j max(n.w_j, 0) * L(w_j) / p(w_j)`.
//!   Light weight: `L(w_j) / p(w_j)`; scale: `a / (pi N)`.
//! - `Seed`, the formula of the reproduced assignment (see /work/shared/seed):
//!   `L = (int L dw / N) * sum_j (1/pi) cos(theta_j) V_j` with `V_j = rgb_j / |rgb_j|` and negative
//!   cosines ignored. Light weight: `V_j`; scale: `a * (int L dw) / (N pi)`.
//!
//! Both reduce to `c(n) = sum_j max(n.w_j, 0) * weight_j` followed by a per-channel scale, which is
//! what [`relight`] evaluates for every pixel of the sphere's silhouette.
//!
//! Files: this one holds the light samples and the renderer; `view` the camera
//! ([`SphereView`]); `tests` the tests of both.

#[cfg(test)]
mod tests;
mod view;

pub use view::SphereView;

use std::collections::hash_map::Entry;
use std::collections::HashMap;

use glam::DVec3;
use rayon::prelude::*;

use crate::maths::render::kernels::{pack_blocks, Block, Cone, Kernel, LANES};
use crate::values::image::Image;

crate::choice! {
    /// How light samples are turned into a pixel value (see the module documentation).
    pub enum Estimator {
        /// Monte Carlo: weight `L / pdf`, scale `albedo / (pi N)`.
        Unbiased,
        /// The assignment's formula: weight `rgb / |rgb|`, scale `albedo * (int L dw) / (N pi)`.
        Seed,
    }
}

impl Estimator {
    /// The per-channel `scale` to pass to [`relight`] for `n_samples` samples (before any merging
    /// of duplicates: a sample drawn k times counts k times).
    ///
    /// - `Unbiased`: `albedo / (pi N)` (Veach 1997, eq. 2.7, times the Lambertian `albedo / pi`);
    ///   `integral` is ignored.
    /// - `Seed`: `albedo * integral / (N pi)`, where `integral` is `int L dw` of the scalar
    ///   (luminance-like) map the samples were drawn from (the assignment's formula).
    ///
    /// `n_samples == 0` gives zeros.
    pub fn scale(self, albedo: [f64; 3], n_samples: usize, integral: f64) -> [f32; 3] {
        if n_samples == 0 {
            return [0.0; 3];
        }
        let n = n_samples as f64;
        let k = match self {
            Estimator::Unbiased => 1.0 / (std::f64::consts::PI * n),
            Estimator::Seed => integral / (n * std::f64::consts::PI),
        };
        [(albedo[0] * k) as f32, (albedo[1] * k) as f32, (albedo[2] * k) as f32]
    }
}

/// One light: a unit direction towards the environment and its per-sample contribution factor
/// (`L / pdf` for [`Estimator::Unbiased`], `rgb / |rgb|` for [`Estimator::Seed`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    pub dir: [f32; 3],
    pub weight: [f32; 3],
}

impl LightSample {
    /// The unbiased estimator's light: weight = `radiance / pdf` (solid-angle pdf, computed in
    /// f64). A pdf that is not finite and positive cannot have produced the sample: weight 0.
    pub fn unbiased(dir: [f32; 3], radiance: [f32; 3], pdf: f32) -> LightSample {
        let weight = if pdf.is_finite() && pdf > 0.0 {
            let p = pdf as f64;
            [(radiance[0] as f64 / p) as f32, (radiance[1] as f64 / p) as f32, (radiance[2] as f64 / p) as f32]
        } else {
            [0.0; 3]
        };
        LightSample { dir, weight }
    }

    /// The assignment's light: weight `V = rgb / M`, `M = sqrt(R^2 + G^2 + B^2)` (computed in
    /// f64); zero when `M` is 0 or not finite.
    pub fn seed(dir: [f32; 3], rgb: [f32; 3]) -> LightSample {
        let (r, g, b) = (rgb[0] as f64, rgb[1] as f64, rgb[2] as f64);
        let m = (r * r + g * g + b * b).sqrt();
        let weight = if m > 0.0 && m.is_finite() { [(r / m) as f32, (g / m) as f32, (b / m) as f32] } else { [0.0; 3] };
        LightSample { dir, weight }
    }
}

/// Merges samples that landed on the same texel (`(texel_index, sample)` pairs) into one light
/// whose weight is the sum of theirs; the first occurrence's direction is kept and lights come out
/// in order of first occurrence.
///
/// Why this is exact: samples on one texel share one direction (the texel centre), so every pixel
/// sees the identical `max(n.dir, 0)` for all k of them, and
/// `sum_k max(n.dir, 0) w_k = max(n.dir, 0) * sum_k w_k`. A sample drawn k times therefore still
/// counts k times (the caller's N stays the number of draws). The sums are formed in f64, so a
/// weight drawn k times becomes the correctly rounded `k w`; the rendered result differs from the
/// unmerged one by float rounding only. Precondition: equal texel indices imply equal directions.
pub fn merge_duplicates(samples: &[(u32, LightSample)]) -> Vec<LightSample> {
    let mut index: HashMap<u32, usize> = HashMap::with_capacity(samples.len());
    let mut merged: Vec<([f32; 3], [f64; 3])> = Vec::with_capacity(samples.len());
    for (texel, s) in samples {
        let w = [s.weight[0] as f64, s.weight[1] as f64, s.weight[2] as f64];
        match index.entry(*texel) {
            Entry::Occupied(e) => {
                let acc = &mut merged[*e.get()].1;
                acc[0] += w[0];
                acc[1] += w[1];
                acc[2] += w[2];
            }
            Entry::Vacant(e) => {
                e.insert(merged.len());
                merged.push((s.dir, w));
            }
        }
    }
    merged.into_iter().map(|(dir, w)| LightSample { dir, weight: [w[0] as f32, w[1] as f32, w[2] as f32] }).collect()
}

/// Side of the square pixel tiles over which back-facing lights are culled.
const TILE: usize = 16;

/// The lights that can contribute at all: non-zero weight and non-zero direction (a light with
/// either zero adds exactly 0 to every pixel).
struct LiveLights {
    dir: Vec<[f32; 3]>,
    /// 1 / |dir| in f64 (directions are expected to be unit, but culling must not rely on it).
    inv_len: Vec<f64>,
    weight: Vec<[f32; 3]>,
}

impl LiveLights {
    fn new(lights: &[LightSample]) -> LiveLights {
        let mut live = LiveLights { dir: Vec::new(), inv_len: Vec::new(), weight: Vec::new() };
        for l in lights {
            let len = DVec3::from(l.dir.map(f64::from)).length();
            // A non-finite weight would turn max(n.d, 0) * w into NaN for pixels facing away;
            // callers refuse such lights first (RelightSphere reports them), here they are dropped.
            if l.weight == [0.0; 3] || !(len > 0.0) || !len.is_finite() || l.weight.iter().any(|w| !w.is_finite()) {
                continue;
            }
            live.dir.push(l.dir);
            live.inv_len.push(1.0 / len);
            live.weight.push(l.weight);
        }
        live
    }

    fn is_empty(&self) -> bool {
        self.dir.is_empty()
    }

    /// Packs into `blocks` (cleared first) the lights that may face at least one of `normals`
    /// (unit, f64), in their order: a light is skipped when [`Cone::cull_threshold`] shows it
    /// behind every normal of the tile (it would add exactly +0 to each of their sums; see
    /// [`crate::maths::render::kernels`] for the test and its margin). The tile's cone is around the
    /// normalised mean of its normals; a tile wider than a hemisphere keeps every light.
    fn pack_visible(&self, normals: &[(usize, usize, [f64; 3])], blocks: &mut Vec<Block>) {
        let cull = Cone::around(normals.iter().map(|p| DVec3::from(p.2)))
            .and_then(|cone| cone.cull_threshold(Cone::RAY).map(|h| (cone.axis, h)));
        // The cosine between the tile's axis and light j's direction (not necessarily unit).
        let cos_to_axis = |j: usize, axis: DVec3| DVec3::from(self.dir[j].map(f64::from)).dot(axis) * self.inv_len[j];
        let visible = (0..self.dir.len()).filter(|&j| cull.is_none_or(|(axis, h)| !(cos_to_axis(j, axis) <= h)));
        blocks.clear();
        pack_blocks(visible.map(|j| (self.dir[j], self.weight[j])), blocks);
    }
}

/// Renders the diffuse sphere: a `size` x `size` RGB image (row 0 at the top) where each pixel on
/// the silhouette is `scale * sum_j max(n.dir_j, 0) * weight_j` (per channel; `n` from
/// [`SphereView::normal_at`]) and every pixel off it is exactly 0.
///
/// Back-facing lights (`n.dir <= 0`) contribute nothing: the clamped cosine of Lambert's law (the
/// assignment: "ignore a negative value of cos theta"). The caller chooses `scale`, see
/// [`Estimator::scale`]: `albedo / (pi N)` for `Unbiased`, `albedo * integral / (N pi)` for `Seed`.
///
/// Speed: bands of 16 rows run in parallel (rayon); within a band, each 16 x 16 tile first drops
/// the lights that are behind all its normals (they would add exactly 0; see `pack_visible`),
/// then runs the inner loop of [`crate::maths::render::kernels`] over the remaining lights in f32, laid
/// out as structure of arrays in blocks of 8, at the `crate::cpu` level ([`Kernel::at`]: AVX-512,
/// AVX, two pixels per pass, or SSE2). The result is deterministic and the same on every CPU (no FMA, fixed
/// summation order). Sums are f32: with 1024 lights
/// the relative rounding is ~1e-6. Lights with a non-finite weight or direction are ignored:
/// callers must refuse them first (`RelightSphere` reports them as an error).
pub fn relight(view: &SphereView, lights: &[LightSample], scale: [f32; 3]) -> Image {
    relight_with(Kernel::at(crate::cpu::level()), view, lights, scale)
}

fn relight_with(kernel: Kernel, view: &SphereView, lights: &[LightSample], scale: [f32; 3]) -> Image {
    let size = view.size;
    let mut image = Image::new(size, size, 3);
    if size == 0 {
        return image;
    }
    let live = LiveLights::new(lights);
    if live.is_empty() {
        return image;
    }
    image.data.par_chunks_mut(size * 3 * TILE).enumerate().for_each(|(band, rows)| {
        let y0 = band * TILE;
        let y1 = (y0 + TILE).min(size);
        let mut normals: Vec<(usize, usize, [f64; 3])> = Vec::with_capacity(TILE * TILE);
        let mut normals_f32: Vec<[f32; 3]> = Vec::with_capacity(TILE * TILE);
        let mut blocks: Vec<Block> = Vec::with_capacity(live.dir.len().div_ceil(LANES));
        for x0 in (0..size).step_by(TILE) {
            let x1 = (x0 + TILE).min(size);
            normals.clear();
            for py in y0..y1 {
                for px in x0..x1 {
                    if let Some(n) = view.normal_at(px, py) {
                        normals.push((px, py, n));
                    }
                }
            }
            if normals.is_empty() {
                continue;
            }
            live.pack_visible(&normals, &mut blocks);
            if blocks.is_empty() {
                continue;
            }
            normals_f32.clear();
            normals_f32.extend(normals.iter().map(|p| p.2.map(|c| c as f32)));
            kernel.for_each_sum(&blocks, &normals_f32, |k, c| {
                let (px, py, _) = normals[k];
                let i = ((py - y0) * size + px) * 3;
                rows[i] = scale[0] * c[0];
                rows[i + 1] = scale[1] * c[1];
                rows[i + 2] = scale[2] * c[2];
            });
        }
    });
    image
}
