//! `Curves` (`curves` in graphs): named series over one shared abscissa, plus named scalars and
//! marked abscissae (e.g. Fresnel reflectance against angle, with its Brewster and critical
//! angles). Saved as `.json`, `.csv`, or a plot (`.png`, `.svg`): `crate::formats::save::curves`.
//!
//! A folder so that the type stays below the plots drawn of it: this file holds the type
//! (`crate::plotting::curves_plot` builds on it), [`codec`] its `TypeSpec` and cache payload.

pub mod codec;

pub use codec::CURVES;

/// A set of curves over a shared x axis.
/// Plain data, its fields public: what computes the curves (`maths::brdf::fresnel`) fills them in.
#[derive(Clone, Debug, PartialEq)]
pub struct Curves {
    /// Plot title.
    pub title: String,
    /// Name of the x column in JSON/CSV (e.g. `angles_deg`) and the x-axis label.
    pub x_name: String,
    pub x_label: String,
    pub y_label: String,
    pub x: Vec<f64>,
    /// (column name, values), each as long as `x`.
    pub series: Vec<(String, Vec<f64>)>,
    /// Named scalars written before the columns in JSON (`None` is JSON `null`).
    pub scalars: Vec<(String, Option<f64>)>,
    /// Vertical markers drawn on plots: (label, x).
    pub markers: Vec<(String, f64)>,
}
