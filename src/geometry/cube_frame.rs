//! The frame a cube map is written in: which world direction an engine sees through the cube
//! texel that the OpenGL / KTX face table ([`super::cubemap`]) gives direction `c`.
//!
//! A cube map is sampled by a shader with a lookup vector `c`, and the hardware picks the texel
//! by the OpenGL table (the same in Vulkan, WebGPU, Metal and D3D for cube arrays uploaded in
//! the +X -X +Y -Y +Z -Z order). What differs between engines is the vector they look up for a
//! world direction `d`: `c = M d`. hdrflow's own cube maps have `M = I` (world = hdrflow's
//! axes, +Y up, -Z forward). A cube map meant for an engine with `M != I` stores at `c` what
//! hdrflow's world holds at `M^-1 c`; `M` is a signed permutation here, so the texels are
//! permuted exactly (texel centres map to texel centres), never resampled:
//!
//! ```text
//! frame      M (lookup = M * world)   who
//! Standard   I                        Filament, Khronos glTF viewers, three.js: textureLod(cube, d)
//! MirrorZ    diag(1, 1, -1)           Bevy: `sample_dir.z = -sample_dir.z` ("cube maps are
//!                                     left-handed", bevy_pbr light_probe/environment_map.wgsl)
//! ```
//!
//! `MirrorZ` is a reflection (determinant -1): no rotation (no `--yaw`) can stand in for it.
//! Tested: the permutation is a bijection, its own inverse, and a texel of a known world
//! direction lands at the texel Bevy's lookup of that direction reads.

use glam::DVec3;

use super::cubemap as cube;

crate::choice! {
    /// The lookup a cube map is written for (`geometry::cube_frame`).
    pub enum CubeFrame {
        /// lookup = world direction (OpenGL / Vulkan cube convention in hdrflow's axes): Filament, Khronos, three.js
        Standard,
        /// lookup = (x, y, -z) of the world direction: Bevy's environment maps
        MirrorZ,
    }
}

impl CubeFrame {
    /// The lookup vector `M d` the engine samples for world direction `d`.
    #[inline]
    pub fn lookup(self, d: DVec3) -> DVec3 {
        match self {
            CubeFrame::Standard => d,
            CubeFrame::MirrorZ => DVec3::new(d.x, d.y, -d.z),
        }
    }

    /// The world direction `M^-1 c` an engine sees through lookup vector `c` (each frame here is
    /// its own inverse).
    #[inline]
    pub fn world(self, c: DVec3) -> DVec3 {
        self.lookup(c)
    }

    /// For every texel of an S x S-faced cube written in this frame (flat index `(face * S + y)
    /// * S + x`), the flat index of the texel of hdrflow's own cube map that it copies: the
    /// texel containing `M^-1 c`, `c` the written texel's centre.
    pub fn source_texels(self, size: usize) -> Vec<usize> {
        let mut out = Vec::with_capacity(6 * size * size);
        for face in 0..6 {
            for y in 0..size {
                for x in 0..size {
                    let c = cube::texel_direction(face, x, y, size);
                    out.push(cube::texel_index_of_direction(self.world(c), size));
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_frame_permutes_the_texels_and_is_its_own_inverse() {
        for frame in CubeFrame::ALL {
            for size in [1, 2, 3, 8] {
                let p = frame.source_texels(size);
                let mut seen = vec![false; p.len()];
                for &i in &p {
                    assert!(!seen[i], "{frame} {size}: texel {i} copied twice");
                    seen[i] = true;
                }
                assert!(p.iter().enumerate().all(|(i, &j)| p[j] == i), "{frame} {size}: not an involution");
            }
        }
        assert!(CubeFrame::Standard.source_texels(4).iter().enumerate().all(|(i, &j)| i == j));
    }

    /// Bevy reads world direction d at lookup (d.x, d.y, -d.z): hdrflow's texel of d must sit
    /// there.
    #[test]
    fn a_world_direction_lands_where_bevy_looks_it_up() {
        let size = 8;
        let p = CubeFrame::MirrorZ.source_texels(size);
        for d in [DVec3::new(0.3, 0.2, -0.9), DVec3::new(-0.7, 0.1, 0.4), DVec3::new(0.1, -0.95, 0.2)] {
            let d = d.normalize();
            let bevy_reads = cube::texel_index_of_direction(DVec3::new(d.x, d.y, -d.z), size);
            assert_eq!(p[bevy_reads], cube::texel_index_of_direction(d, size), "{d}");
        }
        // Forward (-Z, the lat-long centre) is read from the +Z face.
        let forward = DVec3::new(1e-3, 2e-3, -1.0).normalize();
        let lookup = CubeFrame::MirrorZ.lookup(forward);
        assert_eq!(cube::FACE_NAMES[cube::texel_of_direction(lookup, size).0], "+Z");
        assert_eq!(p[cube::texel_index_of_direction(lookup, size)], cube::texel_index_of_direction(forward, size));
    }
}
