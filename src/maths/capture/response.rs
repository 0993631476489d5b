//! Camera responses: what exposure each code stands for, and the known curves the synthetic
//! brackets are made with.
//!
//! A [`Response`] holds, per channel R, G, B, the relative exposure `x(z)` of every code
//! `z = 0..=max` (`exp(g(z))` in Debevec and Malik's notation), normalised so that the middle
//! code `mid = (max + 1) / 2` (128 or 32768, OpenCV's `LDR_SIZE / 2`) maps to 1. As a `curves`
//! value: x = the codes, series `R`, `G`, `B` ([`Response::to_curves`], [`Response::from_curves`]).
//! A usable response is finite, `>= 0`, non-decreasing in `z` and not constant
//! ([`Response::check`]): a merge divides by nothing else, and a decreasing one would make two
//! codes stand for one exposure.
//!
//! The known curves ([`Known`]) map a linear exposure `x` in [0, 1] (1 = the sensor's clip) to a
//! display value `v` in [0, 1], the code being `round(v max)`:
//! - `Srgb`: the IEC 61966-2-1 OETF, `12.92 x` for `x <= 0.0031308`, else `1.055 x^(1/2.4) - 0.055`;
//! - `Gamma22`: `x^(1/2.2)`;
//! - `SCurve`: a film-like S curve in log exposure, as measured camera curves look (a toe in
//!   the shadows and a soft shoulder below the clip; compare the DoRF database of Grossberg and
//!   Nayar 2003): `v = s(c (log2 x + m)) / s(c m)` with the logistic `s(u) = 1 / (1 + e^-u)`,
//!   `c = 1` per stop and `m = 2.5` stops from the clip to the curve's midpoint; `v(0) = 0`,
//!   `v(1) = 1`, about 8 stops from code 1 to the clip at 8 bits. Its inverse is closed form:
//!   `log2 x = logit(v s(c m)) / c - m`.

use crate::values::Curves;

crate::choice! {
    /// A known camera response (linear exposure -> display value), see the module documentation.
    pub enum Known { Srgb, Gamma22, SCurve }
}

/// The S curve's slope, in logistic units per stop.
const S_SLOPE: f64 = 1.0;
/// The S curve's midpoint, in stops below the clip.
const S_MID: f64 = 2.5;

fn logistic(u: f64) -> f64 {
    1.0 / (1.0 + (-u).exp())
}

impl Known {
    /// Linear exposure `x` (clamped to [0, 1]) -> display value in [0, 1].
    pub fn encode(self, x: f64) -> f64 {
        let x = if x > 0.0 { x.min(1.0) } else { 0.0 };
        match self {
            Known::Srgb => {
                if x <= 0.0031308 {
                    12.92 * x
                } else {
                    1.055 * x.powf(1.0 / 2.4) - 0.055
                }
            }
            Known::Gamma22 => x.powf(1.0 / 2.2),
            Known::SCurve => {
                if x == 0.0 {
                    0.0
                } else {
                    logistic(S_SLOPE * (x.log2() + S_MID)) / logistic(S_SLOPE * S_MID)
                }
            }
        }
    }

    /// Display value `v` (clamped to [0, 1]) -> linear exposure in [0, 1]: the inverse of
    /// [`Known::encode`].
    pub fn decode(self, v: f64) -> f64 {
        let v = if v > 0.0 { v.min(1.0) } else { 0.0 };
        match self {
            Known::Srgb => {
                if v <= 0.04045 {
                    v / 12.92
                } else {
                    ((v + 0.055) / 1.055).powf(2.4)
                }
            }
            Known::Gamma22 => v.powf(2.2),
            Known::SCurve => {
                if v == 0.0 {
                    return 0.0;
                }
                let p = (v * logistic(S_SLOPE * S_MID)).min(1.0 - 1e-16);
                let u = (p / (1.0 - p)).ln();
                (u / S_SLOPE - S_MID).exp2().min(1.0)
            }
        }
    }
}

/// Per channel, the relative exposure of every code (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Response {
    /// 8 or 16.
    pub bits: u8,
    /// `x[c][z]`, `max + 1` values per channel.
    pub x: [Vec<f64>; 3],
}

/// The largest code of a bit depth.
pub fn max_code(bits: u8) -> usize {
    (1usize << bits) - 1
}

/// The middle code, mapped to 1: `(max + 1) / 2`.
pub fn mid_code(bits: u8) -> usize {
    1usize << (bits - 1)
}

impl Response {
    /// Codes taken as linear: `x(z) = z / mid`.
    pub fn linear(bits: u8) -> Response {
        let mid = mid_code(bits) as f64;
        let ch: Vec<f64> = (0..=max_code(bits)).map(|z| z as f64 / mid).collect();
        Response { bits, x: [ch.clone(), ch.clone(), ch] }
    }

    /// The response of a known curve: `x(z) = decode(z / max) / decode(mid / max)`.
    pub fn known(curve: Known, bits: u8) -> Response {
        let max = max_code(bits) as f64;
        let norm = curve.decode(mid_code(bits) as f64 / max);
        let ch: Vec<f64> = (0..=max_code(bits)).map(|z| curve.decode(z as f64 / max) / norm).collect();
        Response { bits, x: [ch.clone(), ch.clone(), ch] }
    }

    /// Why this response cannot be merged with, or `Ok` (see the module documentation).
    pub fn check(&self) -> Result<(), String> {
        let n = max_code(self.bits) + 1;
        for (c, name) in ["R", "G", "B"].iter().enumerate() {
            let x = &self.x[c];
            if x.len() != n {
                return Err(format!("the response's {name} has {} codes, not {n} ({} bits)", x.len(), self.bits));
            }
            if let Some(z) = x.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
                return Err(format!("the response's {name} at code {z} is {}, not a finite value >= 0", x[z]));
            }
            if let Some(z) = (1..n).find(|&z| x[z] < x[z - 1]) {
                return Err(format!(
                    "the response's {name} is not monotonic: code {z} stands for {} but code {} for {}",
                    x[z],
                    z - 1,
                    x[z - 1]
                ));
            }
            if !(x[n - 1] > x[0]) {
                return Err(format!("the response's {name} is constant"));
            }
        }
        Ok(())
    }

    /// The `curves` value: x = codes, series R, G, B.
    pub fn to_curves(&self, title: &str) -> Curves {
        Curves {
            title: title.to_string(),
            x_name: "code".into(),
            x_label: "code".into(),
            y_label: "relative exposure (middle code = 1)".into(),
            x: (0..=max_code(self.bits)).map(|z| z as f64).collect(),
            series: ["R", "G", "B"].iter().zip(&self.x).map(|(n, v)| (n.to_string(), v.clone())).collect(),
            scalars: vec![],
            markers: vec![],
        }
    }

    /// A response for codes of `bits` bits from a `curves` value (series R, G, B over the codes
    /// `0..=max`), checked ([`Response::check`]); the error says what is wrong.
    pub fn from_curves(curves: &Curves, bits: u8) -> Result<Response, String> {
        let n = max_code(bits) + 1;
        if curves.x.len() != n {
            return Err(format!(
                "the response has {} codes but the frames have {bits} bits ({n} codes): a response for another bit depth",
                curves.x.len()
            ));
        }
        if let Some(z) = (0..n).find(|&z| curves.x[z] != z as f64) {
            return Err(format!(
                "the response's x values must be the codes 0..={}; entry {z} is {}",
                n - 1,
                curves.x[z]
            ));
        }
        let get = |name: &str| {
            curves
                .series
                .iter()
                .find(|(s, _)| s == name)
                .map(|(_, v)| v.clone())
                .ok_or_else(|| format!("the response has no series {name:?} (it needs R, G and B)"))
        };
        let r = Response { bits, x: [get("R")?, get("G")?, get("B")?] };
        r.check()?;
        Ok(r)
    }

    /// Makes each channel non-decreasing from the middle code outwards: a running maximum above
    /// it and a running minimum below it, with negative values set to 0 (what a least-squares
    /// fit leaves at the rarely seen end codes; the middle code keeps its value 1).
    pub fn make_monotonic(&mut self) {
        let mid = mid_code(self.bits);
        for ch in &mut self.x {
            for z in mid + 1..ch.len() {
                ch[z] = ch[z].max(ch[z - 1]);
            }
            for z in (0..mid).rev() {
                ch[z] = ch[z].min(ch[z + 1]).max(0.0);
            }
        }
    }

    /// The largest relative error `|x / x_true - 1|` over channels and the codes `lo..=hi`, after
    /// the best scale per channel (the ratio's median): responses are known up to a scale.
    pub fn max_relative_error(&self, truth: &Response, lo: usize, hi: usize) -> f64 {
        let mut worst = 0.0f64;
        for c in 0..3 {
            let mut ratios: Vec<f64> = (lo..=hi).map(|z| self.x[c][z] / truth.x[c][z]).collect();
            ratios.sort_by(f64::total_cmp);
            let scale = ratios[ratios.len() / 2];
            for r in ratios {
                worst = worst.max((r / scale - 1.0).abs());
            }
        }
        worst
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_curves_round_trip_and_map_the_ends() {
        for k in Known::ALL {
            assert_eq!(k.encode(0.0), 0.0);
            assert!((k.encode(1.0) - 1.0).abs() < 1e-12, "{k}");
            for i in 1..1000 {
                let x = i as f64 / 1000.0;
                assert!((k.decode(k.encode(x)) / x - 1.0).abs() < 1e-9, "{k} at {x}");
                assert!(k.encode(x) > k.encode(x - 1e-3), "{k} increases");
            }
        }
        // The S curve's midpoint is 2.5 stops below the clip, where the logistic is 1/2.
        let v = Known::SCurve.encode(2f64.powf(-2.5));
        assert!((v - 0.5 / logistic(2.5)).abs() < 1e-12);
    }

    #[test]
    fn responses_round_trip_through_curves_and_bad_ones_are_refused() {
        let r = Response::known(Known::Srgb, 8);
        assert_eq!(r.x[0][128], 1.0);
        let back = Response::from_curves(&r.to_curves("t"), 8).unwrap();
        assert_eq!(back, r);
        let e = Response::from_curves(&r.to_curves("t"), 16).unwrap_err();
        assert!(e.contains("a response for another bit depth"), "{e}");
        let mut bad = r.clone();
        bad.x[1][200] = 0.5;
        let e = Response::from_curves(&bad.to_curves("t"), 8).unwrap_err();
        assert!(e.contains("G is not monotonic: code 200"), "{e}");
        bad.x[1][200] = f64::NAN;
        assert!(bad.check().unwrap_err().contains("not a finite value"));
        let mut flat = Response::linear(8);
        flat.x[2] = vec![1.0; 256];
        assert!(flat.check().unwrap_err().contains("B is constant"));
        let mut wiggly = Response::linear(8);
        wiggly.x[0][1] = -0.1;
        wiggly.x[0][250] = 0.5;
        wiggly.make_monotonic();
        assert!(wiggly.check().is_ok());
    }
}
