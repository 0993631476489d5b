//! How `Save` writes values as files, as far as the engine knows it: the options a `Save` node
//! passes ([`SaveOptions`]), one type's encoder ([`Saver`]: the extensions it writes and its
//! function) and the encoders a registry holds, by value type ([`Savers`]).
//!
//! A saver is registered apart from its value type (`Registry::register_saver`), by whoever knows
//! the file formats: the built-in ones in `crate::formats::save`. So a value type declares only
//! its data and its cache codec, and the engine still knows no file format. Operators see the
//! registry's savers in their contexts (`CheckContext::savers`, `OpContext::savers`): `Save`
//! checks a path's extension against them before anything runs, and encodes with them.

use std::any::Any;
use std::collections::BTreeMap;
use std::fmt;
use std::sync::Arc;

use crate::engine::value::{TypeSpec, Value, ValueType};

/// Options a `Save` node passes to a type's file encoder: the extension and the settings any
/// encoder may read, plus format-specific settings the engine does not know. Those are a small
/// map with one value per Rust type, set by whoever builds the options (`Save`, with the
/// structs that `crate::formats` declares) and read by the encoder that knows the type, so a new
/// format's options touch no engine file.
#[derive(Clone, Debug)]
pub struct SaveOptions {
    /// Lower-case extension of the output path, without the dot.
    pub ext: String,
    /// Exposure in stops (PNG only).
    pub exposure: f64,
    /// Plot width and height in pixels (curve plots).
    pub plot_size: (u32, u32),
    /// Format-specific settings, at most one per type (see [`SaveOptions::with`]).
    specific: Vec<SpecificOption>,
}

/// One format-specific setting: its value and, for `Debug`, its type's name.
#[derive(Clone)]
struct SpecificOption {
    type_name: &'static str,
    value: Arc<dyn Any + Send + Sync>,
}

impl fmt::Debug for SpecificOption {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.type_name)
    }
}

impl SaveOptions {
    /// Options for a file of extension `ext` with `Save`'s defaults: exposure 0, an 800 x 500
    /// plot, no format-specific settings (each encoder then uses its format's defaults).
    pub fn new(ext: impl Into<String>) -> SaveOptions {
        SaveOptions { ext: ext.into(), exposure: 0.0, plot_size: (800, 500), specific: Vec::new() }
    }

    /// The options with the format-specific setting `value`, replacing any earlier one of its type.
    pub fn with<T: Any + Send + Sync>(mut self, value: T) -> SaveOptions {
        self.specific.retain(|o| !o.value.is::<T>());
        self.specific.push(SpecificOption { type_name: std::any::type_name::<T>(), value: Arc::new(value) });
        self
    }

    /// The format-specific setting of type `T`, if one was given.
    pub fn get<T: Any>(&self) -> Option<&T> {
        self.specific.iter().find_map(|o| o.value.downcast_ref::<T>())
    }

    /// The setting of type `T`, or its default when none was given.
    pub fn get_or_default<T: Any + Clone + Default>(&self) -> T {
        self.get::<T>().cloned().unwrap_or_default()
    }
}

/// Encodes a value as a file's bytes (the extension is in the options).
pub type SaveFn = fn(&Value, &SaveOptions) -> Result<Vec<u8>, String>;

/// How `Save` writes one value type: the extensions it accepts and the encoder.
#[derive(Clone, Copy, Debug)]
pub struct Saver {
    /// Extensions `Save` accepts for the type, lower-case, without the dot.
    pub extensions: &'static [&'static str],
    /// Encodes a value of the type as the file `SaveOptions::ext` names.
    pub save: SaveFn,
}

/// The savers of a registry, by value type name. A type without one cannot be saved.
#[derive(Clone, Debug, Default)]
pub struct Savers(BTreeMap<&'static str, Saver>);

impl Savers {
    /// Sets how `Save` writes values of type `spec`, replacing an earlier saver of that type.
    pub fn insert(&mut self, spec: &'static TypeSpec, saver: Saver) {
        self.0.insert(spec.name, saver);
    }

    /// How `Save` writes values of type `ty`, if it can.
    pub fn get(&self, ty: ValueType) -> Option<&Saver> {
        self.0.get(ty.name())
    }
}

#[cfg(test)]
mod tests {
    use super::SaveOptions;

    #[derive(Clone, Debug, Default, PartialEq)]
    struct Level(u8);

    #[derive(Clone, Debug, Default, PartialEq)]
    struct Other(&'static str);

    #[test]
    fn save_options_hold_one_setting_per_type_and_default_the_rest() {
        let o = SaveOptions::new("exr").with(Level(3)).with(Other("a")).with(Level(7));
        assert_eq!(o.get::<Level>(), Some(&Level(7)), "a later setting of a type replaces the earlier one");
        assert_eq!(o.get::<Other>(), Some(&Other("a")));
        assert_eq!(o.get::<u32>(), None);
        assert_eq!(SaveOptions::new("exr").get_or_default::<Level>(), Level(0));
        assert_eq!(format!("{o:?}").matches("Level").count(), 1, "{o:?}");
        let c = o.clone();
        assert_eq!((c.ext.as_str(), c.get::<Level>()), ("exr", Some(&Level(7))));
    }
}
