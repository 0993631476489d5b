//! A frame's plan as bytes, for keeping it between processes ([`super::plan`], [`PlanStore`]):
//! the pixels' stages, and a mirror's reads of one map size, in the cache's byte codec
//! ([`crate::bytes`]: little-endian, f64 by its bits, every length checked before anything is
//! allocated). A plan read back gives renders equal bit for bit to the plan it was written from
//! (tested); bytes that are not a plan of this frame decode to `None`, and the plan is made again.
//!
//! Layout: a magic string (its last byte the format's version), then (stages) the pixel count and
//! one record a pixel: tag 0 `Done(coverage)`, tag 1 `Mirror(rays u32, n u32, coverage)`, tag 2
//! `Shade(t, point, normal, ng, v, coverage)` (14 f64); or (reads) the row count, then per row
//! its pixels' tap counts, texels and weights, each a length-prefixed array.

use glam::DVec3;

use super::mesh::Hit;
use super::mirror_reads::RowReads;
use super::Stage;
use crate::bytes::{Reader, Writer};

/// Where a frame's plan is kept between processes: the run's persistent cache, through the
/// operator (`engine::context::AuxStore`). `name` says what the bytes are; the caller makes it
/// unique to the code that wrote them.
pub trait PlanStore: Sync {
    fn load(&self, name: &str) -> Option<Vec<u8>>;
    fn save(&self, name: &str, bytes: Vec<u8>);
}

const STAGES_MAGIC: &[u8; 8] = b"HFSTAGE1";
const READS_MAGIC: &[u8; 8] = b"HFREADS1";

fn vec3(w: &mut Writer, v: DVec3) {
    [v.x, v.y, v.z].into_iter().for_each(|x| w.f64(x));
}

fn read_vec3(r: &mut Reader) -> Result<DVec3, String> {
    Ok(DVec3::new(r.f64()?, r.f64()?, r.f64()?))
}

fn magic(r: &mut Reader, magic: &[u8; 8]) -> Result<(), String> {
    (r.take(8)? == magic).then_some(()).ok_or_else(|| "not a plan of this format".to_string())
}

/// The stages as bytes.
pub(super) fn encode_stages(stages: &[Stage]) -> Vec<u8> {
    let mut out = Vec::with_capacity(16 + stages.len() * 9);
    let w = &mut Writer(&mut out);
    w.0.extend_from_slice(STAGES_MAGIC);
    w.u64(stages.len() as u64);
    for stage in stages {
        match *stage {
            Stage::Done(a) => {
                w.u8(0);
                w.f64(a);
            }
            Stage::Mirror { rays, n, coverage } => {
                w.u8(1);
                w.u32(rays);
                w.u32(n);
                w.f64(coverage);
            }
            Stage::Shade(hit, v, a) => {
                w.u8(2);
                w.f64(hit.t);
                [hit.point, hit.normal, hit.ng, v].into_iter().for_each(|x| vec3(w, x));
                w.f64(a);
            }
        }
    }
    out
}

/// The stages [`encode_stages`] wrote, if they are `pixels` of them.
pub(super) fn decode_stages(bytes: &[u8], pixels: usize) -> Option<Vec<Stage>> {
    read_stages(&mut Reader::new(bytes), pixels).ok()
}

fn read_stages(r: &mut Reader, pixels: usize) -> Result<Vec<Stage>, String> {
    magic(r, STAGES_MAGIC)?;
    if r.usize()? != pixels {
        return Err("another frame's plan".into());
    }
    r.need(pixels.saturating_mul(9))?;
    let mut stages = Vec::with_capacity(pixels);
    for _ in 0..pixels {
        stages.push(match r.u8()? {
            0 => Stage::Done(r.f64()?),
            1 => Stage::Mirror { rays: r.u32()?, n: r.u32()?, coverage: r.f64()? },
            2 => {
                let t = r.f64()?;
                let (point, normal, ng) = (read_vec3(r)?, read_vec3(r)?, read_vec3(r)?);
                Stage::Shade(Hit { t, point, normal, ng }, read_vec3(r)?, r.f64()?)
            }
            tag => return Err(format!("stage tag {tag}")),
        });
    }
    r.finish()?;
    Ok(stages)
}

/// A mirror's reads of one map size as bytes.
pub(super) fn encode_reads(rows: &[RowReads]) -> Vec<u8> {
    let taps: usize = rows.iter().map(|r| r.counts.len() + 3 * r.texel.len()).sum();
    let mut out = Vec::with_capacity(16 + rows.len() * 24 + taps * 4);
    let w = &mut Writer(&mut out);
    w.0.extend_from_slice(READS_MAGIC);
    w.u64(rows.len() as u64);
    for row in rows {
        w.u32s(&row.counts);
        w.u32s(&row.texel);
        w.f64s(&row.weight);
    }
    out
}

/// The reads [`encode_reads`] wrote, if they are a row each of `stages` (`width` a row) with a
/// tap count per mirror pixel, and texels that lie in a map of `texels`.
pub(super) fn decode_reads(bytes: &[u8], stages: &[Stage], width: usize, texels: usize) -> Option<Vec<RowReads>> {
    read_reads(&mut Reader::new(bytes), stages, width, texels).ok()
}

fn read_reads(r: &mut Reader, stages: &[Stage], width: usize, texels: usize) -> Result<Vec<RowReads>, String> {
    magic(r, READS_MAGIC)?;
    let height = r.usize()?;
    if height.checked_mul(width) != Some(stages.len()) {
        return Err("another frame's reads".into());
    }
    let mut rows = Vec::with_capacity(height);
    for row in stages.chunks_exact(width.max(1)).take(height) {
        let (counts, texel, weight) = (r.u32s()?, r.u32s()?, r.f64s()?);
        let mirrors = row.iter().filter(|s| matches!(s, Stage::Mirror { .. })).count();
        let taps = counts.iter().map(|&c| c as usize).sum::<usize>();
        if counts.len() != mirrors || texel.len() != taps || weight.len() != taps {
            return Err("reads that do not match the frame".into());
        }
        if texel.iter().any(|&t| t as usize >= texels) {
            return Err("a texel beyond the map".into());
        }
        rows.push(RowReads { counts, texel, weight });
    }
    r.finish()?;
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::super::plan::tests_support::{made_and_read_back, MemoryStore};
    use super::super::{ProbeMaterial, ProbeSettings, ProbeShape};
    use super::*;
    use crate::maths::render::probe_sphere::principled::Smith;

    fn settings(material: ProbeMaterial) -> ProbeSettings {
        ProbeSettings {
            material,
            shape: ProbeShape::Subdivided,
            width: 96,
            height: 54,
            samples: 8,
            cut: 0.125,
            smith: Smith::Separable,
            interpolate: true,
        }
    }

    #[test]
    fn a_plan_read_back_is_the_plan_it_was_written_from_bit_for_bit() {
        for material in [ProbeMaterial::Mirror, ProbeMaterial::Diffuse] {
            let s = settings(material);
            let (made, read) = made_and_read_back(&s);
            assert_eq!(encode_stages(&made.0), encode_stages(&read.0), "{material:?}: stages");
            if material == ProbeMaterial::Mirror {
                // Reads from the made plan's rays, from rays traced again, and from bytes.
                assert_eq!(encode_reads(&made.1), encode_reads(&read.1), "reads from traced-again rays");
                let back = decode_reads(&encode_reads(&made.1), &made.0, s.width, 64 * 32).unwrap();
                assert_eq!(encode_reads(&back), encode_reads(&made.1));
            }
        }
    }

    #[test]
    fn truncated_or_altered_bytes_are_not_a_plan() {
        let s = settings(ProbeMaterial::Mirror);
        let (made, _) = made_and_read_back(&s);
        let stages = encode_stages(&made.0);
        let pixels = s.width * s.height;
        assert!(decode_stages(&stages, pixels).is_some());
        for cut in [0, 7, 8, 15, stages.len() / 2, stages.len() - 1] {
            assert!(decode_stages(&stages[..cut], pixels).is_none(), "cut at {cut}");
        }
        assert!(decode_stages(&stages, pixels + 1).is_none(), "another frame's plan");
        let mut bad = stages.clone();
        bad[16] = 7; // the first pixel's tag
        assert!(decode_stages(&bad, pixels).is_none());
        let reads = encode_reads(&made.1);
        assert!(decode_reads(&reads, &made.0, s.width, 64 * 32).is_some());
        assert!(decode_reads(&reads[..reads.len() - 1], &made.0, s.width, 64 * 32).is_none());
        // Texels beyond a smaller map's.
        assert!(decode_reads(&reads, &made.0, s.width, 4).is_none());
        let store = MemoryStore::default();
        assert!(store.load("nothing").is_none());
    }
}
