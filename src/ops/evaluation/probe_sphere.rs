//! `ProbeSphere(env, material: Mirror, width: 960, height: 540, samples: 64, cut: 0.125,
//! shape: Subdivided, smith: Separable, interpolate: true)`: the lighting-estimation protocol's sphere under `env`, as
//! its Blender scene renders it (DiffusionLight-evaluation's `stylelight/mirror.py`,
//! `matte_silver.py`, `diffuse.py`), computed deterministically from the map
//! (`maths::render::probe_sphere`; the scene and its sources: the book's "The sphere evaluation
//! protocol").
//!
//! - The camera of the scripts (at (0, -16, 2), 85 mm lens, 36 mm sensor fitted horizontally,
//!   f/0.5 depth of field focused on the sphere) renders `width` x `height`; the protocol's frame is
//!   1920 x 1080 at its resolution percentage (960 x 540 at the 50% the published renders use).
//! - The materials are Principled BSDF v1 as Cycles 3.4 evaluates it: `Mirror` a perfect mirror
//!   with Principled's metallic Fresnel, `MatteSilver` GGX of roughness 0.3271, `Diffuse` Disney
//!   diffuse with a GGX dielectric coat of roughness 0.364; base colour 0.8.
//! - `env` is read where Blender's Environment Texture reads the same file (its centre column
//!   faces Blender's +X; no rotation is needed for a map in hdrflow's convention).
//! - `samples`: camera rays per pixel over the pixel filter and the lens (4 times as many on the
//!   silhouette), a fixed pattern, as Cycles' samples per pixel. The mirror reads the map along
//!   every ray; the rough materials shade once per pixel, at the rays' mean hit. `cut`: the
//!   refinement of the rough lobes' deterministic sum over the map's texels (blocks far from the
//!   lobe's peak count as one). Their errors, measured (tests and the book page): the default cut
//!   runs low by up to 0.7% (MatteSilver) and 0.1% (Diffuse) against the lobe's exact albedo; the
//!   mirror at 10% of the frame needs about 1024 rays to match a 256-sample Cycles render within
//!   its noise, at 50% fewer. `interpolate` (rough materials) shades every fourth pixel in each
//!   direction where the lobes turn slowly across pixels (the middle of the sphere at 960 x 540),
//!   every second where they turn faster, and interpolates the others: 2.5x faster than shading
//!   every pixel, its error against a four times finer cut within 10% of shading every pixel
//!   (tested).
//! - Port `image`: RGBA, the radiance premultiplied by the coverage (transparent film, as the
//!   protocol's EXR files); port `mask`: the coverage (1 on the sphere, 0 off it, fractional on the
//!   silhouette), the alpha `ImageMetrics` reads.
//! - `shape: Ideal` renders the unit sphere instead of Blender's subdivided mesh; `smith:
//!   Correlated` takes Blender 3.5+'s Smith term (the published renders used 3.6.5).
//!
//! The frame's plan (its camera rays, their hits and the mirror's reads: the same for every map)
//! is kept in the run's cache, so that a later process reads it instead of tracing it again.
//!
//! A map that is not 2:1 is read as lat-long with a warning; NaN or infinite texels are an error.

use crate::engine::context::AuxStore;
use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Outputs};
use crate::engine::typed_op::{Op, Port};
use crate::maths::render::probe_sphere::plan_bytes::PlanStore;
use crate::maths::render::probe_sphere::principled::Smith;
use crate::maths::render::probe_sphere::{render_with, ProbeMaterial, ProbeSettings, ProbeShape};
use crate::ops::latlong_input::{check_finite, warn_unless_latlong};
use crate::values::ty::*;
use crate::values::Image;

crate::params! {
    pub struct ProbeSphereParams {
        /// the environment (lat-long, linear RGB)
        #[input(ANY_IMAGE)]
        pub env: Input<Image>,
        /// Mirror (mirror.py), MatteSilver (matte_silver.py) or Diffuse (diffuse.py)
        pub material: ProbeMaterial = ProbeMaterial::Mirror,
        /// render width (the protocol: 1920 x its resolution percentage)
        #[range(1, 16384)]
        pub width: usize = 960,
        /// render height (the protocol: 1080 x its resolution percentage)
        #[range(1, 16384)]
        pub height: usize = 540,
        /// camera rays per pixel (pixel filter and lens); 4 times as many on the silhouette
        #[range(1, 4096)]
        pub samples: usize = 64,
        /// MatteSilver and Diffuse: a block of texels counts as one when its radius is at most cut
        /// times its angle from the lobe's peak plus the lobe's width (smaller: finer, slower)
        #[range(0.01, 1.0)]
        pub cut: f64 = 0.125,
        /// Subdivided (the mesh Blender renders) or Ideal (the unit sphere)
        pub shape: ProbeShape = ProbeShape::Subdivided,
        /// Separable (Cycles of Blender 3.4, Debian's) or Correlated (Blender 3.5+)
        pub smith: Smith = Smith::Separable,
        /// MatteSilver and Diffuse: shade every fourth or second pixel in each direction where the
        /// lobes turn slowly and interpolate the others (false: shade every pixel)
        pub interpolate: bool = true,
    }
}

const IMAGE: Port<Image> = Port::new("image");
const MASK: Port<Image> = Port::new("mask");

pub fn spec() -> OpSpec {
    Op::new(
        "ProbeSphere",
        4,
        "The sphere protocol's mirror, matte-silver or diffuse sphere under a map, as its Blender scene renders it",
        eval,
    )
    .port(IMAGE, IMAGE_T, "RGBA: the sphere's radiance premultiplied by its coverage, transparent elsewhere")
    .port(MASK, SCALAR_T, "the coverage: 1 on the sphere, 0 off it")
    .size(|_, p| Some((p.width as u64, p.height as u64)))
    .into()
}

fn eval(ctx: &mut OpContext, p: ProbeSphereParams) -> Result<Outputs, OpError> {
    warn_unless_latlong(ctx, &p.env);
    check_finite(&p.env)?;
    let settings = ProbeSettings {
        material: p.material,
        shape: p.shape,
        width: p.width,
        height: p.height,
        samples: p.samples,
        cut: p.cut,
        smith: p.smith,
        interpolate: p.interpolate,
    };
    let plans = ctx.aux.map(Plans);
    let out = render_with(&p.env, &settings, plans.as_ref().map(|s| s as &dyn PlanStore));
    Ok(Outputs::new().port(IMAGE, out.image).port(MASK, out.mask))
}

/// The frames' plans kept in the run's cache (`AuxStore`): a new process reads them instead of
/// tracing the frame again.
struct Plans<'a>(&'a dyn AuxStore);

impl PlanStore for Plans<'_> {
    fn load(&self, name: &str) -> Option<Vec<u8>> {
        self.0.load(name)
    }
    fn save(&self, name: &str, bytes: Vec<u8>) {
        self.0.save(name, bytes)
    }
}
