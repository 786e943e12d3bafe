//! Links the `capsule` binary as a position-dependent executable (`-no-pie`): its loader then
//! has no 13,000 relative relocations to apply and no relocated data pages to copy at every
//! start, which is a fifth of a short run's cost (docs/perf/accuracy.md). The one binary is a
//! command-line tool started many times by scripts; the nodes keep the default.

fn main() {
    println!("cargo:rustc-link-arg-bin=capsule=-no-pie");
    // the argument depends on nothing else: no rerun when the crate's sources change
    println!("cargo:rerun-if-changed=build.rs");
}
