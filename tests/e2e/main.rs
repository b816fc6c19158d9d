//! End-to-end tests of the `spectrace` binary.
mod render;
