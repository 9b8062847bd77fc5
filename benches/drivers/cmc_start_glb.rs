//! Writes the start mesh of a CMC problem file as a binary glTF (`.glb`) with the crate's own
//! writer (`cmc::export::glb`: one mesh per surface, its material named after the surface), so
//! that a problem file can start from it through `[shape] type = "gltf"` (cmc::import_gltf,
//! which names surfaces by material and welds the surfaces' shared vertices back together).
//! Wires are not written (the export has no line primitives): use it for free bubble
//! clusters, or set `fix_boundary = true` for films spanning open boundaries.
//!
//! `cargo run --release --example cmc_start_glb -- FILE.toml OUT.glb [RESOLUTION]`; it made
//! `problems/cmc/double_bubble_start.glb` from `problems/cmc/double_bubble.toml` at resolution 3.

#[path = "../common/cmc_start.rs"]
mod cmc_start;

use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 {
        eprintln!("usage: cmc_start_glb FILE.toml OUT.glb [RESOLUTION]");
        return ExitCode::from(2);
    }
    let nlp = match cmc_start::build_start(&args[0], args.get(2)) {
        Ok(nlp) => nlp,
        Err(code) => return code,
    };
    let bytes = match optimize::cmc::export::glb(nlp.mesh()) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(1);
        }
    };
    if let Err(e) = std::fs::write(&args[1], &bytes) {
        eprintln!("{}: {e}", args[1]);
        return ExitCode::from(1);
    }
    eprintln!(
        "{}: {} vertices, {} triangles, {} surfaces, {} bytes",
        args[1],
        nlp.mesh().vertex_count(),
        nlp.mesh().triangles().len(),
        nlp.mesh().surfaces().len(),
        bytes.len()
    );
    ExitCode::SUCCESS
}
