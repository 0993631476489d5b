//! Choices: Rust enums whose variants pipeline files name by bare identifiers (`Rec709`,
//! `Sobol`), declared one way, with [`choice!`](crate::choice), at whatever layer the enum
//! belongs to (`maths`, `data`, `formats`, an operator). Below every other layer, like
//! [`crate::geometry`]: the engine makes any [`Choice`] a parameter type, and nothing here knows
//! the engine.

/// An enum of named variants.
pub trait Choice: Sized + Copy + 'static {
    /// The names, in declaration order, as written in pipeline files.
    const NAMES: &'static [&'static str];
    /// The variant called `name` (exact spelling: pipeline validation offers a "did you mean").
    fn from_name(name: &str) -> Option<Self>;
    fn name(self) -> &'static str;
}

/// Declares a choice enum: `choice! { pub enum Weights { Rec709, Rec2020, Mean, Max } }`.
///
/// Variants may carry doc comments. The enum derives `Clone, Copy, Debug, PartialEq, Eq, Hash`
/// and implements [`Choice`] and `Display` (its name); it also gets inherent `NAMES`, `ALL`
/// (every variant, in order), `name()` and `from_name()`, so code below the engine uses them
/// without importing the trait.
#[macro_export]
macro_rules! choice {
    ($(#[$meta:meta])* $vis:vis enum $name:ident { $($(#[$vmeta:meta])* $variant:ident),+ $(,)? }) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        $vis enum $name { $($(#[$vmeta])* $variant),+ }

        #[allow(dead_code)]
        impl $name {
            /// The names, in declaration order, as written in pipeline files.
            pub const NAMES: &'static [&'static str] = &[$(stringify!($variant)),+];
            /// Every variant, in declaration order.
            pub const ALL: [$name; 0 $(+ { stringify!($variant); 1 })+] = [$($name::$variant),+];

            /// The name as written in pipeline files.
            pub fn name(self) -> &'static str {
                match self {
                    $($name::$variant => stringify!($variant),)+
                }
            }

            /// The variant called `name` (exact spelling), or `None`.
            pub fn from_name(name: &str) -> Option<$name> {
                match name {
                    $(stringify!($variant) => Some($name::$variant),)+
                    _ => None,
                }
            }

            /// The variant called `name`, in any case and with spaces around it (environment
            /// variables, command-line flags), or `None`.
            pub fn from_name_ignore_case(name: &str) -> Option<$name> {
                $name::ALL.iter().copied().find(|v| v.name().eq_ignore_ascii_case(name.trim()))
            }
        }

        impl $crate::choice::Choice for $name {
            const NAMES: &'static [&'static str] = $name::NAMES;
            fn from_name(name: &str) -> Option<Self> {
                $name::from_name(name)
            }
            fn name(self) -> &'static str {
                $name::name(self)
            }
        }

        impl ::std::fmt::Display for $name {
            fn fmt(&self, f: &mut ::std::fmt::Formatter<'_>) -> ::std::fmt::Result {
                f.write_str($name::name(*self))
            }
        }
    };
}

#[cfg(test)]
mod tests {
    use super::Choice;

    crate::choice! {
        /// A test choice.
        enum Fruit {
            /// the first
            Apple,
            Pear,
        }
    }

    #[test]
    fn names_round_trip_in_order() {
        assert_eq!(<Fruit as Choice>::NAMES, &["Apple", "Pear"]);
        assert_eq!(Fruit::ALL, [Fruit::Apple, Fruit::Pear]);
        for f in Fruit::ALL {
            assert_eq!(Fruit::from_name(f.name()), Some(f));
            assert_eq!(f.to_string(), f.name());
        }
        assert_eq!(Fruit::from_name("apple"), None);
        assert_eq!(Fruit::from_name_ignore_case(" apple "), Some(Fruit::Apple));
    }
}
