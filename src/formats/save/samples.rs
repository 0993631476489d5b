//! How `Save` writes a [`SampleSet`]: `.csv` (`index,x,y,theta,phi,dx,dy,dz,pdf`, one row per
//! sample) or `.json` (`width`, `height`, `count` and `samples`, each with those keys).

use crate::engine::registry::Registry;
use crate::engine::save::SaveOptions;
use crate::engine::value::Value;
use crate::values::json::num;
use crate::values::{SampleSet, SAMPLES};

/// Registers the saver of sample sets.
pub fn register(r: &mut Registry) {
    r.register_saver(&SAMPLES, &["csv", "json"], save);
}

fn save(value: &Value, o: &SaveOptions) -> Result<Vec<u8>, String> {
    let s = value.get::<SampleSet>().ok_or("not a sample set")?;
    Ok(match o.ext.as_str() {
        "csv" => samples_csv(s).into_bytes(),
        _ => samples_json(s).into_bytes(),
    })
}

fn samples_csv(s: &SampleSet) -> String {
    let header = ["index", "x", "y", "theta", "phi", "dx", "dy", "dz", "pdf"].map(String::from);
    let rows = s.samples.iter().enumerate().map(|(i, p)| {
        [i.to_string(), p.x.to_string(), p.y.to_string()]
            .into_iter()
            .chain([p.theta, p.phi, p.dir[0], p.dir[1], p.dir[2], p.pdf].map(|v| v.to_string()))
            .collect::<Vec<_>>()
    });
    crate::formats::csv::text(std::iter::once(header.to_vec()).chain(rows))
}

fn samples_json(s: &SampleSet) -> String {
    let samples: Vec<serde_json::Value> = s
        .samples
        .iter()
        .map(|p| {
            serde_json::json!({
                "x": p.x, "y": p.y, "theta": num(p.theta as f64), "phi": num(p.phi as f64),
                "dx": num(p.dir[0] as f64), "dy": num(p.dir[1] as f64), "dz": num(p.dir[2] as f64),
                "pdf": num(p.pdf as f64),
            })
        })
        .collect();
    let v = serde_json::json!({ "width": s.width, "height": s.height, "count": s.samples.len(), "samples": samples });
    serde_json::to_string_pretty(&v).expect("JSON of plain values") + "\n"
}
