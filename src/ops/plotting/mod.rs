//! Curves and plots.

pub mod fresnel;

use crate::engine::registry::Registry;

pub fn register(r: &mut Registry) {
    r.register(fresnel::spec());
}
