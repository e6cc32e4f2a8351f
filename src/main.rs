//! shellwarp command-line interface.

fn main() {}
