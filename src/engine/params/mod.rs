//! Operator parameters: what a parameter field's Rust type means ([`Param`]), the validated
//! values ([`Params`]), the field specs that drive validation and `hdrflow ops`, choices
//! ([`choice!`](crate::choice)) and the [`params!`](crate::params) macro that declares an
//! operator's fields, its inputs included, as one typed struct (see `engine::fields`):
//!
//! ```ignore
//! hdrflow::params! {
//!     pub struct ExposureParams {
//!         /// the image to scale
//!         #[input(ANY_IMAGE)]
//!         pub image: Input<Image>,
//!         /// exposure change in stops (+1 doubles)
//!         #[range(-126.0, 126.0)]
//!         pub stops: f64,
//!         /// channel weights
//!         pub weights: Weights = Weights::Rec709,
//!     }
//! }
//! ```
//!
//! A field without `= default` is required, unless its type is an `Option`. Choices are Rust
//! enums declared with [`choice!`](crate::choice), so `eval` matches on variants instead of
//! comparing strings.
//!
//! Files: this one holds the field specs and the validated values; `types` the [`Param`] trait
//! and its implementation for each field type.

mod types;

pub use types::{InputPath, InputPattern, OutputPath, Param, Rgb, MAX_NUMBER_LIST};

use std::collections::BTreeMap;

pub use crate::choice::Choice;
use crate::engine::value::ValueType;

/// How many nodes an input field takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Arity {
    /// Exactly one node (`image: "env"`).
    One,
    /// None or one: an absent field means "not wired".
    Optional,
    /// A list of nodes in order (`channels: ["a.R", "b"]`), with an inclusive length range.
    List { min: usize, max: usize },
}

/// The type and accepted range of one field.
#[derive(Clone, Debug)]
pub enum FieldKind {
    /// The name of another node (or `node.port`), whose value must have one of these types
    /// (an empty list accepts any type).
    Input {
        types: Vec<ValueType>,
        arity: Arity,
    },
    /// A number (integer literals are accepted), inclusive range.
    Float {
        min: f64,
        max: f64,
    },
    /// An integer, inclusive range.
    Int {
        min: i64,
        max: i64,
    },
    Bool,
    /// Free text.
    Text,
    /// A list of strings, inclusive length range.
    TextList {
        min: usize,
        max: usize,
    },
    /// A file to read, or `builtin:NAME`. A loader's path is not part of its cache key: the
    /// file's content is.
    Path,
    /// Files to read named by a folder or a glob (`captures/kitchen/`, `shots/*.jpg`), relative
    /// to the pipeline file; like `Path`, left out of the cache key of an operator whose content
    /// key hashes the files it names.
    InputPattern,
    /// A file to write, relative to the output folder: it must stay inside it, and two nodes
    /// may not write the same path (both checked at validation).
    OutputPath,
    /// One of these bare identifiers, e.g. `Rec709`.
    Choice(&'static [&'static str]),
    /// A tuple of N numbers, each in the inclusive range, e.g. `(0.0, 1.0, 0.0)`.
    Tuple {
        len: usize,
        min: f64,
        max: f64,
    },
    /// An RGB colour `(r, g, b)`; a single number `v` means the grey `(v, v, v)`.
    Color {
        min: f64,
        max: f64,
    },
    /// A list of numbers `[a, b, ...]` (a tuple `(a, b)` is read the same way), of an inclusive
    /// length range, each number in the inclusive range `min..=max`. Its value is a
    /// [`ParamValue::Tuple`].
    NumberList {
        min_len: usize,
        max_len: usize,
        min: f64,
        max: f64,
    },
}

impl FieldKind {
    /// How the kind reads in `hdrflow ops` and in error messages.
    pub fn describe(&self) -> String {
        match self {
            FieldKind::Input { types, arity } => {
                let names: Vec<&str> = types.iter().map(|t| t.name()).collect();
                let one =
                    if names.is_empty() { "input<any>".to_string() } else { format!("input<{}>", names.join(" | ")) };
                match arity {
                    Arity::One => one,
                    Arity::Optional => format!("optional {one}"),
                    Arity::List { min, max } if *max == usize::MAX => format!("list of {min}+ {one}"),
                    Arity::List { min, max } => format!("list of {min}..{max} {one}"),
                }
            }
            FieldKind::Float { min, max } => with_range("float", fmt_range(*min, *max)),
            FieldKind::Int { min, max } => with_range("integer", int_range(*min, *max)),
            FieldKind::Bool => "bool".into(),
            FieldKind::Text => "string".into(),
            FieldKind::TextList { .. } => "list of strings".into(),
            FieldKind::Path => "path".into(),
            FieldKind::InputPattern => "folder or glob".into(),
            FieldKind::OutputPath => "output path".into(),
            FieldKind::Choice(options) => options.join(" | "),
            FieldKind::Tuple { len, .. } => format!("({})", vec!["float"; *len].join(", ")),
            FieldKind::Color { .. } => "(r, g, b) or grey".into(),
            FieldKind::NumberList { min, max, .. } => with_range("list of numbers", fmt_range(*min, *max)),
        }
    }

    /// The inclusive range of a number, or of each number of a tuple, colour or number list,
    /// as [`describe`](Self::describe) prints it (`[0, 1]`, `>= 0`); `None` for the
    /// kinds that are not numbers or have no bound.
    pub fn range(&self) -> Option<String> {
        match self {
            FieldKind::Float { min, max }
            | FieldKind::Tuple { min, max, .. }
            | FieldKind::Color { min, max }
            | FieldKind::NumberList { min, max, .. } => fmt_range(*min, *max),
            FieldKind::Int { min, max } => int_range(*min, *max),
            _ => None,
        }
    }

    /// The inclusive length range of a list (of nodes, strings or numbers), `(min, max)`, with
    /// `usize::MAX` for no upper bound; `None` for the kinds that are not lists.
    pub fn length(&self) -> Option<(usize, usize)> {
        match self {
            FieldKind::Input { arity: Arity::List { min, max }, .. } | FieldKind::TextList { min, max } => {
                Some((*min, *max))
            }
            FieldKind::NumberList { min_len, max_len, .. } => Some((*min_len, *max_len)),
            _ => None,
        }
    }

    pub fn is_input(&self) -> bool {
        matches!(self, FieldKind::Input { .. })
    }
}

/// A number's range as messages print it: `[min, max]`, or `<= max` / `>= min` when it is open
/// on one side (a bound of -f64::MAX or f64::MAX, what a field without `#[range]` gets, or an
/// infinite one), or `None` when it is open on both sides.
pub fn fmt_range(min: f64, max: f64) -> Option<String> {
    let open = |v: f64| v.is_infinite() || v.abs() == f64::MAX;
    match (open(min), open(max)) {
        (false, false) => Some(format!("[{}, {}]", fmt_bound(min), fmt_bound(max))),
        (true, false) => Some(format!("<= {}", fmt_bound(max))),
        (false, true) => Some(format!(">= {}", fmt_bound(min))),
        (true, true) => None,
    }
}

/// An integer's range as [`fmt_range`] prints a number's (`i64::MIN`/`i64::MAX` open it).
fn int_range(min: i64, max: i64) -> Option<String> {
    match (min == i64::MIN, max == i64::MAX) {
        (false, false) => Some(format!("[{min}, {max}]")),
        (true, false) => Some(format!("<= {max}")),
        (false, true) => Some(format!(">= {min}")),
        (true, true) => None,
    }
}

/// `kind in [min, max]`, `kind <= max`, `kind >= min` or `kind`, from [`fmt_range`]'s range.
pub fn with_range(kind: &str, range: Option<String>) -> String {
    match range {
        Some(r) if r.starts_with('[') => format!("{kind} in {r}"),
        Some(r) => format!("{kind} {r}"),
        None => kind.to_string(),
    }
}

fn fmt_bound(v: f64) -> String {
    if v == f64::INFINITY {
        "inf".into()
    } else if v == f64::NEG_INFINITY {
        "-inf".into()
    } else if v.abs() >= 1e7 || (v != 0.0 && v.abs() < 1e-4) {
        // Short scientific form for the extremes (f64::MAX, 1e-30), not 309 digits.
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// One field of an operator: an input (an edge) or a parameter.
#[derive(Clone, Debug)]
pub struct FieldSpec {
    pub name: &'static str,
    pub kind: FieldKind,
    /// `None`: the field must be given (inputs of arity `Optional`/`List{min: 0}` may be absent).
    pub default: Option<ParamValue>,
    /// A parameter that may be left out (an `Option<T>` field): absent, it is `None`.
    pub optional: bool,
    pub doc: String,
}

impl FieldSpec {
    /// A parameter field whose kind follows its Rust type.
    pub fn param<T: Param>(name: &'static str, doc: String, range: Option<(f64, f64)>, default: Option<T>) -> Self {
        FieldSpec {
            name,
            kind: T::kind(range),
            default: default.and_then(|d| d.to_value()),
            optional: T::OPTIONAL,
            doc,
        }
    }

    pub fn is_input(&self) -> bool {
        self.kind.is_input()
    }

    /// The default as `hdrflow ops` prints it.
    pub fn describe_default(&self) -> String {
        match (&self.default, &self.kind) {
            (Some(v), _) => format!("default {}", v.to_ron()),
            (None, FieldKind::Input { arity: Arity::Optional, .. }) => "optional".into(),
            (None, FieldKind::Input { arity: Arity::List { min: 0, .. }, .. }) => "default []".into(),
            (None, _) if self.optional => "optional".into(),
            (None, _) => "required".into(),
        }
    }
}

/// Joins a field's doc-comment lines (the `params!` macro passes them here).
pub fn doc_text(lines: &[&str]) -> String {
    lines.iter().map(|l| l.trim()).filter(|l| !l.is_empty()).collect::<Vec<_>>().join(" ")
}

/// A validated parameter value (inputs are not parameters: they are edges).
#[derive(Clone, Debug, PartialEq)]
pub enum ParamValue {
    Float(f64),
    Int(i64),
    Bool(bool),
    Text(String),
    TextList(Vec<String>),
    Choice(String),
    Tuple(Vec<f64>),
}

impl ParamValue {
    /// RON text of the value (for `ops`, messages and reports).
    pub fn to_ron(&self) -> String {
        match self {
            ParamValue::Float(v) => format!("{v:?}"),
            ParamValue::Int(v) => v.to_string(),
            ParamValue::Bool(v) => v.to_string(),
            ParamValue::Text(s) => format!("{s:?}"),
            ParamValue::TextList(v) => {
                format!("[{}]", v.iter().map(|s| format!("{s:?}")).collect::<Vec<_>>().join(", "))
            }
            ParamValue::Choice(s) => s.clone(),
            ParamValue::Tuple(v) => format!("({})", v.iter().map(|x| format!("{x:?}")).collect::<Vec<_>>().join(", ")),
        }
    }
}

/// A node's parameters after validation: every non-input field, given or defaulted.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Params {
    pub values: BTreeMap<&'static str, ParamValue>,
}

impl Params {
    /// A parameter converted to its declared Rust type. Validation has checked kind and range,
    /// so an error here is a bug in the operator's declaration (the message says which field).
    pub fn typed<T: Param>(&self, name: &str) -> Result<T, String> {
        match self.values.get(name) {
            None => T::absent().ok_or_else(|| format!("parameter {name:?} missing after validation")),
            Some(v) => T::from_value(v)
                .ok_or_else(|| format!("parameter {name:?} = {v:?} does not convert to its declared type")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::fields::Fields;

    crate::choice! {
        /// Test weights.
        enum Weights { Rec709, Max }
    }

    crate::params! {
        struct TestParams {
            /// stops of exposure
            /// (second line)
            #[range(-2.0, 2.0)]
            stops: f64,
            /// the weights
            weights: Weights = Weights::Max,
            #[range(1, 10)]
            count: usize = 3,
            tint: Rgb = Rgb([1.0, 0.5, 0.25]),
        }
    }

    #[test]
    fn declaration_drives_specs_and_conversion() {
        let fields = TestParams::fields();
        assert_eq!(fields.len(), 4);
        assert_eq!(fields[0].name, "stops");
        assert_eq!(fields[0].doc, "stops of exposure (second line)");
        assert!(fields[0].default.is_none() && !fields[0].optional);
        assert!(matches!(fields[0].kind, FieldKind::Float { min, max } if min == -2.0 && max == 2.0));
        assert!(matches!(fields[1].kind, FieldKind::Choice(names) if names == ["Rec709", "Max"]));
        assert_eq!(fields[1].default, Some(ParamValue::Choice("Max".into())));
        assert!(matches!(fields[2].kind, FieldKind::Int { min: 1, max: 10 }));
        let mut p = Params::default();
        p.values.insert("stops", ParamValue::Float(1.5));
        p.values.insert("weights", ParamValue::Choice("Rec709".into()));
        p.values.insert("count", ParamValue::Int(7));
        p.values.insert("tint", ParamValue::Tuple(vec![0.5, 0.5, 0.5]));
        let t = TestParams::from_run(&p, &mut Vec::new()).unwrap();
        assert_eq!(t, TestParams { stops: 1.5, weights: Weights::Rec709, count: 7, tint: Rgb([0.5; 3]) });
    }

    #[test]
    fn integer_ranges_never_exceed_the_rust_type() {
        assert!(matches!(<u32 as Param>::kind(None), FieldKind::Int { min: 0, max } if max == u32::MAX as i64));
        assert!(
            matches!(<u32 as Param>::kind(Some((-5.0, 1e30))), FieldKind::Int { min: 0, max } if max == u32::MAX as i64)
        );
    }

    #[test]
    fn ranges_open_on_a_side_read_as_a_bound_not_as_f64_max() {
        let float = |min, max| FieldKind::Float { min, max }.describe();
        assert_eq!(float(-2.0, 2.0), "float in [-2, 2]");
        assert_eq!(float(f64::MIN, 180.0), "float <= 180");
        assert_eq!(float(0.0, f64::MAX), "float >= 0");
        assert_eq!(float(0.0, f64::INFINITY), "float >= 0");
        assert_eq!(float(f64::MIN, f64::MAX), "float");
        assert_eq!(<f64 as Param>::kind(None).describe(), "float");
        assert_eq!(FieldKind::Int { min: 0, max: i64::MAX }.describe(), "integer >= 0");
        assert_eq!(FieldKind::Int { min: 1, max: 10 }.describe(), "integer in [1, 10]");
        let list = FieldKind::NumberList { min_len: 0, max_len: 4, min: 0.0, max: f64::MAX };
        assert_eq!(list.describe(), "list of numbers >= 0");
    }
}
