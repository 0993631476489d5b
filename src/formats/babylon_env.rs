//! Babylon.js `.env` files (write only), the prefiltered environment that
//! `CubeTexture.CreateFromPrefilteredData(url, scene)` (or `new CubeTexture("x.env", scene)`)
//! loads, as Babylon's own `EnvironmentTextureTools.CreateEnvTextureAsync` writes them
//! (`packages/dev/core/src/Misc/environmentTextureTools.ts`, format version 2):
//!
//! - the 8 magic bytes `86 16 87 96 f6 d6 96 36`;
//! - a JSON manifest (ASCII) ended by a NUL byte: `version` 2, `width` (level 0's face size),
//!   `imageType` `"image/png"`, `irradiance` (the spherical polynomial `x, y, z, xx, yy, zz, yz,
//!   zx, xy`, one RGB triple each: [`Polynomial`]), `specular.mipmaps` (one `{length, position}`
//!   per image, position counted from the byte after the NUL) and `specular.lodGenerationScale`;
//! - then every level's six faces, level 0 first, faces +X -X +Y -Y +Z -Z, each an 8-bit RGBA
//!   PNG in RGBD (`formats::rgbd`). Babylon's loader insists on a chain down to 1 x 1
//!   (`6 (log2(width) + 1)` images, "Unsupported specular mipmaps number") and a power-of-two width.
//!
//! Texels beyond RGBD's 255 are clamped and counted by [`encode`]. Rows are written as Babylon's
//! own files hold them (see [`encode`]'s `flip_rows`).

use serde_json::json;

use super::rgbd;
use crate::values::Cubemap;

/// The file's first bytes (`MagicBytes`).
pub const MAGIC: [u8; 8] = [0x86, 0x16, 0x87, 0x96, 0xf6, 0xd6, 0x96, 0x36];

/// Babylon's spherical polynomial (`SphericalPolynomial`: `x, y, z, xx, yy, zz, yz, zx, xy`, one
/// RGB triple each, in Babylon's world). It is not `E / pi` itself: Babylon makes it with
/// `SphericalPolynomial.FromHarmonics` from the SH of the Lambertian radiance `E / pi`
/// (`CubeMapToSphericalPolynomialTools`: `convertIncidentRadianceToIrradiance`,
/// `convertIrradianceToLambertianRadiance`), and `updateFromHarmonics` scales them by the cosine
/// lobe's constants once more; the renderer undoes that (`SphericalHarmonics.FromPolynomial`,
/// `preScaleForRendering`) and evaluates the SH of `E / pi` at the normal: [`Polynomial::irradiance`].
#[derive(Clone, Debug, PartialEq)]
pub struct Polynomial {
    /// `[x, y, z, xx, yy, zz, yz, zx, xy]`, one RGB triple each
    pub terms: [[f64; 3]; 9],
}

/// What `Save` passes the `.env` encoder (`SaveOptions::with`): the irradiance, if any.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EnvIrradiance(pub Option<Polynomial>);

/// Babylon's `lodGenerationScale` for the files it prefilters itself (`HDRFiltering`,
/// `Materials/Textures/Filtering/hdrFiltering.ts`): level `l` holds GGX of `alphaG = 2^(l / 0.8) /
/// width`, and the PBR shader reads `lod = 0.8 log2(width alphaG)`.
pub const LOD_GENERATION_SCALE: f64 = 0.8;

/// The names of [`Polynomial::terms`] in the manifest.
pub const TERMS: [&str; 9] = ["x", "y", "z", "xx", "yy", "zz", "yz", "zx", "xy"];

/// The real SH basis constants of hdrflow's basis (no Condon-Shortley phase): `Y_00`, `Y_1m / x`,
/// `Y_2,-2 / xy` (also `yz`, `xz`), `Y_20 / (3 z^2 - 1)`, `Y_22 / (x^2 - y^2)`.
const C0: f64 = 0.282_094_791_773_878_1;
const C1: f64 = 0.488_602_511_902_919_9;
const C2: f64 = 1.092_548_430_592_079;
const C20: f64 = 0.315_391_565_252_520_1;
const C22: f64 = 0.546_274_215_296_039_5;
/// The cosine lobe's band factors over pi (Ramamoorthi-Hanrahan's `A_l / pi`).
pub const A: [f64; 3] = [1.0, 2.0 / 3.0, 0.25];

/// The band `l` of SH index `i = l^2 + l + m` (order 2: `i < 9`).
pub fn band(i: usize) -> usize {
    match i {
        0 => 0,
        1..=3 => 1,
        _ => 2,
    }
}

impl Polynomial {
    /// From the 9 orthonormal radiance SH `L_lm` (hdrflow's real basis, index `l^2 + l + m`;
    /// `ShIrradiance`) in the axes Babylon evaluates them in, as Babylon makes it: the SH of
    /// `E / pi` (`A_l / pi L_lm`) through `updateFromHarmonics` (its constants 1.02333, 0.886277,
    /// 0.247708, 0.429043, 0.495417, 0.858086 are `A_l Y` products; its signs undo its own
    /// Condon-Shortley phase).
    pub fn from_sh(l: &[[f64; 3]]) -> Result<Polynomial, String> {
        if l.len() < 9 {
            return Err(format!("Babylon's polynomial needs the 9 SH of order 2, got {}", l.len()));
        }
        // The SH of E / pi, then updateFromHarmonics' scaling (A_l / pi again, the basis constants).
        let h = |i: usize, k: usize| A[band(i)] * A[band(i)] * l[i][k];
        let t = |f: &dyn Fn(usize) -> f64| [f(0), f(1), f(2)];
        let terms = [
            t(&|k| C1 * h(3, k)),
            t(&|k| C1 * h(1, k)),
            t(&|k| C1 * h(2, k)),
            t(&|k| C0 * h(0, k) - C20 * h(6, k) + C22 * h(8, k)),
            t(&|k| C0 * h(0, k) - C20 * h(6, k) - C22 * h(8, k)),
            t(&|k| C0 * h(0, k) + 2.0 * C20 * h(6, k)),
            t(&|k| C2 * h(5, k)),
            t(&|k| C2 * h(7, k)),
            t(&|k| C2 * h(4, k)),
        ];
        Ok(Polynomial { terms })
    }

    /// What Babylon's PBR shader computes from this polynomial at a unit normal `n` of its world:
    /// the SH of `SphericalHarmonics.FromPolynomial` (its constants 0.376127, 0.977204, 1.16538,
    /// 1.34567, 0.672834, times pi) evaluated there (`preScaleForRendering`,
    /// `computeEnvironmentIrradiance`): `E(n) / pi` of the SH `from_sh` was given.
    pub fn irradiance(&self, n: [f64; 3]) -> [f64; 3] {
        let [x, y, z] = n;
        let [px, py, pz, xx, yy, zz, yz, zx, xy] = self.terms;
        let pi = std::f64::consts::PI;
        [0, 1, 2].map(|k| {
            let h00 = 0.376127 * (xx[k] + yy[k]) + 0.376126 * zz[k];
            let h1 = [py[k], pz[k], px[k]].map(|v| 0.977204 * v);
            let h2 = [
                1.16538 * xy[k],
                1.16538 * yz[k],
                1.34567 * zz[k] - 0.672834 * (xx[k] + yy[k]),
                1.16538 * zx[k],
                1.16538 * (xx[k] - yy[k]),
            ];
            pi * (h00 * C0
                + C1 * (h1[0] * y + h1[1] * z + h1[2] * x)
                + C2 * (h2[0] * x * y + h2[1] * y * z + h2[3] * z * x)
                + C20 * h2[2] * (3.0 * z * z - 1.0)
                + C22 * h2[4] * (x * x - y * y))
        })
    }
}

/// The `.env` file of `levels` (level k of face size `size >> k`, down to 1 x 1) and the
/// irradiance `polynomial`, with Babylon's `lod_generation_scale`; and how many texels were
/// beyond RGBD's range (clamped). `flip_rows` writes each face bottom row first: Babylon uploads
/// the PNGs with `invertY`, so its files hold each face of the OpenGL cube upside down.
pub fn encode(
    levels: &[Cubemap],
    polynomial: Option<&Polynomial>,
    lod_generation_scale: f64,
    flip_rows: bool,
) -> Result<(Vec<u8>, usize), String> {
    let size = levels.first().ok_or("a .env needs at least one level")?.size;
    if !size.is_power_of_two() {
        return Err(format!(
            "Babylon's .env needs a power-of-two face size (its loader: \"Texture size must be a power of two\"), got {size}"
        ));
    }
    let want = size.trailing_zeros() as usize + 1;
    if levels.len() != want {
        return Err(format!(
            "Babylon's .env holds every level down to 1 x 1: {want} levels for faces of {size}, got {}",
            levels.len()
        ));
    }
    for (k, c) in levels.iter().enumerate() {
        if c.size != size >> k {
            return Err(format!("level {k} has faces of {}, not {}", c.size, size >> k));
        }
    }
    let (images, overflow) = rgbd::chain_pngs(levels, flip_rows)?;
    let mut position = 0;
    let mipmaps: Vec<_> = images
        .iter()
        .map(|png| {
            let entry = json!({ "length": png.len(), "position": position });
            position += png.len();
            entry
        })
        .collect();
    let irradiance = match polynomial {
        Some(p) => {
            let mut m = serde_json::Map::new();
            for (name, t) in TERMS.iter().zip(&p.terms) {
                m.insert(name.to_string(), json!(t.to_vec()));
            }
            serde_json::Value::Object(m)
        }
        None => serde_json::Value::Null,
    };
    let manifest = json!({
        "version": 2,
        "width": size,
        "imageType": "image/png",
        "irradiance": irradiance,
        "specular": { "mipmaps": mipmaps, "lodGenerationScale": lod_generation_scale },
    });
    let text = serde_json::to_string(&manifest).map_err(|e| e.to_string())?;
    let mut out = Vec::with_capacity(MAGIC.len() + text.len() + 1 + position);
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(text.as_bytes());
    out.push(0);
    for png in images {
        out.extend_from_slice(&png);
    }
    Ok((out, overflow))
}

/// The manifest and the images of a `.env` file: what Babylon's `GetEnvInfo` and
/// `CreateRadianceImageDataArrayBufferViews` read (for tests and checks).
pub fn decode(bytes: &[u8]) -> Result<(serde_json::Value, Vec<&[u8]>), String> {
    if bytes.len() < MAGIC.len() || bytes[..MAGIC.len()] != MAGIC {
        return Err("not a Babylon environment map (magic bytes)".into());
    }
    let rest = &bytes[MAGIC.len()..];
    let nul = rest.iter().position(|&b| b == 0).ok_or("the manifest has no NUL terminator")?;
    let manifest: serde_json::Value = serde_json::from_slice(&rest[..nul]).map_err(|e| format!("the manifest: {e}"))?;
    let data = &rest[nul + 1..];
    let mut images = Vec::new();
    for m in manifest["specular"]["mipmaps"].as_array().ok_or("no specular.mipmaps")? {
        let (p, l) = (m["position"].as_u64().unwrap_or(u64::MAX) as usize, m["length"].as_u64().unwrap_or(0) as usize);
        images.push(data.get(p..p.saturating_add(l)).ok_or("an image beyond the file's end")?);
    }
    Ok((manifest, images))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::ibl::sh::eval_sh;
    use crate::values::ShFrame;

    /// What Babylon's shader makes of the polynomial is `E / pi` of the SH it came from
    /// (Ramamoorthi-Hanrahan's `A_l`), to Babylon's 6-digit constants.
    #[test]
    fn babylon_reads_the_polynomial_as_lambertian_radiance_of_the_sh() {
        let l: Vec<[f64; 3]> = (0..9).map(|i| [0.3 + 0.1 * i as f64, -0.2 * i as f64, (i as f64).sin()]).collect();
        let p = Polynomial::from_sh(&l).unwrap();
        let a = [1.0, 2.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0, 0.25, 0.25, 0.25, 0.25, 0.25];
        for d in [[0.0, 1.0, 0.0], [0.6, 0.0, -0.8], [0.48, 0.6, 0.64], [-0.36, -0.48, 0.8]] {
            let y = eval_sh(ShFrame::World, 2, d);
            let want: [f64; 3] = [0, 1, 2].map(|k| (0..9).map(|i| a[i] * l[i][k] * y[i]).sum());
            let got = p.irradiance(d);
            for k in 0..3 {
                assert!((got[k] - want[k]).abs() < 2e-5, "{d:?}: {got:?} vs {want:?}");
            }
        }
        // A constant radiance 1 (L00 = 2 sqrt(pi)): E / pi = 1, which Babylon's
        // updateFromHarmonics stores as xx = yy = zz = 0.886277 L00 / pi = 1.
        let mut c = vec![[0.0; 3]; 9];
        c[0] = [2.0 * std::f64::consts::PI.sqrt(); 3];
        let p = Polynomial::from_sh(&c).unwrap();
        assert!((p.terms[3][0] - 1.0).abs() < 1e-12 && p.terms[0] == [0.0; 3], "{:?}", p.terms);
        assert!((p.irradiance([0.0, 0.0, 1.0])[0] - 1.0).abs() < 1e-5);
        assert!(Polynomial::from_sh(&l[..4]).is_err());
    }

    fn cube(size: usize, v: f32) -> Cubemap {
        let mut c = Cubemap::new(size);
        for (i, x) in c.data.iter_mut().enumerate() {
            *x = v * (1.0 + (i % 7) as f32);
        }
        c
    }

    /// The manifest reads back as Babylon's `GetEnvInfo` reads it, the images lie where it says,
    /// each a PNG of its level's size, and a bright texel is counted.
    #[test]
    fn manifest_round_trips_and_images_are_where_it_says() {
        let mut levels: Vec<Cubemap> = (0..4).map(|k| cube(8 >> k, 0.1 * (k + 1) as f32)).collect();
        levels[0].data[0] = 1000.0;
        let p = Polynomial { terms: [[0.5, 0.25, 0.125]; 9] };
        let (bytes, overflow) = encode(&levels, Some(&p), 0.8, true).unwrap();
        assert_eq!(overflow, 1);
        let (m, images) = decode(&bytes).unwrap();
        assert_eq!(m["version"], 2);
        assert_eq!(m["width"], 8);
        assert_eq!(m["imageType"], "image/png");
        assert_eq!(m["specular"]["lodGenerationScale"], 0.8);
        assert_eq!(m["irradiance"]["zx"], json!([0.5, 0.25, 0.125]));
        assert_eq!(images.len(), 24);
        for (i, png) in images.iter().enumerate() {
            let img = image::load_from_memory(png).unwrap().to_rgba8();
            assert_eq!(img.width() as usize, 8 >> (i / 6), "image {i}");
        }
        // Face +X of level 1, row 0 of the file = the cube's last row (flip_rows).
        let img = image::load_from_memory(images[6]).unwrap().to_rgba8();
        let s = 4;
        let want = rgbd::rgbd([0, 1, 2].map(|k| levels[1].data[3 * ((s - 1) * s) + k])).0;
        assert_eq!(img.get_pixel(0, 0).0, want);
        assert!(encode(&levels[..3], None, 0.8, true).unwrap_err().contains("4 levels"));
        assert!(encode(&[cube(6, 1.0)], None, 0.8, true).unwrap_err().contains("power-of-two"));
        assert!(decode(&bytes[1..]).is_err());
    }
}
