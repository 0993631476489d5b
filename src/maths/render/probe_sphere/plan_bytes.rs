//! A frame's plan as bytes, for keeping it between processes ([`super::plan`], [`PlanStore`]):
//! the pixels' stages, and a mirror's reads of one map size. Every value is stored by its bits
//! (f64 as `to_bits`, little-endian), so a plan read back gives renders equal bit for bit to the
//! plan it was written from (tested). Decoding checks every count against the bytes left and
//! returns `None` on anything unexpected: a plan that cannot be read is made again.
//!
//! Layout: a magic string and a format version, then (stages) the pixel count and one record a
//! pixel: tag 0 `Done(coverage)`, tag 1 `Mirror(rays u32, n u32, coverage)`, tag 2 `Shade(t, point,
//! normal, ng, v, coverage)` (14 f64); or (reads) the row count, then per row its three arrays,
//! each a count and its values.

use glam::DVec3;

use super::mesh::Hit;
use super::mirror_reads::RowReads;
use super::Stage;

/// Where a frame's plan is kept between processes: the run's persistent cache, through the
/// operator (`engine::context::AuxStore`). `name` says what the bytes are; the caller makes it
/// unique to the code that wrote them.
pub trait PlanStore: Sync {
    fn load(&self, name: &str) -> Option<Vec<u8>>;
    fn save(&self, name: &str, bytes: &[u8]);
}

const STAGES_MAGIC: &[u8; 8] = b"HFSTAGE1";
const READS_MAGIC: &[u8; 8] = b"HFREADS1";

struct Out(Vec<u8>);

impl Out {
    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_bits().to_le_bytes());
    }
    fn vec3(&mut self, v: DVec3) {
        [v.x, v.y, v.z].into_iter().for_each(|x| self.f64(x));
    }
}

struct In<'a>(&'a [u8]);

impl<'a> In<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        if self.0.len() < n {
            return None;
        }
        let (head, rest) = self.0.split_at(n);
        self.0 = rest;
        Some(head)
    }
    fn u8(&mut self) -> Option<u8> {
        Some(self.take(1)?[0])
    }
    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
    fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }
    /// A count of items of at least `item` bytes each, checked against the bytes left.
    fn count(&mut self, item: usize) -> Option<usize> {
        let n = usize::try_from(self.u64()?).ok()?;
        (n.checked_mul(item)? <= self.0.len()).then_some(n)
    }
    fn f64(&mut self) -> Option<f64> {
        Some(f64::from_bits(self.u64()?))
    }
    fn vec3(&mut self) -> Option<DVec3> {
        Some(DVec3::new(self.f64()?, self.f64()?, self.f64()?))
    }
}

/// The stages as bytes.
pub(super) fn encode_stages(stages: &[Stage]) -> Vec<u8> {
    let mut out = Out(Vec::with_capacity(16 + stages.len() * 9));
    out.0.extend_from_slice(STAGES_MAGIC);
    out.u64(stages.len() as u64);
    for stage in stages {
        match *stage {
            Stage::Done(a) => {
                out.0.push(0);
                out.f64(a);
            }
            Stage::Mirror { rays, n, coverage } => {
                out.0.push(1);
                out.u32(rays);
                out.u32(n);
                out.f64(coverage);
            }
            Stage::Shade(hit, v, a) => {
                out.0.push(2);
                out.f64(hit.t);
                out.vec3(hit.point);
                out.vec3(hit.normal);
                out.vec3(hit.ng);
                out.vec3(v);
                out.f64(a);
            }
        }
    }
    out.0
}

/// The stages [`encode_stages`] wrote, if they are `pixels` of them.
pub(super) fn decode_stages(bytes: &[u8], pixels: usize) -> Option<Vec<Stage>> {
    let mut r = In(bytes);
    (r.take(8)? == STAGES_MAGIC).then_some(())?;
    let n = r.count(9)?;
    (n == pixels).then_some(())?;
    let mut stages = Vec::with_capacity(n);
    for _ in 0..n {
        stages.push(match r.u8()? {
            0 => Stage::Done(r.f64()?),
            1 => Stage::Mirror { rays: r.u32()?, n: r.u32()?, coverage: r.f64()? },
            2 => {
                let (t, point, normal, ng) = (r.f64()?, r.vec3()?, r.vec3()?, r.vec3()?);
                Stage::Shade(Hit { t, point, normal, ng }, r.vec3()?, r.f64()?)
            }
            _ => return None,
        });
    }
    r.0.is_empty().then_some(stages)
}

/// A mirror's reads of one map size as bytes.
pub(super) fn encode_reads(rows: &[RowReads]) -> Vec<u8> {
    let items: usize = rows.iter().map(|r| r.counts.len() + 3 * r.texel.len()).sum();
    let mut out = Out(Vec::with_capacity(16 + rows.len() * 24 + items * 4));
    out.0.extend_from_slice(READS_MAGIC);
    out.u64(rows.len() as u64);
    for row in rows {
        out.u64(row.counts.len() as u64);
        row.counts.iter().for_each(|&c| out.u32(c));
        out.u64(row.texel.len() as u64);
        row.texel.iter().for_each(|&t| out.u32(t));
        row.weight.iter().for_each(|&w| out.f64(w));
    }
    out.0
}

/// The reads [`encode_reads`] wrote, if they are `height` rows whose pixel counts match the
/// mirror pixels of `stages` (`width` a row) and whose texels lie in a map of `texels`.
pub(super) fn decode_reads(bytes: &[u8], stages: &[Stage], width: usize, texels: usize) -> Option<Vec<RowReads>> {
    let mut r = In(bytes);
    (r.take(8)? == READS_MAGIC).then_some(())?;
    let height = r.count(16)?;
    (height * width == stages.len()).then_some(())?;
    let mut rows = Vec::with_capacity(height);
    for row in 0..height {
        let mirrors = stages[row * width..(row + 1) * width].iter().filter(|s| matches!(s, Stage::Mirror { .. }));
        let pixels = r.count(4)?;
        (pixels == mirrors.count()).then_some(())?;
        let counts: Vec<u32> = (0..pixels).map(|_| r.u32()).collect::<Option<_>>()?;
        let taps = r.count(12)?;
        (counts.iter().map(|&c| c as usize).sum::<usize>() == taps).then_some(())?;
        let texel: Vec<u32> = (0..taps).map(|_| r.u32()).collect::<Option<_>>()?;
        texel.iter().all(|&t| (t as usize) < texels).then_some(())?;
        let weight: Vec<f64> = (0..taps).map(|_| r.f64()).collect::<Option<_>>()?;
        rows.push(RowReads { counts, texel, weight });
    }
    r.0.is_empty().then_some(rows)
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
