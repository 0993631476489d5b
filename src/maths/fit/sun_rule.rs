//! Which bright region is a sun: the rule `SunExtract` (and so `hdrflow bake`'s default `--sun
//! extract`) applies to the region [`super::sun`] finds around the brightest texel, before it
//! takes anything out of the map.
//!
//! A bake turns the sun into the engine's directional light, which has no size: that stands for
//! the region well only when the region is small and carries much of the light. Two bounds, both
//! parameters of `SunExtract`:
//! - **size**: the region's solid angle `Omega`, as the cone of the same solid angle, has a half
//!   angle `r = acos(1 - Omega / 2 pi)` of at most `max_radius_deg` (default 3 degrees). The sun
//!   itself is 0.27 degrees; lens glare in captured maps widens it (rooitou_park_1k's region:
//!   2.0 degrees). A studio's softbox (studio_small_03_1k: 6.5 degrees) or a window is not a
//!   sun: a directional light would put its broad highlight in one sharp point.
//! - **share**: the light taken out, `sum_S (Y_i - Y(F)) dOmega_i` (luminance over the region
//!   above the fill, [`super::sun`]'s step 4), is at least `min_share` (default 0.1) of the map's
//!   luminous integral `sum_i Y_i dOmega_i`. The park's sun is 0.66 of its map; a small lamp
//!   indoors (st_fagans_interior_1k: 0.67 degrees, 0.017) or a bright marker is not a sun: the
//!   prefiltered maps keep it where it is, and the scene needs no light added back.
//!
//! A region that fails either bound stays in the map: the light is zero, the residual is the map,
//! and [`Rejected`] says which bound failed with the region's numbers (the operator reports it).

use std::fmt;

/// The rule's three numbers (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunRule {
    /// the region is what exceeds the reference level (the median luminance) by this many stops
    pub threshold_stops: f64,
    /// the largest half angle (degrees) of the cone of the region's solid angle
    pub max_radius_deg: f64,
    /// the smallest fraction of the map's luminous integral the light may carry
    pub min_share: f64,
}

impl SunRule {
    /// `SunExtract`'s defaults.
    pub const DEFAULT: SunRule = SunRule { threshold_stops: 8.0, max_radius_deg: 3.0, min_share: 0.1 };

    /// No bound on size or share: the brightest region above `threshold_stops`, whatever it is.
    pub fn any(threshold_stops: f64) -> SunRule {
        SunRule { threshold_stops, max_radius_deg: 180.0, min_share: 0.0 }
    }

    /// Whether a region of `solid_angle` steradians whose light is `share` of the map's luminous
    /// integral is a sun by this rule.
    pub fn judge(&self, solid_angle: f64, share: f64) -> Option<Rejection> {
        let radius_deg = cone_radius_deg(solid_angle);
        if radius_deg > self.max_radius_deg {
            Some(Rejection::TooLarge { max_radius_deg: self.max_radius_deg })
        } else if share < self.min_share {
            Some(Rejection::TooFaint { min_share: self.min_share })
        } else {
            None
        }
    }
}

impl Default for SunRule {
    fn default() -> Self {
        SunRule::DEFAULT
    }
}

/// Which bound a region failed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rejection {
    /// wider than `max_radius_deg`
    TooLarge { max_radius_deg: f64 },
    /// carrying less than `min_share` of the light
    TooFaint { min_share: f64 },
}

/// A bright region the rule left in the map, with its numbers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rejected {
    pub rejection: Rejection,
    /// the region's texels
    pub texels: usize,
    /// the half angle of the cone of its solid angle, degrees
    pub radius_deg: f64,
    /// the fraction of the map's luminous integral above the fill
    pub share: f64,
    /// its luminance-weighted centre
    pub direction: [f64; 3],
}

impl fmt::Display for Rejected {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let what = format!(
            "the brightest region ({:.2} degrees across as a disc, {:.1}% of the map's light) is not a sun",
            2.0 * self.radius_deg,
            100.0 * self.share
        );
        match self.rejection {
            Rejection::TooLarge { max_radius_deg } => write!(
                f,
                "{what}: wider than max_radius_deg {max_radius_deg} (a radius of {:.2}); it stays in the map",
                self.radius_deg
            ),
            Rejection::TooFaint { min_share } => {
                write!(f, "{what}: less than min_share {min_share} of the light; it stays in the map")
            }
        }
    }
}

/// The half angle (degrees) of the cone whose solid angle is `solid_angle`:
/// `acos(1 - Omega / 2 pi)` (0 for 0; 180 for the whole sphere).
pub fn cone_radius_deg(solid_angle: f64) -> f64 {
    (1.0 - solid_angle / (2.0 * std::f64::consts::PI)).clamp(-1.0, 1.0).acos().to_degrees()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn cone_radius_inverts_the_cone_solid_angle() {
        for r in [0.1f64, 0.27, 2.0, 3.0, 45.0, 90.0, 180.0] {
            let omega = 2.0 * PI * (1.0 - r.to_radians().cos());
            assert!((cone_radius_deg(omega) - r).abs() < 1e-6, "{r}");
        }
        assert_eq!(cone_radius_deg(0.0), 0.0);
        assert_eq!(cone_radius_deg(100.0), 180.0);
    }

    /// The three shipped maps' regions (measured: docs/src/guides/baking/sun.md): the park's
    /// sun is one, the studio's softbox and the interior's lamp are not.
    #[test]
    fn the_default_rule_on_the_shipped_maps_regions() {
        let rule = SunRule::DEFAULT;
        assert_eq!(rule.judge(0.003887, 0.66), None);
        assert_eq!(rule.judge(0.04013, 0.72), Some(Rejection::TooLarge { max_radius_deg: 3.0 }));
        assert_eq!(rule.judge(0.000431, 0.017), Some(Rejection::TooFaint { min_share: 0.1 }));
        assert_eq!(SunRule::any(8.0).judge(0.04013, 0.0), None);
    }

    #[test]
    fn rejections_say_which_bound_and_the_numbers() {
        let r = Rejected {
            rejection: Rejection::TooLarge { max_radius_deg: 3.0 },
            texels: 900,
            radius_deg: 6.48,
            share: 0.72,
            direction: [0.0, 1.0, 0.0],
        };
        let text = r.to_string();
        assert!(
            text.contains("12.96 degrees") && text.contains("72.0%") && text.contains("max_radius_deg 3"),
            "{text}"
        );
    }
}
