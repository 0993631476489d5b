//! The mirror's reads of a map of one size: each mirror pixel's texels and weights, made once from
//! the frame's reflected rays ([`super::plan`]) and kept for every later map of that size.
//!
//! A mirror pixel is `sum_rays weight_ray bilinear(map, u_ray, t_ray) / n`: linear in the texels,
//! with weights that depend on the rays and the map's size only. Its 64 to 256 rays (4 taps each)
//! land on a few texels where the sphere magnifies the map and on many near the silhouette, so the
//! pixel's taps merged by texel are far fewer than its rays' taps, and a render is a short sum
//! per pixel instead of a lookup per ray. The value is the per-ray sum's, the terms regrouped
//! (rounding only: tested against [`super::environment::Environment::at`] per ray).

use super::environment::{taps, Environment};
use super::{MirrorRay, Stage};

/// One row's merged reads: for each mirror pixel of the row, in order, `counts` entries of
/// `texel` and `weight` (the ray weights times the bilinear ones over `n`).
pub(super) struct RowReads {
    pub(super) counts: Vec<u32>,
    pub(super) texel: Vec<u32>,
    pub(super) weight: Vec<f64>,
}

impl RowReads {
    /// The reads of a row of `stages` whose mirror rays are `rays`, on a `width` x `height` map.
    pub(super) fn new(stages: &[Stage], rays: &[MirrorRay], width: usize, height: usize) -> RowReads {
        let mut row = RowReads { counts: Vec::new(), texel: Vec::new(), weight: Vec::new() };
        let mut pixel = TapTable::default();
        let mut next = 0;
        for stage in stages {
            let Stage::Mirror { rays: count, n, .. } = *stage else { continue };
            pixel.clear(4 * count as usize);
            for ray in &rays[next..next + count as usize] {
                let scale = ray.weight as f64 / n as f64;
                for (i, w) in taps(width, height, ray.u as f64, ray.t as f64) {
                    // A map of 2^32 texels would take 100 GB as the environment's f64 RGB.
                    debug_assert!(i < u32::MAX as usize, "texel index {i} beyond u32");
                    pixel.add(i as u32, w * scale);
                }
            }
            next += count as usize;
            let start = row.texel.len();
            pixel.sort();
            for (i, w) in pixel.entries() {
                row.texel.push(i);
                row.weight.push(w);
            }
            row.counts.push((row.texel.len() - start) as u32);
        }
        row.texel.shrink_to_fit();
        row.weight.shrink_to_fit();
        row
    }

    /// The row's mirror pixels' premultiplied radiance, in order.
    pub(super) fn pixels<'a>(&'a self, env: &'a Environment) -> impl Iterator<Item = [f64; 3]> + 'a {
        let mut next = 0;
        self.counts.iter().map(move |&count| {
            let range = next..next + count as usize;
            next = range.end;
            let mut sum = [0.0; 3];
            for (&i, &w) in self.texel[range.clone()].iter().zip(&self.weight[range]) {
                let l = env.texel(i as usize);
                (0..3).for_each(|k| sum[k] += w * l[k]);
            }
            sum
        })
    }
}

/// A pixel's taps summed by texel: open addressing on the texel index (a pixel's 256 to 1024 taps
/// land on a few dozen texels, so sorting every tap would cost more than the table).
#[derive(Default)]
struct TapTable {
    keys: Vec<u32>,
    sums: Vec<f64>,
    used: Vec<usize>,
}

impl TapTable {
    const EMPTY: u32 = u32::MAX;

    /// Empties the table and makes room for `taps` taps (at most half full: a probe always ends).
    fn clear(&mut self, taps: usize) {
        let size = (2 * taps).next_power_of_two().clamp(16, 1 << 31);
        if self.keys.len() < size {
            self.keys = vec![Self::EMPTY; size];
            self.sums = vec![0.0; size];
        } else {
            for &slot in &self.used {
                self.keys[slot] = Self::EMPTY;
            }
        }
        self.used.clear();
    }

    fn add(&mut self, texel: u32, w: f64) {
        let mask = self.keys.len() - 1;
        // Fibonacci hashing, the product's high bits: a column's texels (a multiple of a
        // power-of-two width apart) spread over the table as well as a row's.
        let bits = self.keys.len().trailing_zeros();
        let mut slot = (texel.wrapping_mul(0x9E37_79B9) >> (32 - bits)) as usize;
        loop {
            if self.keys[slot] == texel {
                self.sums[slot] += w;
                return;
            }
            if self.keys[slot] == Self::EMPTY {
                self.keys[slot] = texel;
                self.sums[slot] = w;
                self.used.push(slot);
                return;
            }
            slot = (slot + 1) & mask;
        }
    }

    /// Orders [`TapTable::entries`] by texel index.
    fn sort(&mut self) {
        let keys = &self.keys;
        self.used.sort_unstable_by_key(|&slot| keys[slot]);
    }

    /// The texels and their summed weights, in the order of the slots used.
    fn entries(&self) -> impl Iterator<Item = (u32, f64)> + '_ {
        self.used.iter().map(|&s| (self.keys[s], self.sums[s]))
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::sky_with_sun;
    use super::super::{scene, trace_row, ProbeMaterial, ProbeSettings, ProbeShape};
    use super::*;
    use crate::maths::render::probe_sphere::principled::Smith;

    #[test]
    fn merged_reads_give_the_rays_lookups_with_fewer_terms() {
        let (w, h) = (64, 32);
        let map = sky_with_sun(w, h);
        let env = Environment::new(&map);
        let settings = ProbeSettings {
            material: ProbeMaterial::Mirror,
            shape: ProbeShape::Subdivided,
            width: 160,
            height: 90,
            samples: 16,
            cut: 0.125,
            smith: Smith::Separable,
            interpolate: false,
        };
        let scene = scene(&settings);
        let (mut checked, mut taps_total, mut merged) = (0, 0, 0);
        for r in 0..settings.height {
            let (stages, rays) = trace_row(&scene, r);
            let reads = RowReads::new(&stages, &rays, w, h);
            merged += reads.texel.len();
            let mut got = reads.pixels(&env);
            let mut next = 0;
            for stage in &stages {
                let Stage::Mirror { rays: count, n, .. } = *stage else { continue };
                let mut want = [0.0; 3];
                for ray in &rays[next..next + count as usize] {
                    let l = env.at(ray.u as f64, ray.t as f64);
                    (0..3).for_each(|k| want[k] += ray.weight as f64 * l[k] / n as f64);
                }
                next += count as usize;
                taps_total += 4 * count as usize;
                let got = got.next().expect("one sum per mirror pixel");
                for k in 0..3 {
                    assert!((got[k] - want[k]).abs() <= 1e-12 * want[k].abs().max(1e-12), "row {r}: {got:?} {want:?}");
                }
                checked += 1;
            }
            assert!(got.next().is_none());
        }
        assert!(checked > 1000, "{checked}");
        assert!(merged * 3 < taps_total, "{merged} merged reads of {taps_total} taps");
    }
}
