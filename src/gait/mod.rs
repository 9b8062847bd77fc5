//! Reduced-gradient spacetime optimization of articulated characters (seed chapter 3).
//!
//! A character (a tree of rigid links) is simulated forward from actuator force trajectories;
//! pose constraints are read off the simulated motion at key times.
//! - [`spatial`]: 6-D spatial algebra; [`character`]: the link tree; [`aba`]: forward dynamics;
//! - [`contact`]: the seed's ground spring and friction; [`sim`]: RK4 rollouts;
//! - [`spline`]: Hermite force splines and the closed-form objective; [`task`]: pose
//!   constraints; [`reduced`]: the reduced-gradient NLP with exact dual-number derivatives;
//! - [`feasibility`]: a Levenberg–Marquardt phase on the constraint violations, and
//!   [`continuation`]: key-time continuation of unmet lower bounds, both run before the SQP
//!   solve of a trial when the file asks ([`trials`]); [`shaping`]: the shaping solves that
//!   open each trial;
//! - [`spec`]: the problem file.

pub mod aba;
pub mod character;
pub mod collocation;
pub mod contact;
pub mod continuation;
pub mod export;
pub mod feasibility;
pub mod formulation;
pub mod reduced;
pub mod shaping;
pub mod sim;
pub mod spatial;
pub mod spec;
pub mod spline;
pub mod task;
pub mod trials;

#[cfg(test)]
mod truth_tests;

/// The golden-test problem file `tests/golden/problems/gait/{name}.toml`, loaded (tests only).
#[cfg(test)]
pub(crate) fn golden_problem(name: &str) -> Problem {
    let path = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join(format!("tests/golden/problems/gait/{name}.toml"));
    load(&path).unwrap()
}

use std::path::Path;
use std::time::Instant;

use crate::error::{Error, InputError};
use crate::run::{Outcome, ResultSummary, RunOptions};
use crate::solver::derivatives::{CheckOptions, check_derivatives};
use crate::solver::{Evaluations, Nlp};
use crate::spec::{Key, Source};

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

/// Loads and runs a gait problem file: the traditional collocation formulation when the file
/// says `formulation = "collocation"` ([`collocation`]), else the reduced-gradient one
/// ([`load`], [`run`]). Returns the problem's name and the outcome.
pub fn execute(path: &Path, opts: &RunOptions) -> Result<(String, Outcome), Error> {
    let source = Source::read(path)?;
    if collocation::spec::selects_collocation(&source) {
        let problem = collocation::load_source(&source)?;
        let outcome = collocation::run(&problem, opts)?;
        return Ok((problem.name.clone(), outcome));
    }
    let problem = spec::load_source(&source)?;
    let count = problem.trials.count;
    if let Some(k) = opts.trial
        && !(1..=count).contains(&k)
    {
        let at = [Key::Name("trials"), Key::Name("count")];
        let message = format!("--trial {k}: {} has trials 1 to {count}", problem.name);
        return Err(source.error_at(&at, message).into());
    }
    let outcome = run(&problem, opts)?;
    Ok((problem.name().to_string(), outcome))
}

/// Relative agreement required of exact derivatives and central differences in `--check` runs.
pub const CHECK_TOLERANCE: f64 = 1e-5;

/// The `--check` comparison: every column, Richardson-extrapolated central differences
/// (`D = (4·D(h/2) − D(h))/3` cancels the h² truncation term; the stiff contact makes plain
/// central differences truncation-limited: on the full Luxo leap their error falls 100× from
/// h = 1e-5 to 1e-6 and then levels off near 1e-5 relative, at the simulation's round-off).
pub fn check_options() -> CheckOptions {
    CheckOptions {
        tolerance: CHECK_TOLERANCE,
        richardson: true,
        kink_threshold: Some(CHECK_TOLERANCE),
        ..CheckOptions::default()
    }
}

/// Runs a gait problem. With `opts.check`: builds the reduced-gradient NLP, evaluates it at the
/// start point and compares its exact derivatives with extrapolated central differences by the
/// shared checker ([`check_options`]; the report goes to `result.json` figures). Otherwise
/// solves the trials ([`trials`]; `opts.trial` picks one) and returns the best motion
/// ([`solve_trials`]).
pub fn run(problem: &Problem, opts: &RunOptions) -> Result<Outcome, Error> {
    if !opts.check {
        return solve_trials(problem, opts);
    }
    let t0 = Instant::now();
    let nlp = reduced::Reduced::new(problem);
    let d = nlp.dims();
    let mut x = vec![0.0; d.n];
    nlp.start(&mut x);
    let failed = |e: crate::solver::EvalError| Error::Runtime(format!("{}: {e}", problem.name));
    let report = check_derivatives(&nlp, &x, &check_options()).map_err(failed)?;
    let mut summary = ResultSummary::checked(&problem.name, "gait", opts.seed, &nlp, &x, &report)
        .map_err(failed)?;
    summary
        .timings
        .insert("check".to_string(), t0.elapsed().as_secs_f64());
    summary.set_figure("variables", d.n);
    summary.set_figure("constraints", d.m);
    summary.set_figure("jacobian_nonzeros", d.jac_nnz);
    Ok(Outcome {
        summary,
        status: None,
        check_passed: Some(report.passed()),
        artifacts: vec![],
    })
}

/// Solves the trials in parallel, prints the trial table (unless `opts.quiet`) and returns the
/// best trial's motion with the table in `result.json` figures.
pub fn solve_trials(problem: &Problem, opts: &RunOptions) -> Result<Outcome, Error> {
    let count = problem.trials.count;
    if let Some(k) = opts.trial
        && !(1..=count).contains(&k)
    {
        return Err(Error::Runtime(format!(
            "--trial {k}: {} has trials 1 to {count}",
            problem.name
        )));
    }
    let mut options = opts.solver_options(&problem.solver);
    if opts.trial.is_none() && !opts.verbose {
        // Parallel trials would interleave their logs.
        options.verbosity = 0;
    }
    let clock = Instant::now();
    let results = trials::run_trials(problem, opts.seed, opts.trial, &options);
    let solve_seconds = clock.elapsed().as_secs_f64();
    let tol = problem.trials.tolerance;
    let table = trials::table(&results, tol);
    if !opts.quiet {
        eprintln!(
            "{}: {} trial(s), {solve_seconds:.1} s\n{table}",
            problem.name,
            results.len()
        );
    }
    let best = trials::best(&results)
        .ok_or_else(|| Error::Runtime(format!("{}: no trials were run", problem.name)))?;
    let chosen = &results[best];
    let mut evaluations = Evaluations::default();
    for r in &results {
        evaluations.functions += r.evaluations.functions;
        evaluations.derivatives += r.evaluations.derivatives;
        evaluations.hessians += r.evaluations.hessians;
    }
    let export_clock = Instant::now();
    let mut artifacts = export::artifacts(problem, &chosen.x)
        .map_err(|e| Error::Runtime(format!("{}: {e}", problem.name)))?;
    artifacts.push(crate::io::result::iterations_csv(
        "iterations.csv",
        &chosen.solution.log,
    ));
    let mut timings = std::collections::BTreeMap::new();
    timings.insert("solve".to_string(), solve_seconds);
    timings.insert("export".to_string(), export_clock.elapsed().as_secs_f64());
    let counts = |s: trials::TrialStatus| results.iter().filter(|r| r.status == s).count();
    let end = chosen.end.as_ref();
    let summary = ResultSummary {
        problem: problem.name.clone(),
        kind: "gait".into(),
        status: format!("{:?}", chosen.solver_status),
        status_message: format!(
            "Best of {} trial(s): trial {} ({:?}). {}",
            results.len(),
            chosen.trial,
            chosen.status,
            chosen.solver_status.sentence()
        ),
        objective: chosen.cost(),
        max_violation: end.map_or(f64::INFINITY, |a| a.max()),
        iterations: results.iter().map(|r| r.iterations).sum(),
        evaluations,
        timings,
        seed: opts.seed,
        figures: serde_json::json!({
            "best_trial": chosen.trial,
            "best_status": format!("{:?}", chosen.status),
            "cost": chosen.cost(),
            "tolerance": tol,
            "successes": counts(trials::TrialStatus::Success),
            "marginal": counts(trials::TrialStatus::Marginal),
            "failures": counts(trials::TrialStatus::Failure),
            "unimproved": counts(trials::TrialStatus::Unimproved),
            "trials": trials::table_json(&results, tol),
            "median_trial_seconds": median(results.iter().map(|r| r.seconds).collect()),
        }),
    };
    Ok(Outcome {
        summary,
        status: Some(chosen.solver_status),
        check_passed: None,
        artifacts,
    })
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}
