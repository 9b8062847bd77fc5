//! The traditional spacetime formulation (seed §3.2–3.4; Witkin & Kass 1988), for comparison
//! with the reduced-gradient one of [`crate::gait::reduced`]: the motion itself is the unknown
//! (Hermite position splines), Newton's law is a set of equality constraints collocated on
//! every frame, and the contact times are given in advance.
//!
//! - [`spec`]: the problem file (`formulation = "collocation"`), the seed's "actuated rubber
//!   ball" (a point mass that can push on the floor only during its contact phases);
//! - [`nlp`]: knots, variables, constraints and their constant exact derivatives;
//! - [`validate`]: the physical checks of a solution (Newtonian residual between knots, RK4
//!   re-simulation, impulse balance, floor, friction, wall clearance).
//!
//! Selected by a gait problem file with a top-level `formulation = "collocation"`
//! ([`crate::gait::execute`]).

pub mod nlp;
pub mod spec;
pub mod validate;

use std::time::Instant;

use crate::error::{Error, InputError};
use crate::io::result::{Csv, num};
use crate::run::{Artifact, Headline, Outcome, ResultSummary, RunOptions};
use crate::solver::derivatives::{CheckOptions, check_derivatives};
use crate::solver::{EvalError, Nlp, solve};
use crate::spec::Source;

pub use nlp::{Collocation, Layout};
pub use spec::Problem;
pub use validate::{Validity, validate};

/// Parses and validates a collocation problem file's text.
pub fn load_source(source: &Source) -> Result<Problem, InputError> {
    spec::load_source(source)
}

/// Solves the problem (or, with `opts.check`, compares its derivatives with central
/// differences at the start point) and reports the physical checks of [`validate`] in the
/// `result.json` figures; writes `trajectory.csv` (knots) and `iterations.csv`.
pub fn run(problem: &Problem, opts: &RunOptions) -> Result<Outcome, Error> {
    let nlp = Collocation::new(problem);
    let d = nlp.dims();
    let failed = |e: crate::solver::EvalError| Error::Runtime(format!("{}: {e}", problem.name));
    if opts.check {
        let clock = Instant::now();
        let x = nlp.initial_guess();
        let report = check(&nlp, &x).map_err(failed)?;
        let mut summary =
            ResultSummary::checked(&problem.name, "gait", opts.seed, &nlp, &x, &report)
                .map_err(failed)?;
        summary
            .timings
            .insert("check".into(), clock.elapsed().as_secs_f64());
        summary.set_figure("formulation", "collocation");
        summary.set_figure("variables", d.n);
        summary.set_figure("constraints", d.m);
        summary.set_figure("jacobian_nonzeros", d.jac_nnz);
        return Ok(Outcome {
            summary,
            status: None,
            check_passed: Some(report.passed()),
            artifacts: vec![],
        });
    }
    let options = opts.solver_options(&problem.solver);
    let clock = Instant::now();
    let solution = solve(&nlp, &options);
    let solve_seconds = clock.elapsed().as_secs_f64();
    let validity = validate(problem, &nlp.layout, &solution.x);
    let mut summary = ResultSummary::from_solution(&problem.name, "gait", opts.seed, &solution);
    summary.timings.insert("solve".into(), solve_seconds);
    summary.figures = serde_json::json!({
        "formulation": "collocation",
        "variables": d.n,
        "constraints": d.m,
        "jacobian_nonzeros": d.jac_nnz,
        "knots": nlp.layout.times.len(),
        "cost": solution.objective,
        "validity": validity,
    });
    summary.headline = Headline::new("effort", solution.objective, "N²·s");
    opts.say(&format!(
        "{}: {:?} in {} iterations, {:.3} s; cost {:.6} N²·s; Newton residual {:.2e} N, \
             re-simulation gap {:.2e} m, wall clearance {}",
        problem.name,
        solution.status,
        solution.iterations,
        solve_seconds,
        solution.objective,
        validity.newton_residual,
        validity.resimulation_gap,
        validity
            .wall_clearance
            .map_or("n/a".into(), |c| format!("{c:.4} m")),
    ));
    let mut artifacts = vec![trajectory_csv(&nlp.layout, &solution.x)];
    artifacts.extend(crate::io::result::iteration_files(
        &problem.name,
        &summary.headline,
        &solution.log,
    ));
    Ok(Outcome {
        summary,
        status: Some(solution.status),
        check_passed: None,
        artifacts,
    })
}

/// Compares the exact gradient, Jacobian and Hessian of `nlp` at `x` with central differences
/// in every variable (the fixed start, take-off and end positions included).
pub fn check(
    nlp: &Collocation<'_>,
    x: &[f64],
) -> Result<crate::solver::derivatives::DerivativeReport, EvalError> {
    check_derivatives(nlp, x, &CheckOptions::default())
}

/// `trajectory.csv`: per knot, time (s), position (m), velocity (m/s) and ground force (N).
pub fn trajectory_csv(l: &Layout, x: &[f64]) -> Artifact {
    let mut csv = Csv::new(&["t", "x", "y", "vx", "vy", "fx", "fy"]);
    for (i, &t) in l.times.iter().enumerate() {
        let f = |a: usize| l.force[i].map_or(0.0, |j| x[j + a]);
        csv.row([
            num(t),
            num(x[l.var(i, 0, false)]),
            num(x[l.var(i, 1, false)]),
            num(x[l.var(i, 0, true)]),
            num(x[l.var(i, 1, true)]),
            num(f(0)),
            num(f(1)),
        ]);
    }
    csv.into_artifact("trajectory.csv")
}

#[cfg(test)]
mod tests;
