//! Geometry shared by every layer: the lat-long convention. A leaf module: it depends on nothing
//! else in the crate, so [`crate::data`] and [`crate::formats`] can use it without depending on
//! [`crate::maths`].

pub mod latlong;
