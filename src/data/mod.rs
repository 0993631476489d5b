//! The data types that flow between operators.

pub mod camera;
pub mod cubemap;
pub mod curves;
pub mod distribution;
pub mod image;
pub mod label;
pub mod light;
pub mod lights;
pub mod metrics;
pub mod samples;
pub mod sg;
pub mod sh;

pub use camera::Camera;
pub use cubemap::{Cubemap, MipChain};
pub use curves::Curves;
pub use distribution::Distribution2D;
pub use image::Image;
pub use label::Label;
pub use light::Light;
pub use lights::Lights;
pub use metrics::Metrics;
pub use samples::{Sample, SampleSet};
pub use sg::{SgLobe, SphericalGaussians};
pub use sh::{ShCoefficients, ShFrame};
