//! End-to-end tests of the `spectrace` binary.
mod color;
mod render;
