//! The tiled sum of the rough lobes against each pixel's own ([`super::shading::rough`]) and a
//! finer cut; the lobe kernel's levels against each other.

use super::camera::Camera;
use super::lobe_kernel::{self, FlatCut, PixelLobe};
use super::mesh::{self, hit_ideal};
use super::principled::Smith;
use super::shading::{self, rough};
use super::tests::{settings, sky_with_sun};
use super::texel_tree::TexelTree;
use super::tile_cut::TileCones;
use super::*;

const MATERIALS: [(ProbeMaterial, Smith); 4] = [
    (ProbeMaterial::MatteSilver, Smith::Separable),
    (ProbeMaterial::MatteSilver, Smith::Correlated),
    (ProbeMaterial::Diffuse, Smith::Separable),
    (ProbeMaterial::Diffuse, Smith::Correlated),
];

#[test]
fn a_tile_of_one_pixel_sums_the_pixels_own_cut_at_every_level() {
    // Hits over the whole disc of the mesh and of the ideal sphere, the silhouette included (where
    // the corrected normal departs from the interpolated one).
    let map = sky_with_sun(256, 128);
    let cam = Camera::new(160, 90);
    let mut cut = FlatCut::default();
    let (mut checked, mut worst) = (0, 0.0f64);
    for (material, smith) in MATERIALS {
        let bsdf = material.principled(smith);
        let tree = TexelTree::new(&map, 0.125, shading::lobe_width(&bsdf));
        // A grid over the disc, then points just inside the silhouette (23.47 px from the frame's
        // centre), where the view grazes.
        let grid =
            (20..70).step_by(3).flat_map(|r| (55..105).step_by(3).map(move |c| (c as f64 + 0.1, r as f64 - 0.2)));
        let rim = (0..240).map(|i| {
            let (a, radius) = (i as f64 * 0.1309, 23.0 + 0.45 * (i % 8) as f64 / 7.0);
            (80.0 + radius * a.cos(), 45.0 + radius * a.sin())
        });
        for (c, r) in grid.chain(rim) {
            let ray = cam.pinhole(c, r, 0.0, 0.0);
            for hit in [hit_ideal(&ray), mesh::subdivided().hit(&ray)].into_iter().flatten() {
                let v = -ray.dir;
                let own = rough(&tree, &bsdf, &hit, v);
                let Some(lobe) = PixelLobe::new(&bsdf, &hit, v) else {
                    assert_eq!(own, [0.0; 3]);
                    continue;
                };
                tree.tile_cut(&TileCones::new(&[lobe]).unwrap(), &mut cut);
                let portable = lobe_kernel::sum(crate::cpu::Level::Portable, &lobe, &cut);
                for ch in 0..3 {
                    let rel = (portable[ch] - own[ch]).abs() / own[ch].abs().max(1e-300);
                    worst = worst.max(rel);
                    assert!(rel < 1e-5, "{material:?} {smith:?} ({c:.2}, {r:.2}): {portable:?} vs {own:?}");
                }
                for level in crate::cpu::tested_levels() {
                    let got = lobe_kernel::sum(level, &lobe, &cut);
                    assert_eq!(got, portable, "{level}");
                }
                checked += 1;
            }
        }
    }
    eprintln!("single precision against the f64 lobes: worst {worst:.2e} relative over {checked} pixels");
    assert!(checked > 2500, "{checked}");
}

/// The mean and largest relative difference of `a` from `reference` over fully covered pixels.
pub(super) fn difference(a: &ProbeRender, reference: &ProbeRender) -> (f64, f64) {
    let (mut sum, mut worst, mut count) = (0.0, 0.0f64, 0);
    for (pa, pb) in a.image.data.chunks(4).zip(reference.image.data.chunks(4)) {
        if pb[3] < 1.0 {
            continue;
        }
        let rel = (0..3).map(|c| ((pa[c] - pb[c]) / pb[c]).abs() as f64).fold(0.0, f64::max);
        sum += rel;
        worst = worst.max(rel);
        count += 1;
    }
    (sum / count as f64, worst)
}

#[test]
fn tiles_stay_as_close_to_a_four_times_finer_cut_as_each_pixels_own_cut() {
    // The tiles' cut is at least as fine as each pixel's: against the pixels' own sums at cut/4 its
    // error is no larger (mean and worst), and it departs from the pixels' own sums at the default
    // cut by less than that cut's own error (measured on the mesh: MatteSilver 0.14% mean, 1.35%
    // worst against cut/4 where the pixels' own cuts give 0.36% and 1.6%, 0.23% and 1.28% from
    // them; Diffuse 0.054% and 7.3% against 0.057% and 7.3%, 0.0099% and 0.16% from them).
    let map = sky_with_sun(256, 128);
    for material in [ProbeMaterial::MatteSilver, ProbeMaterial::Diffuse] {
        let s = ProbeSettings { samples: 4, ..settings(material, ProbeShape::Subdivided, 160, 90) };
        let tiled = render_tiled(&map, &s, tiles::TILE, None);
        let own = render_tiled(&map, &s, 1, None);
        let fine = render_tiled(&map, &ProbeSettings { cut: 0.03125, ..s }, 1, None);
        let (tiled_mean, tiled_worst) = difference(&tiled, &fine);
        let (own_mean, own_worst) = difference(&own, &fine);
        let (apart_mean, apart_worst) = difference(&tiled, &own);
        eprintln!(
            "{material:?}: against cut/4 tiled {tiled_mean:.2e} (worst {tiled_worst:.2e}), own {own_mean:.2e} \
             ({own_worst:.2e}); tiled against own {apart_mean:.2e} ({apart_worst:.2e})"
        );
        assert!(tiled_mean <= own_mean * 1.01 && tiled_worst <= own_worst * 1.01, "{material:?}");
        assert!(apart_mean < own_mean && apart_worst < own_worst, "{material:?}");
        assert_eq!(tiled.mask.data, own.mask.data);
    }
}

#[test]
fn interpolating_between_shaded_pixels_adds_little_to_the_cuts_own_error() {
    // At 480 x 270 a pixel turns the peak twice as fast as at the protocol's 960 x 540, so the
    // interpolation covers the sphere's middle at stride 2 and leaves the rim to the shading; at
    // 960 x 540 its middle is interpolated at stride 4. Against a four times finer cut the mean and
    // worst errors stay within 10% of shading every pixel's (measured: at 480 x 270 half the
    // pixels interpolated, MatteSilver 1.29e-3 against 1.66e-3, Diffuse 5.95e-4 against 5.54e-4;
    // at 960 x 540 the middle at stride 4, 33k and 40k of 62k pixels, MatteSilver 1.30e-3 against
    // 2.40e-3, Diffuse 5.94e-4 against 5.66e-4; the worst unchanged or smaller). Interpolated, the
    // tiles are four times as wide, and a wider tile's shared cut is finer: hence the matte
    // silver's lower error.
    let map = sky_with_sun(256, 128);
    for (width, height) in [(480, 270), (960, 540)] {
        for material in [ProbeMaterial::MatteSilver, ProbeMaterial::Diffuse] {
            let s = ProbeSettings { samples: 4, ..settings(material, ProbeShape::Subdivided, width, height) };
            let every = render(&map, &s);
            let interpolated = render(&map, &ProbeSettings { interpolate: true, ..s });
            let fine = render(&map, &ProbeSettings { cut: 0.03125, ..s });
            let plan = plan::plan_for(&s, None);
            let bsdf = material.principled(Smith::Separable);
            let fills = plan.fills(&bsdf);
            let count = |f: interpolation::Fill| fills.iter().filter(|&&g| g == f).count();
            let lit = plan.stages.iter().filter(|st| matches!(st, Stage::Shade(..))).count();
            let (filled, coarse) = (lit - count(interpolation::Fill::Shade), count(interpolation::Fill::Coarse));
            let (every_mean, every_worst) = difference(&every, &fine);
            let (interpolated_mean, interpolated_worst) = difference(&interpolated, &fine);
            eprintln!(
                "{width} x {height} {material:?}: {filled} of {lit} pixels interpolated ({coarse} at stride 4); \
                 against cut/4 every pixel {every_mean:.3e} (worst {every_worst:.2e}), interpolated \
                 {interpolated_mean:.3e} ({interpolated_worst:.2e})"
            );
            assert!(filled * 2 > lit, "{material:?}: {filled} of {lit}");
            if width == 960 {
                assert!(coarse * 2 > lit, "{material:?}: {coarse} of {lit} at stride 4");
            }
            assert!(interpolated_mean <= 1.1 * every_mean, "{width} x {height} {material:?}");
            assert!(interpolated_worst <= 1.1 * every_worst, "{width} x {height} {material:?}");
            assert_eq!(interpolated.mask.data, every.mask.data);
        }
    }
}
