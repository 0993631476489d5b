//! `SplitChannels(image)`: each channel of an image as its own scalar field, on a port named like
//! the channel: `"split.R"`, `"split.A"`, `"split.Z"`.
//!
//! out_c(x, y) = image(x, y, c) for the channel c named like the port, bit for bit (no arithmetic).
//!
//! The operator has no default port (it declares no `output`), so a consumer must name a
//! channel. Channel names are known only once the image exists, so the ports are open ports
//! (`OpSpec::open_ports`): validation accepts any port name, and at run time a port the image
//! lacks is an error naming the image's channels. Only the ports that consumers use are produced
//! (`OpContext::wanted_ports`); a channel nobody reads is never copied.
//!
//! A channel whose name contains a dot (an EXR layer such as `diffuse.R`) cannot be named in a
//! pipeline, because `"node.port"` splits at the last dot.

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Outputs, Persist};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::values::ty::*;
use crate::values::Image;

crate::params! {
    pub struct SplitChannelsParams {
        /// the image to split
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
    }
}

pub fn spec() -> OpSpec {
    Op::new("SplitChannels", 1, "Each channel of an image as a scalar field, on a port named like it", eval)
        .open_ports(SCALAR_T, "one port per channel, named like it: \"split.R\", \"split.A\" (no default port)")
        .size(|_, p| p.image.size)
        .persist(Persist::IfSmall)
        .into()
}

/// The channels named `wanted`, in that order, each as a one-channel image named like it; an
/// error naming the image's channels if one is missing.
pub fn split(img: &Image, wanted: &[String]) -> Result<Vec<Image>, OpError> {
    wanted
        .iter()
        .map(|name| {
            img.channel_index(name).map(|i| img.channel(i)).ok_or_else(|| {
                OpError::Invalid(format!("the image has no channel {name:?} (its channels: {})", img.names.join(", ")))
            })
        })
        .collect()
}

fn eval(ctx: &mut OpContext, p: SplitChannelsParams) -> Result<Outputs, OpError> {
    let img = &*p.image;
    // A port a consumer names must exist; then every channel is produced, so that the cache
    // entry serves later pipelines that name other channels of the same image.
    if let Some(missing) = ctx.wanted_ports.iter().find(|w| img.channel_index(w).is_none()) {
        return Err(split(img, std::slice::from_ref(missing)).expect_err("a missing channel is an error"));
    }
    let names = img.names.clone();
    let channels = split(img, &names)?;
    Ok(names.iter().zip(channels).fold(Outputs::new(), |out, (name, ch)| out.with(name, Value::new(ch))))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rgba() -> Image {
        let names = ["R", "G", "B", "A"].map(String::from).to_vec();
        Image::with_names(2, 1, names, vec![1.0, 2.0, 3.0, 0.5, -4.0, f32::NAN, f32::INFINITY, 1.0])
    }

    #[test]
    fn each_port_is_its_channel_bit_for_bit() {
        let img = rgba();
        let wanted: Vec<String> = ["A", "G", "R"].map(String::from).to_vec();
        let parts = split(&img, &wanted).unwrap();
        assert_eq!(parts[0].names, vec!["A"]);
        assert_eq!(parts[0].data, vec![0.5, 1.0]);
        assert_eq!(parts[1].data[0], 2.0);
        assert!(parts[1].data[1].is_nan());
        assert_eq!(parts[2].data, vec![1.0, -4.0]);
        assert!(parts.iter().all(|p| p.channels == 1 && p.width == 2 && p.height == 1));
    }

    #[test]
    fn a_missing_channel_names_the_images_channels() {
        let err = split(&rgba(), &["Z".to_string()]).unwrap_err().to_string();
        assert_eq!(err, "the image has no channel \"Z\" (its channels: R, G, B, A)");
    }
}
