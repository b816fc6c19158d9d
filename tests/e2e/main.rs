//! End-to-end tests of the `spectrace` binary.
mod color;
mod defaults;
mod farm;
mod fuzz_replay;
mod outputs;
mod render;
