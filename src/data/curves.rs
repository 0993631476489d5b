//! `Curves`: named series over one shared abscissa, plus named scalars and marked abscissae
//! (e.g. Fresnel reflectance against angle, with its Brewster and critical angles).

/// A set of curves over a shared x axis.
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
