//! The `octoarm` command line (work in progress: see the README).
fn main() {
    println!("octoarm {}", env!("CARGO_PKG_VERSION"));
}
