//! An operator's fields, parameters and inputs alike, declared once as one typed struct.
//!
//! `params!` turns `pub struct ExposureParams { pub image: Input<Image>, pub stops: f64 }`
//! into a struct generic over the [`Stage`] it is read in:
//!
//! - `ExposureParams` (the default, [`Run`]): what `eval` receives. `p.image` is an
//!   [`Input<Image>`] holding the wired value, already of the declared Rust type (it derefs to
//!   `Image`; `p.image.take()` moves the buffer out when this node is its last consumer).
//! - `ExposureParams<Check>`: what validation, computed output types, sizes and content keys
//!   receive, before anything runs. `p.image` is a [`Shape`]: the wired value's type and, when
//!   known, its pixel size.
//!
//! A field's Rust type says what it is: a parameter ([`Param`] types), `Input<T>` (one node),
//! `Option<Input<T>>` (none or one), `Vec<Input<T>>` (a list, `#[range(min, max)]` nodes), or
//! `Option<P>` for an optional parameter. `T` is the data type (`Image`, `Distribution2D`, ...)
//! or [`AnyValue`] for an input of any type; `#[input(TYPES)]` lists the value types accepted.
//! Nothing is named twice, and nothing here can panic: a value of another Rust type than
//! declared (a declaration bug) is an [`OpError`], reported with the node's name.

use std::fmt;
use std::marker::PhantomData;
use std::ops::Deref;
use std::sync::Arc;

pub use crate::engine::context::RunInputs;
use crate::engine::context::{CheckContext, OpError, Size};
use crate::engine::params::{Arity, FieldKind, FieldSpec, Param, Params};
use crate::engine::value::{Value, ValueData, ValueType};

/// The stage a field struct is read in; its associated types are what an input field holds.
pub trait Stage: 'static + Clone + fmt::Debug + PartialEq {
    type One<T: InputKind>: Clone + fmt::Debug + PartialEq;
    type Optional<T: InputKind>: Clone + fmt::Debug + PartialEq;
    type List<T: InputKind>: Clone + fmt::Debug + PartialEq;
}

/// Evaluation: each input holds its value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Run;

/// Validation, before anything runs: each input holds its [`Shape`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Check;

impl Stage for Run {
    type One<T: InputKind> = Input<T>;
    type Optional<T: InputKind> = Option<Input<T>>;
    type List<T: InputKind> = Vec<Input<T>>;
}

impl Stage for Check {
    type One<T: InputKind> = Shape;
    type Optional<T: InputKind> = Option<Shape>;
    type List<T: InputKind> = Vec<Shape>;
}

/// What an input is known to be before running: its value type and, where the producer can
/// tell (file headers, parameters), its default output's pixel size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shape {
    /// The field the input is wired to (problems about it name this field).
    pub field: &'static str,
    pub ty: ValueType,
    pub size: Size,
}

/// The Rust type an input's value is read as: a data type, or [`AnyValue`].
pub trait InputKind: 'static {
    /// Whether `value` holds this Rust type.
    fn holds(value: &Value) -> bool;
}

impl<T: ValueData> InputKind for T {
    fn holds(value: &Value) -> bool {
        value.get::<T>().is_some()
    }
}

/// An input of any value type (`Save`, `Display`): read it with [`Input::value`].
#[derive(Debug)]
pub struct AnyValue;

impl InputKind for AnyValue {
    fn holds(_: &Value) -> bool {
        true
    }
}

/// A wired input's value, of the declared Rust type `T` (checked when the struct was built).
pub struct Input<T: InputKind> {
    value: Value,
    field: &'static str,
    kind: PhantomData<fn() -> T>,
}

impl<T: InputKind> Input<T> {
    fn new(field: &'static str, value: Value) -> Result<Self, OpError> {
        if T::holds(&value) {
            Ok(Input { value, field, kind: PhantomData })
        } else {
            Err(OpError::Invalid(format!(
                "input {field:?} holds a {}, which is not the Rust type the operator declares (a bug in its declaration)",
                value.value_type()
            )))
        }
    }
    /// The field it is wired to (warnings and errors about it name this field).
    pub fn field(&self) -> &'static str {
        self.field
    }
    /// The value as it travels on the edge.
    pub fn value(&self) -> &Value {
        &self.value
    }
    /// The value, given up (to pass it on unchanged).
    pub fn into_value(self) -> Value {
        self.value
    }
    /// The value's type.
    pub fn value_type(&self) -> ValueType {
        self.value.value_type()
    }
}

impl<T: ValueData> Input<T> {
    fn data(&self) -> &T {
        // `new` checked that the value holds a `T`, and `value` is never replaced.
        self.value.get::<T>().expect("Input::new checked the Rust type")
    }
    /// The shared data, without copying it.
    pub fn arc(&self) -> Arc<T> {
        self.value.arc::<T>().expect("Input::new checked the Rust type")
    }
    /// The data by value: its buffer is moved out when this node is the value's last consumer
    /// (nothing else holds it), and copied otherwise.
    pub fn take(self) -> T
    where
        T: Clone,
    {
        self.value.take::<T>().expect("Input::new checked the Rust type")
    }
}

impl<T: ValueData> Deref for Input<T> {
    type Target = T;
    fn deref(&self) -> &T {
        self.data()
    }
}

impl<T: InputKind> Clone for Input<T> {
    fn clone(&self) -> Self {
        Input { value: self.value.clone(), field: self.field, kind: PhantomData }
    }
}

impl<T: InputKind> fmt::Debug for Input<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Input({:?})", self.value)
    }
}

impl<T: InputKind> PartialEq for Input<T> {
    /// The same allocation (values are immutable, so that is equality without a comparison).
    fn eq(&self, other: &Self) -> bool {
        self.value.ptr_eq(&other.value)
    }
}

fn take_values(inputs: &mut RunInputs, field: &'static str) -> Vec<Value> {
    inputs.iter_mut().find(|(f, _)| *f == field).map(|(_, v)| std::mem::take(v)).unwrap_or_default()
}

fn shapes(ctx: &CheckContext, field: &'static str) -> Vec<Shape> {
    let types = ctx.input_types.get(field).map(Vec::as_slice).unwrap_or_default();
    let sizes = ctx.input_sizes.get(field).map(Vec::as_slice).unwrap_or_default();
    types.iter().enumerate().map(|(k, &ty)| Shape { field, ty, size: sizes.get(k).copied().flatten() }).collect()
}

/// One field of a `params!` struct: its spec, and how it is read in each stage.
pub trait Field: Sized {
    /// What the field holds in stage `S`.
    type At<S: Stage>: Clone + fmt::Debug + PartialEq;
    /// The field's spec. `range` is `#[range(min, max)]`, `accepts` is `#[input(TYPES)]`.
    fn spec(
        name: &'static str,
        doc: String,
        range: Option<(f64, f64)>,
        default: Option<Self>,
        accepts: Option<&'static [ValueType]>,
    ) -> FieldSpec;
    /// The field for `eval`.
    fn run(name: &'static str, params: &Params, inputs: &mut RunInputs) -> Result<Self::At<Run>, OpError>;
    /// The field before running; `None` when a required input is not wired (validation has
    /// reported that already).
    fn check(name: &'static str, ctx: &CheckContext) -> Option<Self::At<Check>>;
}

impl<P: Param + Clone + fmt::Debug + PartialEq> Field for P {
    type At<S: Stage> = P;
    fn spec(
        name: &'static str,
        doc: String,
        range: Option<(f64, f64)>,
        default: Option<Self>,
        _: Option<&'static [ValueType]>,
    ) -> FieldSpec {
        FieldSpec::param::<P>(name, doc, range, default)
    }
    fn run(name: &'static str, params: &Params, _: &mut RunInputs) -> Result<P, OpError> {
        params.typed::<P>(name).map_err(OpError::Invalid)
    }
    fn check(name: &'static str, ctx: &CheckContext) -> Option<P> {
        ctx.params.typed::<P>(name).ok()
    }
}

fn input_spec(name: &'static str, doc: String, accepts: Option<&'static [ValueType]>, arity: Arity) -> FieldSpec {
    FieldSpec {
        name,
        kind: FieldKind::Input { types: accepts.unwrap_or_default().to_vec(), arity },
        default: None,
        optional: false,
        doc,
    }
}

impl<T: InputKind> Field for Input<T> {
    type At<S: Stage> = S::One<T>;
    fn spec(
        name: &'static str,
        doc: String,
        _: Option<(f64, f64)>,
        _: Option<Self>,
        accepts: Option<&'static [ValueType]>,
    ) -> FieldSpec {
        input_spec(name, doc, accepts, Arity::One)
    }
    fn run(name: &'static str, _: &Params, inputs: &mut RunInputs) -> Result<Input<T>, OpError> {
        let value = take_values(inputs, name)
            .into_iter()
            .next()
            .ok_or_else(|| OpError::Invalid(format!("input {name:?} is not wired (a bug in validation)")))?;
        Input::new(name, value)
    }
    fn check(name: &'static str, ctx: &CheckContext) -> Option<Shape> {
        shapes(ctx, name).first().copied()
    }
}

impl<T: InputKind> Field for Option<Input<T>> {
    type At<S: Stage> = S::Optional<T>;
    fn spec(
        name: &'static str,
        doc: String,
        _: Option<(f64, f64)>,
        _: Option<Self>,
        accepts: Option<&'static [ValueType]>,
    ) -> FieldSpec {
        input_spec(name, doc, accepts, Arity::Optional)
    }
    fn run(name: &'static str, _: &Params, inputs: &mut RunInputs) -> Result<Option<Input<T>>, OpError> {
        take_values(inputs, name).into_iter().next().map(|v| Input::new(name, v)).transpose()
    }
    fn check(name: &'static str, ctx: &CheckContext) -> Option<Option<Shape>> {
        Some(shapes(ctx, name).first().copied())
    }
}

impl<T: InputKind> Field for Vec<Input<T>> {
    type At<S: Stage> = S::List<T>;
    /// `range` bounds the list's length (default: any).
    fn spec(
        name: &'static str,
        doc: String,
        range: Option<(f64, f64)>,
        _: Option<Self>,
        accepts: Option<&'static [ValueType]>,
    ) -> FieldSpec {
        let (min, max) = range
            .map(|(a, b)| (a as usize, if b.is_finite() { b as usize } else { usize::MAX }))
            .unwrap_or((0, usize::MAX));
        input_spec(name, doc, accepts, Arity::List { min, max })
    }
    fn run(name: &'static str, _: &Params, inputs: &mut RunInputs) -> Result<Vec<Input<T>>, OpError> {
        take_values(inputs, name).into_iter().map(|v| Input::new(name, v)).collect()
    }
    fn check(name: &'static str, ctx: &CheckContext) -> Option<Vec<Shape>> {
        Some(shapes(ctx, name))
    }
}

/// A `params!` struct in the evaluation stage (`eval` receives it).
pub trait Fields: Sized {
    /// The same struct in the validation stage.
    type Check: CheckFields + 'static;
    /// The file the struct is declared in (`file!()`): the operator's source, for its code hash.
    const SOURCE: &'static str;
    /// The module it is declared in (`module_path!()`): its folder is the operator's category.
    const MODULE: &'static str;
    /// The fields' specs, in declaration order.
    fn fields() -> Vec<FieldSpec>;
    /// The struct from a node's validated parameters and its wired inputs (moved in).
    fn from_run(params: &Params, inputs: &mut RunInputs) -> Result<Self, OpError>;
}

/// A `params!` struct in the validation stage (`check`, `size`, computed outputs, content keys).
pub trait CheckFields: Sized {
    /// `None` when a required input is not wired (already reported).
    fn from_check(ctx: &CheckContext) -> Option<Self>;
}

/// `Some(x)` for one argument, `None` for none (used by `params!`).
#[doc(hidden)]
#[macro_export]
macro_rules! __opt {
    () => {
        None
    };
    ($e:expr) => {
        Some($e)
    };
}

/// Declares an operator's fields, its parameters and its inputs, as one typed struct; see
/// `hdrflow::engine::fields`. Each field takes doc comments, then optionally `#[input(TYPES)]`
/// (the value types an input accepts; left out: any) and `#[range(min, max)]` (a number's
/// range, or a list input's length), then `name: Type` and optionally `= default`.
#[macro_export]
macro_rules! params {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident {}
    ) => {
        $(#[$meta])*
        #[derive(Clone, Debug, PartialEq)]
        $vis struct $name<S: $crate::engine::fields::Stage = $crate::engine::fields::Run>(
            ::std::marker::PhantomData<S>,
        );

        impl $crate::engine::fields::Fields for $name {
            type Check = $name<$crate::engine::fields::Check>;
            const SOURCE: &'static str = file!();
            const MODULE: &'static str = module_path!();
            fn fields() -> Vec<$crate::engine::params::FieldSpec> {
                Vec::new()
            }
            fn from_run(
                _: &$crate::engine::params::Params,
                _: &mut $crate::engine::fields::RunInputs,
            ) -> Result<Self, $crate::engine::context::OpError> {
                Ok($name(::std::marker::PhantomData))
            }
        }

        impl $crate::engine::fields::CheckFields for $name<$crate::engine::fields::Check> {
            fn from_check(_: &$crate::engine::context::CheckContext) -> Option<Self> {
                Some($name(::std::marker::PhantomData))
            }
        }
    };
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident {
            $(
                $(#[doc = $doc:literal])*
                $(#[input($accepts:expr)])?
                $(#[range($min:expr, $max:expr)])?
                $fvis:vis $field:ident : $ty:ty $(= $default:expr)?
            ),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Debug, PartialEq)]
        $vis struct $name<S: $crate::engine::fields::Stage = $crate::engine::fields::Run> {
            $( $(#[doc = $doc])* $fvis $field: <$ty as $crate::engine::fields::Field>::At<S>, )+
        }

        /// Each field's name, as a constant of the same name: problems and warnings name a
        /// field as `Params::field`, checked by the compiler.
        #[allow(non_upper_case_globals, dead_code)]
        impl $name {
            $( pub const $field: &'static str = stringify!($field); )+
        }

        impl $crate::engine::fields::Fields for $name {
            type Check = $name<$crate::engine::fields::Check>;
            const SOURCE: &'static str = file!();
            const MODULE: &'static str = module_path!();
            fn fields() -> Vec<$crate::engine::params::FieldSpec> {
                vec![$(
                    <$ty as $crate::engine::fields::Field>::spec(
                        stringify!($field),
                        $crate::engine::params::doc_text(&[$($doc),*]),
                        $crate::__opt!($(($min as f64, $max as f64))?),
                        $crate::__opt!($({ let d: $ty = $default; d })?),
                        $crate::__opt!($($accepts)?),
                    )
                ),+]
            }
            fn from_run(
                params: &$crate::engine::params::Params,
                inputs: &mut $crate::engine::fields::RunInputs,
            ) -> Result<Self, $crate::engine::context::OpError> {
                Ok($name { $( $field: <$ty as $crate::engine::fields::Field>::run(stringify!($field), params, inputs)?, )+ })
            }
        }

        impl $crate::engine::fields::CheckFields for $name<$crate::engine::fields::Check> {
            fn from_check(ctx: &$crate::engine::context::CheckContext) -> Option<Self> {
                Some($name { $( $field: <$ty as $crate::engine::fields::Field>::check(stringify!($field), ctx)?, )+ })
            }
        }
    };
}
