//! Dataset preparation: what a lighting-estimation dataset stores beside each crop.

pub mod crop_label;

use crate::engine::registry::Registry;

pub fn register(r: &mut Registry) {
    r.register(crop_label::spec());
}
