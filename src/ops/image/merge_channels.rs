//! `MergeChannels(channels: [..], names: [])`: one image from a list of images and scalar fields
//! of the same size, every channel of each input in list order.
//!
//! out(x, y) = (in_0(x, y, 0..c_0), in_1(x, y, 0..c_1), ...), bit for bit (no arithmetic), so
//! `MergeChannels(channels: ["split.R", "split.G", "split.B"])` rebuilds the image `split` read.
//!
//! **Names.** `names: []` keeps the inputs' channel names (a scalar field from `SplitChannels`
//! is named like its channel, one from `Luminance` is `Y`); they must then be unique, which is
//! checked when the node runs. Otherwise `names` gives one unique name per resulting channel,
//! e.g. `names: ["R", "G", "B"]` for three luminance fields. Put `R, G, B` first for an image
//! that `Save` should show in colour.
//!
//! **Output type** (known before anything runs): one channel in all is a scalar field, two or
//! more an image. A scalar field has one channel and an image at least two, so
//! - with `names` given, the count is `names.len()`; validation checks it against the inputs:
//!   at least one name per scalar field plus two per image, and exactly one per input when
//!   every input is a scalar field (an image's exact count is checked when the node runs);
//! - with `names: []`, the output is a scalar field exactly when a single scalar field is
//!   wired, and an image otherwise.
//!
//! All inputs must have the same width and height (checked when the node runs; the message
//! gives every input's size).

use std::collections::BTreeSet;

use rayon::prelude::*;

use crate::engine::fields::{Check, Input, Shape};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec, Persist};
use crate::engine::typed_op::Op;
use crate::engine::value::{Value, ValueType};
use crate::values::ty::*;
use crate::values::Image;

/// The most inputs a merge takes.
pub const MAX_INPUTS: usize = 64;

crate::params! {
    pub struct MergeChannelsParams {
        /// the inputs in order, e.g. ["split.B", "split.G", "split.R"]
        #[input(ANY_IMAGE)]
        #[range(1, MAX_INPUTS)]
        pub channels: Vec<Input<Image>>,
        /// names of the resulting channels, one per channel, unique ([] keeps the inputs' names)
        pub names: Vec<String> = Vec::new(),
    }
}

pub fn spec() -> OpSpec {
    Op::new("MergeChannels", 1, "One image from images and scalar fields of the same size, channels in order", eval)
        .output_computed(
            "image",
            "depends on inputs and parameters",
            output_type,
            "one channel in all: a scalar field; else an image",
        )
        .size(|_, p| p.channels.first().and_then(|s| s.size))
        .persist(Persist::IfSmall)
        .check(check)
        .into()
}

/// Channels of the inputs as validation knows them: (at least, exactly when every input is a
/// scalar field).
fn channel_bounds(inputs: &[Shape]) -> (usize, bool) {
    let min = inputs.iter().map(|s| if s.ty == SCALAR_T { 1 } else { 2 }).sum();
    (min, inputs.iter().all(|s| s.ty == SCALAR_T))
}

fn output_type(_: &CheckContext, p: MergeChannelsParams<Check>) -> Result<ValueType, String> {
    let inputs = &p.channels;
    let single = if p.names.is_empty() { inputs.len() == 1 && inputs[0].ty == SCALAR_T } else { p.names.len() == 1 };
    Ok(if single { SCALAR_T } else { IMAGE_T })
}

fn check(_: &CheckContext, p: MergeChannelsParams<Check>) -> Result<(), CheckProblem> {
    if p.names.is_empty() {
        return Ok(());
    }
    let mut seen = BTreeSet::new();
    for n in &p.names {
        if n.is_empty() {
            return Err(CheckProblem::at(MergeChannelsParams::names, "a channel name may not be empty"));
        }
        if !seen.insert(n.as_str()) {
            return Err(CheckProblem::at(MergeChannelsParams::names, format!("channel name {n:?} appears twice")));
        }
    }
    let inputs = &p.channels;
    let (min, exact) = channel_bounds(inputs);
    let describe = || {
        let scalars = inputs.iter().filter(|s| s.ty == SCALAR_T).count();
        format!("{scalars} scalar field(s) and {} image(s)", inputs.len() - scalars)
    };
    if exact && p.names.len() != min {
        return Err(CheckProblem::at(
            MergeChannelsParams::names,
            format!("{} names for {min} channels ({}): give one name per channel", p.names.len(), describe()),
        ));
    }
    if p.names.len() < min {
        return Err(CheckProblem::at(
            MergeChannelsParams::names,
            format!(
                "{} names, but the inputs have at least {min} channels ({}: an image has 2 or more)",
                p.names.len(),
                describe()
            ),
        ));
    }
    Ok(())
}

/// Interleaves the inputs' channels in order. `names`: empty keeps the inputs' names. Errors
/// name the sizes or names that do not fit.
pub fn merge(inputs: &[&Image], names: &[String]) -> Result<Image, OpError> {
    let first = inputs.first().ok_or_else(|| OpError::Invalid("nothing to merge".into()))?;
    let (w, h) = (first.width, first.height);
    if inputs.iter().any(|i| (i.width, i.height) != (w, h)) {
        let sizes: Vec<String> =
            inputs.iter().enumerate().map(|(k, i)| format!("channels[{k}] is {}x{}", i.width, i.height)).collect();
        return Err(OpError::Invalid(format!("inputs must have the same size: {}", sizes.join(", "))));
    }
    let from_inputs: Vec<String> = inputs.iter().flat_map(|i| i.names.iter().cloned()).collect();
    let names = if names.is_empty() {
        let mut seen = BTreeSet::new();
        let dups: BTreeSet<&str> =
            from_inputs.iter().filter(|n| !seen.insert(n.as_str())).map(String::as_str).collect();
        if !dups.is_empty() {
            return Err(OpError::Invalid(format!(
                "the inputs' channel names repeat ({}; all: {}): give `names`, one per channel",
                dups.into_iter().collect::<Vec<_>>().join(", "),
                from_inputs.join(", ")
            )));
        }
        from_inputs
    } else {
        if names.len() != from_inputs.len() {
            return Err(OpError::Invalid(format!(
                "{} names for {} channels (the inputs' channels: {})",
                names.len(),
                from_inputs.len(),
                from_inputs.join(", ")
            )));
        }
        names.to_vec()
    };
    let c = names.len();
    let mut data = vec![0f32; w * h * c];
    data.par_chunks_mut(w * c).enumerate().for_each(|(y, row)| {
        let mut offset = 0;
        for img in inputs {
            let k = img.channels;
            for (dst, src) in row.chunks_exact_mut(c).zip(img.row(y).chunks_exact(k)) {
                dst[offset..offset + k].copy_from_slice(src);
            }
            offset += k;
        }
    });
    Ok(Image::with_names(w, h, names, data))
}

fn eval(_: &mut OpContext, p: MergeChannelsParams) -> Result<Value, OpError> {
    let inputs: Vec<&Image> = p.channels.iter().map(|i| &**i).collect();
    Ok(Value::new(merge(&inputs, &p.names)?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ops::image::split_channels::split;

    fn names(n: &[&str]) -> Vec<String> {
        n.iter().map(|s| s.to_string()).collect()
    }

    fn rgba(w: usize, h: usize) -> Image {
        let data = (0..w * h * 4).map(|i| (i as f32 * 0.37).sin() * 1e4).collect();
        Image::with_names(w, h, names(&["R", "G", "B", "A"]), data)
    }

    #[test]
    fn merge_of_split_round_trips_bit_for_bit() {
        let img = rgba(5, 3);
        let parts = split(&img, &img.names).unwrap();
        let refs: Vec<&Image> = parts.iter().collect();
        assert_eq!(merge(&refs, &[]).unwrap(), img);
    }

    #[test]
    fn channels_interleave_in_list_order_and_take_new_names() {
        let img = rgba(2, 2);
        let parts = split(&img, &names(&["B", "G", "R"])).unwrap();
        let y = Image::with_names(2, 2, names(&["Y"]), vec![7.0, 8.0, 9.0, 10.0]);
        let refs = vec![&parts[0], &parts[1], &parts[2], &y];
        let out = merge(&refs, &names(&["R", "G", "B", "A"])).unwrap();
        assert_eq!(out.names, names(&["R", "G", "B", "A"]));
        for yy in 0..2 {
            for x in 0..2 {
                let (a, b) = (img.pixel(x, yy), out.pixel(x, yy));
                assert_eq!(b[..3], [a[2], a[1], a[0]]);
                assert_eq!(b[3], y.pixel(x, yy)[0]);
            }
        }
        // A whole image contributes all its channels.
        let out = merge(&[&img, &y], &[]).unwrap();
        assert_eq!(out.names, names(&["R", "G", "B", "A", "Y"]));
    }

    #[test]
    fn sizes_counts_and_duplicates_are_errors() {
        let (a, b) = (rgba(2, 2), rgba(3, 2));
        let e = merge(&[&a, &b], &[]).unwrap_err().to_string();
        assert_eq!(e, "inputs must have the same size: channels[0] is 2x2, channels[1] is 3x2");
        let e = merge(&[&a, &a], &[]).unwrap_err().to_string();
        assert!(e.contains("repeat (A, B, G, R;"), "{e}");
        let e = merge(&[&a], &names(&["X", "Y", "Z"])).unwrap_err().to_string();
        assert_eq!(e, "3 names for 4 channels (the inputs' channels: R, G, B, A)");
    }

    #[test]
    fn validation_knows_the_count_and_the_type() {
        use crate::engine::fields::CheckFields;
        use crate::engine::params::{ParamValue, Params};
        use std::collections::BTreeMap;
        let run = |types: Vec<ValueType>, n: &[&str]| {
            let mut params = Params::default();
            params.values.insert("names", ParamValue::TextList(names(n)));
            let mut input_types = BTreeMap::new();
            input_types.insert("channels", types);
            let ctx = CheckContext {
                params: &params,
                input_types: &input_types,
                input_sizes: &BTreeMap::new(),
                base_dir: std::path::Path::new("."),
                savers: &Default::default(),
            };
            let p = MergeChannelsParams::<Check>::from_check(&ctx).expect("the fields are valid");
            (check(&ctx, p.clone()).map_err(|p| p.message), output_type(&ctx, p))
        };
        assert_eq!(run(vec![SCALAR_T], &[]).1, Ok(SCALAR_T));
        assert_eq!(run(vec![IMAGE_T], &[]).1, Ok(IMAGE_T));
        assert_eq!(run(vec![SCALAR_T, SCALAR_T], &[]).1, Ok(IMAGE_T));
        assert_eq!(run(vec![IMAGE_T], &["L"]).1, Ok(SCALAR_T)); // fails validation, below
        assert!(run(vec![IMAGE_T], &["L"]).0.unwrap_err().contains("at least 2 channels"));
        assert!(run(vec![SCALAR_T; 3], &["R", "G"]).0.unwrap_err().contains("2 names for 3 channels"));
        assert!(run(vec![SCALAR_T; 2], &["R", "R"]).0.unwrap_err().contains("\"R\" appears twice"));
        assert!(run(vec![SCALAR_T, IMAGE_T], &["a", "b", "c", "d"]).0.is_ok());
    }
}
