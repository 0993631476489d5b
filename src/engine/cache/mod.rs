//! The content-addressed cache.
//!
//! - `key`: a node's key is a BLAKE3 hash of its operator's name and version, its parameters in
//!   canonical binary form (floats by their bits), its inputs' keys, and for loaders the content
//!   of the file they read. Keys never contain absolute paths, times, thread counts or RON text,
//!   so they are portable between machines.
//! - `codec`: values to bytes and back, with every length checked on the way in.
//! - `store`: one file per key under the cache folder, written atomically (temporary file then
//!   rename), checksummed, evicted least-recently-used past a size limit.
//! - `policy`: which computed results are worth storing at all.

pub mod codec;
pub mod key;
pub mod policy;
pub mod store;

pub use key::{aux_key, key_hex, node_key, node_key_with, provided_key, provided_key_with, Key};
pub use policy::{Persist, PersistPolicy};
pub use store::CacheStore;
