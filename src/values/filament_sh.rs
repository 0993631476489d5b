//! `filament sh`: Filament's 9 pre-scaled irradiance coefficients ([`FilamentSh`],
//! `maths::ibl::sh_filament`), the type, its cache codec, and cmgen's `sh.txt` text, which the
//! value displays and `Save` writes as `.txt` (`crate::formats::save::sh`, also `.json`):
//!
//! - `.txt`: cmgen's `sh.txt`, byte for byte in layout (tools/cmgen/src/cmgen.cpp, `outputSh`):
//!   one line per coefficient, l = 0..2, m = -l..l,
//!   `(` r `, ` g `, ` b `); // L{l}{m}, irradiance, pre-scaled base`, each number
//!   `std::fixed << std::setprecision(15) << std::setw(18)` (15 decimals, right-aligned in 18),
//!   e.g. `( 0.712845027446747,  0.752190291881561,  0.811474263668060); // L00, irradiance, pre-scaled base`.
//!   Filament's samples read it with `IndirectLight::Builder::irradiance(3, sh)`.

use crate::engine::cache::codec::{Reader, Writer};
use crate::engine::value::{TypeSpec, Value, ValueData, ValueType};

/// Filament's irradiance SH: `E(n) / pi = sh[0] + sh[1] y + sh[2] z + sh[3] x + ...` in
/// Filament's world (`maths::ibl::sh_filament`), one `[r, g, b]` per coefficient.
#[derive(Clone, Debug, PartialEq)]
pub struct FilamentSh {
    pub rgb: [[f64; 3]; 9],
}

pub static FILAMENT_SH: TypeSpec = TypeSpec {
    name: "filament sh",
    doc:
        "Filament's 9 pre-scaled irradiance SH coefficients (cmgen's sh.txt): E/pi = sh0 + sh1 y + sh2 z + sh3 x + ...",
    decode,
};

impl ValueData for FilamentSh {
    fn value_type(&self) -> ValueType {
        ValueType(&FILAMENT_SH)
    }
    fn approx_bytes(&self) -> usize {
        9 * 24
    }
    fn summary(&self) -> String {
        let [r, g, b] = self.rgb[0];
        format!("Filament irradiance SH (9, pre-scaled; mean E/pi ({r:.4}, {g:.4}, {b:.4}))")
    }
    fn display(&self) -> Option<String> {
        Some(sh_txt(self).trim_end().to_string())
    }
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = Writer(out);
        for c in &self.rgb {
            for v in c {
                w.f64(*v);
            }
        }
    }
}

fn decode(bytes: &[u8]) -> Result<Value, String> {
    let mut r = Reader::new(bytes);
    r.need(9 * 24)?;
    let mut rgb = [[0.0; 3]; 9];
    for c in rgb.iter_mut() {
        *c = [r.f64()?, r.f64()?, r.f64()?];
    }
    r.finish()?;
    Ok(Value::new(FilamentSh { rgb }))
}

/// cmgen's `sh.txt` text (see the module documentation).
pub fn sh_txt(sh: &FilamentSh) -> String {
    let mut out = String::new();
    let mut i = 0;
    for l in 0..3i32 {
        for m in -l..=l {
            let [r, g, b] = sh.rgb[i];
            out.push_str(&format!("({r:>18.15}, {g:>18.15}, {b:>18.15}); // L{l}{m}, irradiance, pre-scaled base\n"));
            i += 1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> FilamentSh {
        let mut rgb = [[0.0; 3]; 9];
        for (i, c) in rgb.iter_mut().enumerate() {
            *c = [0.712845027446747 - i as f64 * 0.1, 0.0 - 0.25 * i as f64, 12.5 / (i + 1) as f64];
        }
        FilamentSh { rgb }
    }

    /// The layout of cmgen's `outputSh`: names L00, L1-1 ... L22, 15 decimals right-aligned in
    /// 18 columns (a negative number fills them).
    #[test]
    fn sh_txt_is_cmgens_layout() {
        let text = sh_txt(&sample());
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 9);
        assert_eq!(
            lines[0],
            "( 0.712845027446747,  0.000000000000000, 12.500000000000000); // L00, irradiance, pre-scaled base"
        );
        assert!(lines[1].starts_with("( 0.612845027446747, -0.250000000000000,  6.250000000000000); // L1-1,"));
        let names: Vec<&str> =
            lines.iter().map(|l| l.split("// ").nth(1).unwrap().split(',').next().unwrap()).collect();
        assert_eq!(names, ["L00", "L1-1", "L10", "L11", "L2-2", "L2-1", "L20", "L21", "L22"]);
        assert!(text.ends_with("pre-scaled base\n"));
    }

    #[test]
    fn cache_round_trip() {
        let sh = sample();
        let mut bytes = Vec::new();
        sh.encode(&mut bytes);
        assert_eq!(decode(&bytes).unwrap().get::<FilamentSh>(), Some(&sh));
        assert!(decode(&bytes[..bytes.len() - 1]).unwrap_err().starts_with("truncated: need"));
    }
}
