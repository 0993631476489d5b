//! Values that flow along the graph's edges, and their types.
//!
//! Every value is immutable and shared (`Arc`): a node's output is handed to all its consumers
//! without copying. The type of every value is known before anything runs (`ValueType`), so a
//! pipeline file that wires an image into a sample input fails validation, not evaluation.

use std::fmt;
use std::sync::Arc;

use crate::data::{Curves, Distribution2D, Image, Metrics, SampleSet};

/// The kinds of value an operator can take or produce.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ValueType {
    /// An RGB float image (linear radiance).
    Image,
    /// A one-channel float image (luminance, weights, masks).
    ScalarField,
    /// A 2D piecewise-constant sampling distribution over a lat-long map.
    Distribution,
    /// Directions with their solid-angle pdfs.
    Samples,
    /// Named series over a shared abscissa.
    Curves,
    /// A record of named numbers.
    Metrics,
    /// An encoded file, written into the output folder by the engine.
    File,
}

impl ValueType {
    pub const ALL: [ValueType; 7] = [
        ValueType::Image,
        ValueType::ScalarField,
        ValueType::Distribution,
        ValueType::Samples,
        ValueType::Curves,
        ValueType::Metrics,
        ValueType::File,
    ];

    pub fn name(self) -> &'static str {
        match self {
            ValueType::Image => "image",
            ValueType::ScalarField => "scalar field",
            ValueType::Distribution => "distribution",
            ValueType::Samples => "sample set",
            ValueType::Curves => "curves",
            ValueType::Metrics => "metrics",
            ValueType::File => "file",
        }
    }
}

impl fmt::Display for ValueType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An encoded output file: its path relative to the output folder, and its bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct FileBlob {
    pub rel_path: String,
    pub bytes: Vec<u8>,
}

/// A value on an edge of the graph.
#[derive(Clone, Debug)]
pub enum Value {
    /// RGB (`channels == 3`) or, as `ScalarField`, one channel.
    Image(Arc<Image>),
    Distribution(Arc<Distribution2D>),
    Samples(Arc<SampleSet>),
    Curves(Arc<Curves>),
    Metrics(Arc<Metrics>),
    File(Arc<FileBlob>),
}

impl Value {
    /// An image value; its type follows its channel count (1: scalar field, 3: image).
    pub fn image(image: Image) -> Value {
        Value::Image(Arc::new(image))
    }

    pub fn value_type(&self) -> ValueType {
        match self {
            Value::Image(img) if img.channels == 1 => ValueType::ScalarField,
            Value::Image(_) => ValueType::Image,
            Value::Distribution(_) => ValueType::Distribution,
            Value::Samples(_) => ValueType::Samples,
            Value::Curves(_) => ValueType::Curves,
            Value::Metrics(_) => ValueType::Metrics,
            Value::File(_) => ValueType::File,
        }
    }

    /// The image inside, for `Image` and `ScalarField` values.
    pub fn as_image(&self) -> Option<&Arc<Image>> {
        match self {
            Value::Image(i) => Some(i),
            _ => None,
        }
    }
    pub fn as_distribution(&self) -> Option<&Arc<Distribution2D>> {
        match self {
            Value::Distribution(d) => Some(d),
            _ => None,
        }
    }
    pub fn as_samples(&self) -> Option<&Arc<SampleSet>> {
        match self {
            Value::Samples(s) => Some(s),
            _ => None,
        }
    }
    pub fn as_curves(&self) -> Option<&Arc<Curves>> {
        match self {
            Value::Curves(c) => Some(c),
            _ => None,
        }
    }
    pub fn as_metrics(&self) -> Option<&Arc<Metrics>> {
        match self {
            Value::Metrics(m) => Some(m),
            _ => None,
        }
    }
    pub fn as_file(&self) -> Option<&Arc<FileBlob>> {
        match self {
            Value::File(f) => Some(f),
            _ => None,
        }
    }

    /// Approximate heap size in bytes (for reports and cache accounting).
    pub fn approx_bytes(&self) -> usize {
        match self {
            Value::Image(i) => i.data.len() * 4,
            Value::Distribution(d) => d.approx_bytes(),
            Value::Samples(s) => s.samples.len() * std::mem::size_of::<crate::data::Sample>(),
            Value::Curves(c) => (c.x.len() * (1 + c.series.len())) * 8,
            Value::Metrics(m) => m.fields.len() * 32,
            Value::File(f) => f.bytes.len(),
        }
    }
}
