//! Integration tests of the geometry crate (one binary, modules per topic).

// The benchmarks' scene generators (icosphere, terrain, xorshift stream), shared rather than copied.
#[path = "../../benches/common/mod.rs"]
mod common;
mod intersection;
mod loaders;
