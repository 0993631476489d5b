//! `Metrics`: a flat record of named numbers (error metrics, statistics), saved as JSON or CSV.

#[derive(Clone, Debug, PartialEq, Default)]
pub struct Metrics {
    pub fields: Vec<(String, f64)>,
}

impl Metrics {
    pub fn get(&self, name: &str) -> Option<f64> {
        self.fields.iter().find(|(n, _)| n == name).map(|(_, v)| *v)
    }
}
