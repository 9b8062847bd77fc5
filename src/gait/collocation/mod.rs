//! The traditional spacetime formulation (seed §3.2–3.4; Witkin & Kass 1988), for comparison
//! with the reduced-gradient one of [`crate::gait::reduced`]: the motion itself is the unknown
//! (Hermite position splines), Newton's law is a set of equality constraints collocated on
//! every frame, and the contact times are given in advance.
//!
//! - [`spec`]: the problem file (`formulation = "collocation"`), the seed's "actuated rubber
//!   ball" (a point mass that can push on the floor only during its contact phases);
//! - [`nlp`]: knots, variables, constraints and their constant exact derivatives;
//! - [`validate`](mod@validate): the physical checks of a solution (Newtonian residual between knots, RK4
//!   re-simulation, impulse balance, floor, friction, wall clearance).
//!
//! Selected by a gait problem file with a top-level `formulation = "collocation"`
//! ([`crate::gait::Gait`]).

pub mod export;
pub mod nlp;
pub mod spec;
pub mod validate;

use std::time::Instant;

use crate::error::{Error, InputError};
use crate::io::result::{Csv, num};
use crate::outcome::{Artifact, Headline, Kind, Outcome, ResultSummary, RunOptions};
use crate::solver::derivatives::CheckOptions;
use crate::solver::{Nlp, solve};
use crate::spec::Source;

pub use nlp::{Collocation, Layout};
pub use spec::Problem;
pub use validate::{Validity, validate};

/// Parses and validates a collocation problem file's text.
pub fn load_source(source: &Source) -> Result<Problem, InputError> {
    spec::load_source(source)
}

/// Solves the problem and reports the physical checks of [`validate`](mod@validate) in the
/// `result.json` figures; writes `trajectory.csv` (knots) and `iterations.csv`.
pub fn run(problem: &Problem, opts: &RunOptions) -> Result<Outcome, Error> {
    let nlp = Collocation::new(problem);
    let d = nlp.dims();
    let options = opts.solver_options(&problem.solver);
    let clock = Instant::now();
    let solution = solve(&nlp, &options);
    let solve_seconds = clock.elapsed().as_secs_f64();
    let validity = validate(problem, &nlp.layout, &solution.x);
    let mut summary = ResultSummary::from_solution(&problem.name, Kind::Gait, opts.seed, &solution);
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
    let caption = format!(
        "{}: {:?}, effort {:.4} N²·s",
        problem.name, solution.status, solution.objective
    );
    let glb = export::model_glb(problem, &nlp.layout, &solution.x)
        .map_err(|e| Error::Runtime(e.to_string()))?;
    let mut artifacts = vec![
        trajectory_csv(&nlp.layout, &solution.x),
        Artifact {
            name: "model.glb".into(),
            bytes: glb,
        },
        Artifact {
            name: "filmstrip.svg".into(),
            bytes: export::filmstrip(problem, &nlp.layout, &solution.x, &caption).into_bytes(),
        },
    ];
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

/// The `--check` comparison: the exact gradient, Jacobian and Hessian against central
/// differences in every variable (the fixed start, take-off and end positions included).
pub fn check_options() -> CheckOptions {
    CheckOptions::default()
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
