//! Real spherical harmonics (SH) of any order, projection of a lat-long map onto them in a
//! chosen frame, and the irradiance environment map of Ramamoorthi and Hanrahan.
//!
//! # The basis
//!
//! For band `l >= 0` and `-l <= m <= l`, as a function of a unit vector `(x, y, z)` with polar
//! angle `t` from +z and azimuth `p` from +x towards +y (`x = sin t cos p`, `y = sin t sin p`,
//! `z = cos t`):
//!
//! ```text
//! Y_l0  = K_l^0 P_l^0(z)
//! Y_lm  = sqrt(2) K_l^m cos(m p) P_l^m(z)        m > 0
//! Y_l-m = sqrt(2) K_l^m sin(m p) P_l^m(z)        m > 0
//! K_l^m = sqrt((2l + 1) / (4 pi) * (l - m)! / (l + m)!)
//! ```
//!
//! with `P_l^m` the associated Legendre polynomials *without* the Condon-Shortley phase
//! (`P_m^m = (2m - 1)!! (1 - z^2)^(m/2)`). Up to order 2 this is Ramamoorthi and Hanrahan's
//! table (2001, eq. 3), the same polynomials as three.js `SphericalHarmonics3.getBasisAt`:
//!
//! ```text
//! Y_00  = 1 / (2 sqrt(pi))             = 0.282095
//! Y_1-1 = sqrt(3) / (2 sqrt(pi))  y    = 0.488603 y
//! Y_10  = sqrt(3) / (2 sqrt(pi))  z    = 0.488603 z
//! Y_11  = sqrt(3) / (2 sqrt(pi))  x    = 0.488603 x
//! Y_2-2 = sqrt(15) / (2 sqrt(pi)) xy   = 1.092548 xy
//! Y_2-1 = sqrt(15) / (2 sqrt(pi)) yz   = 1.092548 yz
//! Y_20  = sqrt(5) / (4 sqrt(pi))  (3z^2 - 1) = 0.315392 (3z^2 - 1)
//! Y_21  = sqrt(15) / (2 sqrt(pi)) xz   = 1.092548 xz
//! Y_22  = sqrt(15) / (4 sqrt(pi)) (x^2 - y^2) = 0.546274 (x^2 - y^2)
//! ```
//!
//! The basis is orthonormal over the sphere. Coefficients are stored at index `l (l + 1) + m`
//! ([`sh_index`]), `(L + 1)^2` of them for order `L` ([`sh_count`]). Definitions: P.-P. Sloan,
//! "Stupid Spherical Harmonics (SH) Tricks", GDC 2008 (which keeps the Condon-Shortley phase: his
//! odd-m functions have the opposite sign, as have Filament's raw `cmgen --sh` coefficients);
//! R. Green, "Spherical Harmonic Lighting: The Gritty Details", GDC 2003.
//!
//! # Frames
//!
//! Which axes `(x, y, z)` are in hdrflow's world ([`ShFrame`]; `d` a unit direction, world +Y
//! up, -Z forward, +X right, the lat-long convention of [`crate::geometry::latlong`]:
//! `d = (-sin t sin p, cos t, sin t cos p)` for the map's theta and phi):
//!
//! ```text
//! World    (x, y, z) = ( d_x, d_y,  d_z)   hdrflow's axes, Y up; three.js, Filament
//! Paper    (x, y, z) = ( d_x, d_y, -d_z)   Ramamoorthi-Hanrahan for a Debevec probe, z forward
//! LatLong  (x, y, z) = ( d_z, -d_x, d_y)   z up, p = the map's phi (ShIrradiance version 1)
//! ```
//!
//! `World` is what a Y-up engine evaluates with a world-space normal: three.js
//! `SphericalHarmonics3` (`0.488603 * y`, `* z`, `* x` in slots 1, 2, 3) and Filament's 3-band
//! irradiance SH (`computeIrradianceSH3Bands`, shader `Irradiance_SphericalHarmonics`: `n.y`,
//! `n.z`, `n.x`, ...). Its polar axis is Z, so `L_1,-1` is the up component and `L_20` is zonal
//! about the forward-back axis. `Paper` is the frame Ramamoorthi and Hanrahan's published
//! Grace Cathedral coefficients are expressed in (computed from Debevec's angular probe): z
//! towards the probe's centre, that is forward, x right, y up. hdrflow's `Paper` coefficients of
//! `grace_probe.hdr` match their 27 numbers to 0.005 once each channel is scaled by its `L_00`
//! (`tests/sh_frames.rs`); in the `LatLong` frame, which version 1 of `ShIrradiance` used and
//! documented as theirs, 20 of the 27 differ in place or sign. `Paper` is a mirror image of
//! `World` (z reversed), so `L_lm(Paper) = (-1)^(l + m) L_lm(World)`, since
//! `P_l^m(-z) = (-1)^(l + m) P_l^m(z)`. `LatLong` puts the pole on the map's pole, so rotating
//! the map about +Y by `a` (its columns shifted by `a W / (2 pi)`) keeps `L_l0` and turns each
//! pair `(L_lm, L_l-m)` by `m a`; it is the frame hdrflow projects in (below) and the one
//! `ShSphere` works in. `Paper` and `LatLong` are left-handed in hdrflow's right-handed world
//! (determinant -1), so no rotation maps `World` onto them: the change of frame is an
//! orthogonal map per band that includes a reflection.
//!
//! # Evaluation
//!
//! The normalised polynomials `Pbar_l^m = K_l^m P_l^m` are computed directly, which never forms
//! the factorials (no overflow at high order): with `s = sin t`, `Pbar_l^m = s^m Q_l^m(z)` and
//!
//! ```text
//! Q_0^0 = 1 / sqrt(4 pi)
//! Q_m^m = sqrt((2m + 1) / (2m)) Q_{m-1}^{m-1}
//! Q_{m+1}^m = sqrt(2m + 3) z Q_m^m
//! Q_l^m = a_lm (z Q_{l-1}^m - b_lm Q_{l-2}^m),  a_lm = sqrt((4l^2 - 1) / (l^2 - m^2)),
//!                                               b_lm = sqrt(((l-1)^2 - m^2) / (4(l-1)^2 - 1))
//! ```
//!
//! These are the three-term recurrences of the unnormalised `P_l^m` (Green 2003; Sloan 2008;
//! pbrt-v2 `core/sh.cpp`: `P_m^m = (2m-1)!! s^m`, `P_{m+1}^m = z (2m+1) P_m^m`,
//! `(l - m) P_l^m = z (2l - 1) P_{l-1}^m - (l + m - 1) P_{l-2}^m`) multiplied through by `K_l^m`
//! (the form used for very high degrees in geodesy: S. A. Holmes, W. E. Featherstone, J. Geodesy
//! 76, 2002). The azimuthal factors `s^m cos(m p)` and `s^m sin(m p)` are the real and imaginary
//! parts of `(x + i y)^m`, so a direction is evaluated without trigonometry and exactly at the
//! poles. The tests check the recurrence against the factorial form up to l = 8 and
//! orthonormality by exact (Gauss-Legendre) quadrature.
//!
//! # Irradiance (Ramamoorthi and Hanrahan 2001)
//!
//! R. Ramamoorthi, P. Hanrahan, "An Efficient Representation for Irradiance Environment Maps",
//! SIGGRAPH 2001, eqs. 7-9: the irradiance is the radiance convolved with the clamped cosine, a
//! zonal kernel, so by the Funk-Hecke theorem each band is scaled by one number:
//!
//! ```text
//! E(n) = sum_l A_l sum_m L_lm Y_lm(n)
//! A_0 = pi, A_1 = 2 pi / 3, A_l = 0 for odd l > 1,
//! A_l = 2 pi (-1)^(l/2 - 1) / ((l + 2)(l - 1)) * l! / (2^l ((l/2)!)^2)  for even l
//! ```
//!
//! (A_2 = pi/4, A_4 = -pi/24, A_6 = pi/64.) `E` does not depend on the frame, as long as `L_lm`
//! and `Y_lm(n)` use the same one. Order 2 (9 coefficients) is their irradiance map: the
//! truncation error of the kernel is small for smooth lighting (they report ~1% average, < 9%
//! worst for their maps), and large for a small bright source, whose energy is spread over all
//! bands (a sun gives rings and negative values opposite to it). Results are not clamped.
//!
//! # Projection
//!
//! `L_lm = sum_texels L_i Y_lm(d_i) dOmega_i` (midpoint rule with hdrflow's texel solid angle,
//! the same quadrature as `reference::irradiance_exact`), in f64, first in the `LatLong` frame:
//! per row the sum over columns is a short Fourier sum (`sum_x L cos(m phi_x)`,
//! `sum_x L sin(m phi_x)`), multiplied by the row's `Pbar_l^m`: O(W H (L + 1)) work, rows in
//! parallel, row results added in row order (so independent of the number of threads). Another
//! frame's coefficients are then, band by band, `L'_l = T_l L_l` with
//! `T_l[m][m'] = int Y_lm(frame axes of d) Y_lm'(LatLong axes of d) dd` ([`frame_matrices`]):
//! `Y_lm` of the new axes is a combination of the band-`l` functions of the old ones, since the
//! axes are an orthogonal transform of each other, so this equals the midpoint sum taken
//! directly in the new axes (a test checks it against that sum). `T_l` is computed by exact
//! quadrature (Gauss-Legendre in `z` times equally spaced azimuths: the integrand is a
//! polynomial of degree `2l`), and entries within 1e-13 of 0 or +-1 are set to exactly that
//! (so `L_00` is unchanged and band 1 is an exact signed permutation).
//!
//! # Files
//!
//! One step per file: `basis` (indexing and evaluation), `project` (a map's coefficients in
//! the `LatLong` frame), `frames` (the change to another frame), `irradiance` (the band
//! factors `A_l`, `E(n)` and the lit sphere). Callers use the re-exports below.

mod basis;
mod frames;
mod irradiance;
mod project;
#[cfg(test)]
mod test_support;

pub use basis::{coefficient_name, eval_sh, eval_sh_into, sh_count, sh_index, sh_lm};
pub use frames::{frame_matrices, from_latlong};
pub use irradiance::{irradiance_sh, lambert_coefficient, sh_sphere};
pub use project::{project, project_turned};
