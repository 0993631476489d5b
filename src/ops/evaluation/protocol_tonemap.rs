//! `ProtocolTonemap(image, gamma: 2.4, percentile: 50, max_mapping: 0.5)`: the tonemap the
//! lighting-estimation protocol applies to each predicted and ground-truth map before rendering its
//! spheres (`stylelight/tonemap.py`; the formula and its source in `maths::stats::protocol_tonemap`).
//! Not a display tonemap: the result is not clipped, and the spheres are rendered under it.
//!
//! Every channel but alpha (`A`) is mapped, with one scale for all of them, as the script maps an
//! RGB image; a sample the script would turn into NaN (negative or NaN) becomes 0, with a warning
//! that counts them.

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Persist};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::stats::protocol_tonemap::protocol_tonemap;
use crate::values::ty::*;
use crate::values::Image;

crate::params! {
    pub struct ProtocolTonemapParams {
        /// the map (linear radiance)
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// the power 1/gamma applied first (tonemap.py: 2.4)
        #[range(0.1, 10.0)]
        pub gamma: f64 = 2.4,
        /// the percentile of the powered samples above 0 that maps to max_mapping (tonemap.py: 50)
        #[range(0.0, 100.0)]
        pub percentile: f64 = 50.0,
        /// the value that percentile maps to (tonemap.py: 0.5)
        #[range(1e-6, 1e6)]
        pub max_mapping: f64 = 0.5,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "ProtocolTonemap",
        1,
        "The sphere protocol's tonemap (tonemap.py): alpha x^(1/gamma), the median of the powered samples mapped to 0.5",
        eval,
    )
    .output_like("image", |p| p.image, "the tonemapped map, not clipped; alpha unchanged")
    .size(|_, p| p.image.size)
    .persist(Persist::IfSmall)
    .into()
}

fn eval(ctx: &mut OpContext, p: ProtocolTonemapParams) -> Result<Value, OpError> {
    let mut img = p.image.take();
    let alpha_channel = img.channel_index("A").filter(|_| img.channels > 1);
    let mapped: Vec<usize> = (0..img.channels).filter(|&c| Some(c) != alpha_channel).collect();
    let mut samples: Vec<f32> =
        img.data.chunks_exact(img.channels).flat_map(|px| mapped.iter().map(|&c| px[c])).collect();
    let t = protocol_tonemap(&mut samples, p.gamma, p.percentile, p.max_mapping);
    for (px, s) in img.data.chunks_exact_mut(img.channels).zip(samples.chunks_exact(mapped.len())) {
        for (&c, &v) in mapped.iter().zip(s) {
            px[c] = v;
        }
    }
    if t.bad_samples > 0 {
        ctx.warn(format!("{} samples were negative or NaN (the script's np.power gives NaN): set to 0", t.bad_samples));
    }
    Ok(Value::new(img))
}
