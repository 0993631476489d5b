//! Placeholder while the client is written; the real program replaces it.
fn main() {}
