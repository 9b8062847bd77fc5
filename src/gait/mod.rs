//! Reduced-gradient spacetime optimization of articulated characters (seed chapter 3).
//!
//! A character (a tree of rigid links) is simulated forward from actuator force trajectories;
//! pose constraints are read off the simulated motion at key times.
//! - [`spatial`]: 6-D spatial algebra; [`character`]: the link tree; [`aba`]: forward dynamics;
//! - [`contact`]: the seed's ground spring and friction; [`sim`]: RK4 rollouts;
//! - [`spline`]: Hermite force splines and the closed-form objective; [`task`]: pose
//!   constraints; [`reduced`]: the reduced-gradient NLP with exact dual-number derivatives;
//! - [`spec`]: the problem file.

pub mod aba;
pub mod character;
pub mod contact;
pub mod reduced;
pub mod sim;
pub mod spatial;
pub mod spec;
pub mod spline;
pub mod task;

#[cfg(test)]
mod truth_tests;

use std::path::Path;
use std::time::Instant;

use crate::error::{Error, InputError};
use crate::run::{Outcome, ResultSummary, RunOptions};
use crate::solver::{Evaluations, Nlp};
use crate::spec::Source;

pub use spec::Problem;

/// Reads, parses and validates a gait problem file.
pub fn load(path: &Path) -> Result<Problem, InputError> {
    spec::load_source(&Source::read(path)?)
}

impl Problem {
    /// The problem's name (the file's `name`, or its stem).
    pub fn name(&self) -> &str {
        &self.name
    }
}

/// Relative agreement required of exact derivatives and central differences in `--check` runs.
pub const CHECK_TOLERANCE: f64 = 1e-5;

/// Runs a gait problem. With `opts.check`: builds the reduced-gradient NLP, evaluates it at the
/// start point and compares its exact derivatives with extrapolated central differences
/// ([`reduced::check_derivatives`]; figures in
/// `result.json`). Solving (trials from several starts) is not available yet and is reported as
/// a runtime error.
pub fn run(problem: &Problem, opts: &RunOptions) -> Result<Outcome, Error> {
    if !opts.check {
        return Err(Error::Runtime(
            "gait problems can only be checked (--check) so far; solving is not wired yet".into(),
        ));
    }
    let t0 = Instant::now();
    let nlp = reduced::Reduced::new(problem);
    let d = nlp.dims();
    let mut x = vec![0.0; d.n];
    nlp.start(&mut x);
    let (mut f, mut c) = (0.0, vec![0.0; d.m]);
    let failed = |e: crate::solver::EvalError| Error::Runtime(format!("{}: {e}", problem.name));
    nlp.eval(&x, &mut f, &mut c).map_err(failed)?;
    let (mut xl, mut xu, mut cl, mut cu) = (
        vec![0.0; d.n],
        vec![0.0; d.n],
        vec![0.0; d.m],
        vec![0.0; d.m],
    );
    nlp.bounds(&mut xl, &mut xu, &mut cl, &mut cu);
    let violation = c
        .iter()
        .zip(cl.iter().zip(&cu))
        .map(|(v, (lo, hi))| (lo - v).max(v - hi).max(0.0))
        .fold(0.0, f64::max);
    let check = reduced::check_derivatives(&nlp, &x, 1e-5).map_err(failed)?;
    let passed = check.jacobian_error < CHECK_TOLERANCE
        && check.gradient_error < CHECK_TOLERANCE
        && check.pattern_violations == 0;
    let mut timings = std::collections::BTreeMap::new();
    timings.insert("check".to_string(), t0.elapsed().as_secs_f64());
    let summary = ResultSummary {
        problem: problem.name.clone(),
        kind: "gait".into(),
        status: "Checked".into(),
        status_message: if passed {
            "Exact derivatives agree with central differences.".into()
        } else {
            "Exact derivatives disagree with central differences.".into()
        },
        objective: f,
        max_violation: violation,
        iterations: 0,
        evaluations: Evaluations {
            functions: 1 + 4 * d.n,
            derivatives: 1,
            hessians: 0,
        },
        timings,
        seed: opts.seed,
        figures: serde_json::json!({
            "variables": d.n,
            "constraints": d.m,
            "jacobian_nonzeros": d.jac_nnz,
            "jacobian_error": check.jacobian_error,
            "gradient_error": check.gradient_error,
            "pattern_violations": check.pattern_violations,
        }),
    };
    Ok(Outcome {
        summary,
        status: None,
        check_passed: Some(passed),
        artifacts: vec![],
    })
}
