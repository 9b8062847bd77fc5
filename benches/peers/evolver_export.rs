//! Writes the start mesh of a CMC problem file as a Surface Evolver datafile (cmc::evolver),
//! so both programs minimize the same mesh (benches/peers/evolver_compare.sh).
//!
//! `cargo run --release --example evolver_export -- FILE.toml OUT.fe [RESOLUTION [SCALE]]`:
//! RESOLUTION overrides the file's refinement level; SCALE multiplies every length (default
//! 100: metres to centimetres, so areas print in cm²).

#[path = "../common/cmc_start.rs"]
mod cmc_start;

use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 {
        eprintln!("usage: evolver_export FILE.toml OUT.fe [RESOLUTION [SCALE]]");
        return ExitCode::from(2);
    }
    let scale = match args.get(3).map(|s| s.parse::<f64>()) {
        Some(Ok(s)) if s > 0.0 => s,
        Some(_) => {
            eprintln!("scale must be a positive number");
            return ExitCode::from(2);
        }
        None => 100.0,
    };
    let nlp = match cmc_start::build_start(&args[0], args.get(2)) {
        Ok(nlp) => nlp,
        Err(code) => return code,
    };
    let text = match optimize::cmc::evolver::datafile(nlp.mesh(), nlp.volumes(), scale) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(1);
        }
    };
    if let Err(e) = std::fs::write(&args[1], text) {
        eprintln!("{}: {e}", args[1]);
        return ExitCode::from(1);
    }
    eprintln!(
        "{}: {} vertices, {} triangles",
        args[1],
        nlp.mesh().vertex_count(),
        nlp.mesh().triangles().len()
    );
    ExitCode::SUCCESS
}
