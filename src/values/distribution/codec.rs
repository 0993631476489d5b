//! [`Distribution2D`] as an engine value: its type, summary and the cache encoding (the CDFs and
//! row sums, read back with every invariant `sample` relies on checked).

use super::Distribution2D;
use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{TypeSpec, Value, ValueData, ValueType};

pub static DISTRIBUTION: TypeSpec = TypeSpec {
    name: "distribution",
    doc: "a piecewise-constant 2D sampling distribution over a lat-long map (f64)",
    decode,
};

impl ValueData for Distribution2D {
    fn value_type(&self) -> ValueType {
        ValueType(&DISTRIBUTION)
    }
    fn approx_bytes(&self) -> usize {
        Distribution2D::approx_bytes(self)
    }
    /// What `--print cdf` shows: the size, the light it carries, and its brightest texel (where
    /// it is and what share of the samples it draws: `P(x, y) = P(row y) P(x | y)`).
    fn summary(&self) -> String {
        let (w, h) = (self.width, self.height);
        let weighting = if self.sin_theta { "luminance x sin(theta)" } else { "luminance" };
        if !self.carries_light {
            return format!("a {w} x {h} distribution carrying no light: uniform over solid angle");
        }
        let (mut best, mut at) = (0.0f64, (0, 0));
        for y in 0..h {
            let row = self.marginal_cdf[y + 1] - self.marginal_cdf[y];
            let cdf = &self.conditional_cdf[y * (w + 1)..(y + 1) * (w + 1)];
            for x in 0..w {
                let p = row * (cdf[x + 1] - cdf[x]);
                if p > best {
                    (best, at) = (p, (x, y));
                }
            }
        }
        let (x, y) = at;
        let d = crate::geometry::latlong::texel_direction(x, y, w, h);
        format!(
            "a {w} x {h} distribution over {weighting}; luminance integral {:.6e} (over the sphere, in sr); \
             brightest texel ({x}, {y}), direction ({:.4}, {:.4}, {:.4}) (theta {:.2} deg, phi {:.2} deg), \
             draws {:.3}% of the samples ({:.1}x a uniform texel's)",
            self.luminance_integral,
            d[0],
            d[1],
            d[2],
            crate::geometry::latlong::theta_of_row(y, h).to_degrees(),
            crate::geometry::latlong::phi_of_column(x, w).to_degrees(),
            100.0 * best,
            best * (w * h) as f64,
        )
    }
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = Writer(out);
        w.u64(self.width as u64);
        w.u64(self.height as u64);
        w.u8(u8::from(self.sin_theta));
        w.u8(u8::from(self.carries_light));
        w.f64(self.total);
        w.f64(self.luminance_integral);
        w.f64s(&self.conditional_cdf);
        w.f64s(&self.row_sums);
        w.f64s(&self.marginal_cdf);
    }
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    let width = r.usize()?;
    let height = r.usize()?;
    let sin_theta = r.u8()? != 0;
    let carries_light = r.u8()? != 0;
    let total = r.f64()?;
    let luminance_integral = r.f64()?;
    let conditional_cdf = r.f64s()?;
    let row_sums = r.f64s()?;
    let marginal_cdf = r.f64s()?;
    r.finish()?;
    let n = width.checked_mul(height).ok_or("distribution size overflows")?;
    if n == 0
        || Some(conditional_cdf.len()) != height.checked_mul(width + 1)
        || row_sums.len() != height
        || marginal_cdf.len() != height + 1
    {
        return Err("distribution arrays do not match its size".into());
    }
    Ok(Value::new(Distribution2D {
        width,
        height,
        sin_theta,
        conditional_cdf,
        row_sums,
        marginal_cdf,
        total,
        luminance_integral,
        carries_light,
    }))
}
