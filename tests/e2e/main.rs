//! End-to-end tests of the `spectrace` binary.
mod color;
mod fuzz_replay;
mod render;
