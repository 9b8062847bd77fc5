//! The `optimize` command line.
fn main() {}
