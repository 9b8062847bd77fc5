//! Shared by the CMC export examples: the start mesh of a problem file, optionally at another
//! resolution, with the CLI's exit codes (2: bad input, 1: the mesh could not be built).

use std::path::Path;
use std::process::ExitCode;

use optimize::cmc::nlp::CmcNlp;

/// Loads `file`, applies `resolution` (the example's optional argument) and builds the start
/// mesh (`Problem::start`: after the coarse levels of a coarse-to-fine start); prints a one-line error and returns the exit code on failure.
pub fn build_start(file: &str, resolution: Option<&String>) -> Result<CmcNlp, ExitCode> {
    let problem = optimize::cmc::load(Path::new(file)).map_err(|e| {
        eprintln!("{e}");
        ExitCode::from(2)
    })?;
    let problem = match resolution.map(|r| r.parse::<usize>()) {
        Some(Ok(r)) => problem.with_resolution(r),
        Some(Err(e)) => {
            eprintln!("resolution: {e}");
            return Err(ExitCode::from(2));
        }
        None => problem,
    };
    problem.start().map_err(|e| {
        eprintln!("{e}");
        ExitCode::from(1)
    })
}
