//! `ShSphere(env, size: 256, albedo, view, order: 2)`: the diffuse sphere lit by the map's
//! spherical-harmonic irradiance approximation (Ramamoorthi and Hanrahan, "An Efficient
//! Representation for Irradiance Environment Maps", SIGGRAPH 2001):
//! `Lo(n) = (albedo / pi) sum_{l <= order} A_l sum_m L_lm Y_lm(n)` (`maths::sh`). Same `size`,
//! `albedo` and `view` fields and defaults as `RelightSphere`, so it compares pixel for pixel
//! with `ReferenceSphere`. Accurate (~1%) for smooth lighting at order 2; a small sun gives large
//! errors and rings, even negative values, which are kept (not clamped) so they can be measured.

use super::{ALBEDO_FIELD, SIZE_FIELD, VIEW_FIELD};
use crate::engine::op::{Default, FieldKind, FieldSpec, OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::{Value, ValueType};
use crate::geometry::latlong;
use crate::maths::relight::SphereView;
use crate::maths::sh::sh_sphere;

use super::reference_sphere::check_finite;

pub static SPEC: OpSpec = OpSpec {
    name: "ShSphere",
    category: "shading",
    version: 1,
    doc: "Relight a diffuse sphere with the spherical-harmonic irradiance map (Ramamoorthi-Hanrahan)",
    fields: &[
        FieldSpec::input("env", &[ValueType::Image], "the lat-long environment (linear RGB)"),
        SIZE_FIELD,
        ALBEDO_FIELD,
        VIEW_FIELD,
        FieldSpec {
            name: "order",
            kind: FieldKind::Int { min: 0, max: 32 },
            default: Default::Int(2),
            doc: "highest SH band l (2: 9 coefficients)",
        },
    ],
    output: OutputType::Fixed(ValueType::Image),
    eval,
    content_key: None,
    check: None,
};

fn eval(ctx: &OpContext) -> Result<Value, OpError> {
    let env = ctx.image("env");
    check_finite(env)?;
    let size = ctx.params.usize("size");
    let albedo = ctx.params.vec3("albedo");
    let [vt, vp] = ctx.params.vec2("view");
    let order = ctx.params.usize("order");
    let view = SphereView::new(size, latlong::direction_deg(vt, vp));
    Ok(Value::image(sh_sphere(env, &view, albedo, order)))
}
