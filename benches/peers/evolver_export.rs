//! Writes the start mesh of a CMC problem file as a Surface Evolver datafile (cmc::evolver),
//! so both programs minimize the same mesh (benches/peers/evolver_compare.sh).
//!
//! `cargo run --release --example evolver_export -- FILE.toml OUT.fe [RESOLUTION [SCALE
//! [RESULT.json]]]`: RESOLUTION overrides the file's refinement level; SCALE multiplies every
//! length (default 100: metres to centimetres, so areas print in cm²). RESULT.json, a run's
//! `result.json` at the same resolution without edge flips (its `figures.mesh`, the start's
//! vertices in the start's order, as `--start` reads it), replaces the start's positions by the
//! run's final ones: optimize's answer as an Evolver datafile, for Evolver to evaluate and probe.

#[path = "../common/cmc_start.rs"]
mod cmc_start;

use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 {
        eprintln!("usage: evolver_export FILE.toml OUT.fe [RESOLUTION [SCALE [RESULT.json]]]");
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
    let nlp = match args.get(4) {
        Some(result) => match solved(&nlp, result) {
            Ok(nlp) => nlp,
            Err(code) => return code,
        },
        None => nlp,
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

/// `start`'s problem on the final mesh of the run whose `result.json` is `path`; a one-line
/// error and the CLI's exit code (2: unreadable or not this problem's mesh) on failure.
fn solved(
    start: &optimize::cmc::nlp::CmcNlp,
    path: &str,
) -> Result<optimize::cmc::nlp::CmcNlp, ExitCode> {
    let fail = |e: &dyn std::fmt::Display| {
        eprintln!("{path}: {e}");
        ExitCode::from(2)
    };
    let text = std::fs::read_to_string(path).map_err(|e| fail(&e))?;
    let result = serde_json::from_str(&text).map_err(|e| fail(&e))?;
    let previous = optimize::outcome::Previous {
        path: path.into(),
        result,
    };
    optimize::cmc::restart::nlp_from(start, &previous).map_err(|e| {
        eprintln!("{e}");
        ExitCode::from(2)
    })
}
