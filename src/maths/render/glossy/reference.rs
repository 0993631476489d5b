//! The exact side of the glossy sphere: the midpoint sum over every texel
//! ([`reference_glossy_sphere`], on the texels packed once by [`PackedTexels`]) and a point
//! light added in closed form ([`add_light`]); see the "Reference" section of the
//! [parent module](super).

use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;

use super::GlossyBrdf;
use crate::geometry::latlong;
use crate::maths::brdf::phong;
use crate::maths::render::relight::SphereView;
use crate::values::Image;

/// The non-zero texels of a map, structure of arrays: centre directions and `L dOmega`.
pub struct PackedTexels {
    dirs: Vec<DVec3>,
    weights: Vec<[f64; 3]>,
}

impl PackedTexels {
    /// Every texel of `env` with a non-zero colour, in row-major order (midpoint solid angles).
    pub fn new(env: &Image) -> PackedTexels {
        let (w, h) = (env.width, env.height);
        let mut dirs = Vec::new();
        let mut weights = Vec::new();
        for y in 0..h {
            let d_omega = latlong::texel_solid_angle(y, w, h);
            for x in 0..w {
                let l = env.rgb(x, y);
                if l != [0.0f32; 3] {
                    dirs.push(DVec3::from(latlong::texel_direction(x, y, w, h)));
                    weights.push(l.map(|c| c as f64 * d_omega));
                }
            }
        }
        PackedTexels { dirs, weights }
    }

    /// The exact texel sum `sum_i L_i f(d_i) max(n.d_i, 0) dOmega_i` at unit normal `n` seen
    /// from unit `v` (f64; the diffuse and specular sums are formed separately, then scaled).
    pub fn radiance(&self, brdf: &GlossyBrdf, n: [f64; 3], v: [f64; 3]) -> [f64; 3] {
        let n = DVec3::from(n);
        let r = DVec3::from(phong::mirror(v, n.to_array()));
        let s = if brdf.exponent > 0.0 { brdf.exponent } else { 0.0 };
        let mut diffuse = [0.0f64; 3];
        let mut specular = [0.0f64; 3];
        for (d, wt) in self.dirs.iter().zip(&self.weights) {
            let c = n.dot(*d);
            if !(c > 0.0) {
                continue;
            }
            for ch in 0..3 {
                diffuse[ch] += wt[ch] * c;
            }
            let ca = r.dot(*d);
            if ca > 0.0 {
                let k = c * ca.powf(s);
                for ch in 0..3 {
                    specular[ch] += wt[ch] * k;
                }
            }
        }
        let norm = (s + 2.0) / (2.0 * PI);
        std::array::from_fn(|ch| brdf.diffuse[ch] / PI * diffuse[ch] + brdf.specular[ch] * norm * specular[ch])
    }
}

/// The exact glossy sphere: [`PackedTexels::radiance`] at every pixel of `view`'s disc, 0
/// elsewhere; `size` x `size` RGB, pixel for pixel comparable with [`glossy_sphere`]. Cost
/// O(pixels x non-zero texels); rows in parallel.
pub fn reference_glossy_sphere(env: &Image, view: &SphereView, brdf: &GlossyBrdf) -> Image {
    let size = view.size;
    let mut image = Image::new(size, size, 3);
    if size == 0 {
        return image;
    }
    let texels = PackedTexels::new(env);
    let v = view.view_dir();
    image.data.par_chunks_mut(size * 3).enumerate().for_each(|(py, row)| {
        for px in 0..size {
            if let Some(n) = view.normal_at(px, py) {
                let lo = texels.radiance(brdf, n, v);
                for ch in 0..3 {
                    row[px * 3 + ch] = lo[ch] as f32;
                }
            }
        }
    });
    image
}

/// Adds a distant light to a rendered glossy sphere in the small-source approximation: at every
/// pixel of `view`'s disc, `radiance * solid_angle * f(direction) max(n.direction, 0)` per
/// channel (the integrand at the light's centre times its solid angle; exact in the limit of a
/// vanishing solid angle, and off by the lobe's curvature across the light otherwise: a light of
/// angular radius `a` under a lobe of exponent `s` errs by O(s a^2) relative). With the
/// `residual` of `SunExtract`, `glossy_sphere(residual) + add_light(sun)` estimates the sphere
/// under the original map (`hdrflow bench --glossy` measures both).
pub fn add_light(image: &mut Image, view: &SphereView, brdf: &GlossyBrdf, light: &crate::values::Light) {
    let size = view.size;
    if size == 0 || image.width != size || image.height != size || image.channels != 3 || light.solid_angle <= 0.0 {
        return;
    }
    let Some(d) = crate::geometry::unit(DVec3::from(light.direction)) else { return };
    let v = view.view_dir();
    let power = light.power();
    image.data.par_chunks_mut(size * 3).enumerate().for_each(|(py, row)| {
        for px in 0..size {
            let Some(n) = view.normal_at(px, py) else { continue };
            let n = DVec3::from(n);
            let r = DVec3::from(phong::mirror(v, n.to_array()));
            let fc = brdf.eval_cos(n, r, d);
            for ch in 0..3 {
                row[px * 3 + ch] += (power[ch] * fc[ch]) as f32;
            }
        }
    });
}
