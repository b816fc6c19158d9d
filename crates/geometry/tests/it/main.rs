//! Integration tests of the geometry crate (one binary, modules per topic).

mod intersection;
mod loaders;
