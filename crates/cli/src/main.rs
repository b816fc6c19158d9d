//! The `spectrace` command-line renderer (in progress).
fn main() {
    eprintln!("spectrace: not yet implemented");
    std::process::exit(2);
}
