//! The Rust types a parameter field may have: the [`Param`] trait (a type's field kind, and its
//! conversion from and to the validated [`ParamValue`]) and its implementations for numbers,
//! flags, strings, lists, paths, colours, options and choices.

use super::{FieldKind, ParamValue};
use crate::choice::Choice;

/// A Rust type usable as a parameter field: its kind (what validation accepts) and its
/// conversion from and to the validated value.
pub trait Param: Sized {
    /// Whether the field may be left out (`Option<T>`).
    const OPTIONAL: bool = false;
    /// The field kind; `range` is the `#[range(min, max)]` given in the declaration.
    fn kind(range: Option<(f64, f64)>) -> FieldKind;
    /// The validated value (`None`: absent, for an optional field left out).
    fn to_value(&self) -> Option<ParamValue>;
    fn from_value(v: &ParamValue) -> Option<Self>;
    /// The value of a field left out of the pipeline (`Some(None)` for `Option<T>`).
    fn absent() -> Option<Self> {
        None
    }
}

/// An optional parameter: absent in the pipeline, it is `None` (no sentinel value stands in).
impl<T: Param> Param for Option<T> {
    const OPTIONAL: bool = true;
    fn kind(range: Option<(f64, f64)>) -> FieldKind {
        T::kind(range)
    }
    fn to_value(&self) -> Option<ParamValue> {
        self.as_ref().and_then(T::to_value)
    }
    fn from_value(v: &ParamValue) -> Option<Self> {
        T::from_value(v).map(Some)
    }
    fn absent() -> Option<Self> {
        Some(None)
    }
}

impl Param for f64 {
    fn kind(range: Option<(f64, f64)>) -> FieldKind {
        let (min, max) = range.unwrap_or((f64::MIN, f64::MAX));
        FieldKind::Float { min, max }
    }
    fn to_value(&self) -> Option<ParamValue> {
        Some(ParamValue::Float(*self))
    }
    fn from_value(v: &ParamValue) -> Option<Self> {
        match v {
            ParamValue::Float(v) => Some(*v),
            ParamValue::Int(v) => Some(*v as f64),
            _ => None,
        }
    }
}

macro_rules! int_param {
    ($($t:ty),*) => {$(
        impl Param for $t {
            fn kind(range: Option<(f64, f64)>) -> FieldKind {
                let (min, max) = range.unwrap_or((<$t>::MIN as f64, <$t>::MAX as f64));
                // Clamp to what the Rust type holds, so a declared range can never overflow it.
                let min = (min.max(<$t>::MIN as f64)).max(i64::MIN as f64) as i64;
                let max = (max.min(<$t>::MAX as f64)).min(i64::MAX as f64) as i64;
                FieldKind::Int { min, max }
            }
            fn to_value(&self) -> Option<ParamValue> {
                Some(ParamValue::Int(*self as i64))
            }
            fn from_value(v: &ParamValue) -> Option<Self> {
                match v {
                    ParamValue::Int(v) => <$t>::try_from(*v).ok(),
                    _ => None,
                }
            }
        }
    )*};
}
int_param!(i64, u64, u32, usize);

impl Param for bool {
    fn kind(_: Option<(f64, f64)>) -> FieldKind {
        FieldKind::Bool
    }
    fn to_value(&self) -> Option<ParamValue> {
        Some(ParamValue::Bool(*self))
    }
    fn from_value(v: &ParamValue) -> Option<Self> {
        match v {
            ParamValue::Bool(b) => Some(*b),
            _ => None,
        }
    }
}

impl Param for String {
    fn kind(_: Option<(f64, f64)>) -> FieldKind {
        FieldKind::Text
    }
    fn to_value(&self) -> Option<ParamValue> {
        Some(ParamValue::Text(self.clone()))
    }
    fn from_value(v: &ParamValue) -> Option<Self> {
        match v {
            ParamValue::Text(s) => Some(s.clone()),
            _ => None,
        }
    }
}

impl Param for Vec<String> {
    fn kind(range: Option<(f64, f64)>) -> FieldKind {
        let (min, max) = range.map(|(a, b)| (a as usize, b as usize)).unwrap_or((0, 1 << 16));
        FieldKind::TextList { min, max }
    }
    fn to_value(&self) -> Option<ParamValue> {
        Some(ParamValue::TextList(self.clone()))
    }
    fn from_value(v: &ParamValue) -> Option<Self> {
        match v {
            ParamValue::TextList(s) => Some(s.clone()),
            _ => None,
        }
    }
}

impl<const N: usize> Param for [f64; N] {
    fn kind(range: Option<(f64, f64)>) -> FieldKind {
        let (min, max) = range.unwrap_or((f64::MIN, f64::MAX));
        FieldKind::Tuple { len: N, min, max }
    }
    fn to_value(&self) -> Option<ParamValue> {
        Some(ParamValue::Tuple(self.to_vec()))
    }
    fn from_value(v: &ParamValue) -> Option<Self> {
        match v {
            ParamValue::Tuple(t) => t.as_slice().try_into().ok(),
            _ => None,
        }
    }
}

/// A list of numbers, `percentiles: [1, 50, 99]`: `#[range(min, max)]` bounds each number; the
/// list holds at most [`MAX_NUMBER_LIST`] of them.
impl Param for Vec<f64> {
    fn kind(range: Option<(f64, f64)>) -> FieldKind {
        let (min, max) = range.unwrap_or((f64::MIN, f64::MAX));
        FieldKind::NumberList { min_len: 0, max_len: MAX_NUMBER_LIST, min, max }
    }
    fn to_value(&self) -> Option<ParamValue> {
        Some(ParamValue::Tuple(self.clone()))
    }
    fn from_value(v: &ParamValue) -> Option<Self> {
        match v {
            ParamValue::Tuple(t) => Some(t.clone()),
            _ => None,
        }
    }
}

/// The longest list a `Vec<f64>` parameter takes.
pub const MAX_NUMBER_LIST: usize = 1024;

/// A file to read (`path: "maps/grace.exr"` or `builtin:NAME`), relative to the pipeline file.
#[derive(Clone, Debug, PartialEq)]
pub struct InputPath(pub String);

impl Param for InputPath {
    fn kind(_: Option<(f64, f64)>) -> FieldKind {
        FieldKind::Path
    }
    fn to_value(&self) -> Option<ParamValue> {
        Some(ParamValue::Text(self.0.clone()))
    }
    fn from_value(v: &ParamValue) -> Option<Self> {
        match v {
            ParamValue::Text(s) => Some(InputPath(s.clone())),
            _ => None,
        }
    }
}

/// Files to read named by a folder or a glob (`captures/kitchen/`, `captures/kitchen/*.jpg`),
/// relative to the pipeline file (on the command line, to the working folder, as a path). The
/// operator that reads them hashes their contents into its content key; the text is not keyed.
#[derive(Clone, Debug, PartialEq)]
pub struct InputPattern(pub String);

impl Param for InputPattern {
    fn kind(_: Option<(f64, f64)>) -> FieldKind {
        FieldKind::InputPattern
    }
    fn to_value(&self) -> Option<ParamValue> {
        Some(ParamValue::Text(self.0.clone()))
    }
    fn from_value(v: &ParamValue) -> Option<Self> {
        match v {
            ParamValue::Text(s) => Some(InputPattern(s.clone())),
            _ => None,
        }
    }
}

/// A file to write, relative to the output folder (checked to stay inside it).
#[derive(Clone, Debug, PartialEq)]
pub struct OutputPath(pub String);

impl OutputPath {
    /// The lower-case extension, without the dot.
    pub fn extension(&self) -> String {
        std::path::Path::new(&self.0).extension().map(|e| e.to_string_lossy().to_lowercase()).unwrap_or_default()
    }
}

impl Param for OutputPath {
    fn kind(_: Option<(f64, f64)>) -> FieldKind {
        FieldKind::OutputPath
    }
    fn to_value(&self) -> Option<ParamValue> {
        Some(ParamValue::Text(self.0.clone()))
    }
    fn from_value(v: &ParamValue) -> Option<Self> {
        match v {
            ParamValue::Text(s) => Some(OutputPath(s.clone())),
            _ => None,
        }
    }
}

/// A linear RGB colour; a pipeline may give a single number for grey.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rgb(pub [f64; 3]);

impl Rgb {
    pub fn f32(self) -> [f32; 3] {
        self.0.map(|v| v as f32)
    }
}

impl Param for Rgb {
    fn kind(range: Option<(f64, f64)>) -> FieldKind {
        let (min, max) = range.unwrap_or((f64::MIN, f64::MAX));
        FieldKind::Color { min, max }
    }
    fn to_value(&self) -> Option<ParamValue> {
        Some(ParamValue::Tuple(self.0.to_vec()))
    }
    fn from_value(v: &ParamValue) -> Option<Self> {
        match v {
            ParamValue::Tuple(t) => Some(Rgb(t.as_slice().try_into().ok()?)),
            _ => None,
        }
    }
}

/// Any choice (declared with [`crate::choice!`]) is a parameter: a bare identifier among its
/// names.
impl<T: Choice> Param for T {
    fn kind(_: Option<(f64, f64)>) -> FieldKind {
        FieldKind::Choice(T::NAMES)
    }
    fn to_value(&self) -> Option<ParamValue> {
        Some(ParamValue::Choice(self.name().to_string()))
    }
    fn from_value(v: &ParamValue) -> Option<Self> {
        match v {
            ParamValue::Choice(s) => T::from_name(s),
            _ => None,
        }
    }
}
