//! `Exposure(image, stops)`: multiply every value by 2^stops (the smallest operator: a template).

use rayon::prelude::*;

use crate::data::Image;
use crate::engine::op::{OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::Value;
use crate::types::ty::*;

crate::params! {
    pub struct ExposureParams {
        /// exposure change in stops (+1 doubles)
        #[range(-126.0, 126.0)]
        pub stops: f64,
    }
}

pub fn spec() -> OpSpec {
    OpSpec::new("Exposure", "image", 1, "Scale an image by 2^stops")
        .input("image", ANY_IMAGE, "the image to scale")
        .output("image", OutputType::SameAsInput("image"), "the scaled image")
        .code(crate::this_file!())
        .eval(eval)
}

fn eval(ctx: &mut OpContext, p: ExposureParams) -> Result<Value, OpError> {
    let scale = 2f64.powf(p.stops) as f32;
    // The input's buffer is reused when this node is its last consumer.
    let mut out: Image = ctx.take("image");
    out.data.par_iter_mut().for_each(|v| *v *= scale);
    Ok(Value::new(out))
}
