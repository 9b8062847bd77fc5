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
pub mod cmaes;
pub mod collocation;
pub mod contact;
pub mod continuation;
pub mod export;
pub mod feasibility;
pub mod formulation;
pub mod global;
pub mod penetration;
pub mod reduced;
pub mod restart;
pub mod shaping;
pub mod sim;
pub mod spatial;
pub mod spec;
pub mod spline;
pub mod step_check;
pub mod stepped;
pub mod task;
pub mod trials;

#[cfg(test)]
mod interrupt_tests;
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

use crate::application::{Application, CheckCase};
use crate::error::{Error, InputError};
use crate::outcome::{Headline, Kind, Outcome, ResultSummary, RunOptions};
use crate::solver::derivatives::CheckOptions;
use crate::solver::{Evaluations, Nlp, Status};
use crate::spec::Source;

pub use spec::Problem;

/// Reads, parses and validates a gait problem file of the reduced-gradient formulation.
pub fn load(path: &Path) -> Result<Problem, InputError> {
    spec::load_source(&Source::read(path)?)
}

impl Problem {
    /// The problem's name (the file's `name`, or its stem).
    pub fn name(&self) -> &str {
        &self.name
    }
}

/// A loaded gait problem in either formulation: the reduced-gradient one, or the traditional
/// collocation one when the file says `formulation = "collocation"` ([`collocation`]).
#[derive(Debug, Clone)]
pub enum GaitProblem {
    /// [`reduced`], solved in trials ([`trials`]).
    Reduced(Box<Problem>),
    /// [`collocation`].
    Collocation(Box<collocation::Problem>),
}

/// Gait problems as an [`Application`].
pub struct Gait;

impl Application for Gait {
    const KIND: Kind = Kind::Gait;
    type Problem = GaitProblem;

    fn load(source: Source) -> Result<GaitProblem, Error> {
        Ok(if collocation::spec::selects_collocation(&source) {
            GaitProblem::Collocation(Box::new(collocation::load_source(&source)?))
        } else {
            GaitProblem::Reduced(Box::new(spec::load_source(&source)?))
        })
    }

    fn name(problem: &GaitProblem) -> &str {
        match problem {
            GaitProblem::Reduced(p) => &p.name,
            GaitProblem::Collocation(p) => &p.name,
        }
    }

    /// Reduced gradient: the NLP at the start point with [`check_options`]. Collocation: the
    /// NLP at its initial guess, every variable by plain central differences.
    fn check_case<'p>(problem: &'p GaitProblem, opts: &RunOptions) -> Result<CheckCase<'p>, Error> {
        Ok(match problem {
            GaitProblem::Reduced(p) => {
                let nlp = reduced::Reduced::new(p);
                let mut x = vec![0.0; nlp.dims().n];
                nlp.start(&mut x);
                CheckCase::new(Box::new(nlp), x, check_options(), opts.seed)
            }
            GaitProblem::Collocation(p) => {
                let nlp = collocation::Collocation::new(p);
                let x = nlp.initial_guess();
                CheckCase::new(Box::new(nlp), x, collocation::check_options(), opts.seed)
                    .figure("formulation", "collocation")
            }
        })
    }

    fn run(problem: &GaitProblem, opts: &RunOptions) -> Result<Outcome, Error> {
        match problem {
            GaitProblem::Reduced(p) => solve_trials(p, opts),
            GaitProblem::Collocation(_) if opts.start.is_some() => {
                Err(Error::Input(InputError::whole_file(
                    &opts
                        .start
                        .as_ref()
                        .map_or_else(Default::default, |s| s.path.clone()),
                    "--start is not available for the collocation formulation",
                )))
            }
            GaitProblem::Collocation(p) => collocation::run(p, opts),
        }
    }
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

/// Solves the trials in parallel, prints the trial table (unless `opts.quiet`) and returns the
/// best trial's motion with the table in `result.json` figures.
pub fn solve_trials(problem: &Problem, opts: &RunOptions) -> Result<Outcome, Error> {
    let count = problem.trials.count;
    if let Some(k) = opts.trial
        && !(1..=count).contains(&k)
    {
        // A usage error (exit 2): the command line asks for a trial the file does not have.
        return Err(Error::Input(InputError::whole_file(
            Path::new(&problem.name),
            format!("--trial {k}: the file has trials 1 to {count} (`[trials] count`)"),
        )));
    }
    let mut options = opts.solver_options(&problem.solver);
    if opts.trial.is_none() && !opts.verbose {
        // Parallel trials: one line per trial as it finishes; their solver logs (buffered and
        // written in trial order) only with --verbose.
        options.verbosity = 0;
    }
    let clock = Instant::now();
    // Every rollout of the trials polls the run's interrupt flag.
    let polled = Problem {
        interrupt: opts.interrupt.clone(),
        ..problem.clone()
    };
    let results = match &opts.start {
        Some(previous) => {
            let mut options = options.clone();
            options.log.objective = crate::solver::log::ObjectiveUnit::new(
                "effort",
                "N²·s",
                formulation::Formulation::new(&polled).objective_scale(),
            );
            vec![restart::trial_from(&polled, previous, &options)?]
        }
        None => trials::run_trials(&polled, opts.seed, opts.trial, &options),
    };
    let solve_seconds = clock.elapsed().as_secs_f64();
    let tol = problem.trials.tolerance;
    let table = trials::table(&results, tol);
    opts.say(&format!(
        "{}: {} trial(s), {solve_seconds:.1} s\n{}",
        problem.name,
        results.len(),
        table.trim_end()
    ));
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
    let caption = format!(
        "{}: trial {} {:?}, effort {:.4} N²·s",
        problem.name,
        chosen.trial,
        chosen.status,
        chosen.cost()
    );
    let mut artifacts = export::artifacts(problem, &chosen.x, &caption)
        .map_err(|e| Error::Runtime(format!("{}: {e}", problem.name)))?;
    // Every trial's records, in trial order (the stage column names the trial).
    let log: Vec<_> = results
        .iter()
        .flat_map(|r| r.solution.log.iter().cloned())
        .collect();
    let headline = Headline::new("effort", chosen.cost(), "N²·s");
    artifacts.extend(crate::io::result::iteration_files(
        &problem.name,
        &headline,
        &log,
    ));
    let mut timings = std::collections::BTreeMap::new();
    timings.insert("solve".to_string(), solve_seconds);
    timings.insert("export".to_string(), export_clock.elapsed().as_secs_f64());
    let counts = |s: trials::TrialStatus| results.iter().filter(|r| r.status == s).count();
    let end = chosen.end.as_ref();
    let status = run_status(chosen);
    let summary = ResultSummary {
        problem: problem.name.clone(),
        kind: Kind::Gait,
        headline,
        status: format!("{status:?}"),
        status_message: format!(
            "Best of {} trial(s): trial {} ({:?}); its last solve ended {:?}. {}",
            results.len(),
            chosen.trial,
            chosen.status,
            chosen.solver_status,
            status_sentence(status, chosen.status)
        ),
        objective: chosen.cost(),
        max_violation: end.map_or(f64::INFINITY, |a| a.max()),
        iterations: results.iter().map(|r| r.iterations).sum(),
        evaluations,
        timings,
        seed: opts.seed,
        overrides: Vec::new(),
        figures: serde_json::json!({
            "best_trial": chosen.trial,
            "best_status": format!("{:?}", chosen.status),
            "best_solver_status": format!("{:?}", chosen.solver_status),
            "cost": chosen.cost(),
            "tolerance": tol,
            "successes": counts(trials::TrialStatus::Success),
            "marginal": counts(trials::TrialStatus::Marginal),
            "failures": counts(trials::TrialStatus::Failure),
            "unimproved": counts(trials::TrialStatus::Unimproved),
            "trials": trials::table_json(&results, tol),
            "knots": restart::knots_json(problem, &chosen.x),
            "median_trial_seconds": median(results.iter().map(|r| r.seconds).collect()),
            "global_seconds": results
                .iter()
                .map(|r| r.global.as_ref().map_or(0.0, |g| g.seconds))
                .sum::<f64>(),
        }),
    };
    Ok(Outcome {
        summary,
        status: Some(status),
        check_passed: None,
        artifacts,
    })
}

/// The status of a gait run, which decides its exit code (a raised interrupt flag makes any
/// run `Interrupted`, [`crate::outcome::Outcome::mark_interrupted`]): the run converged
/// (exit 0) exactly when its best trial is a Success (every pose constraint within `[trials] tolerance`), whatever
/// stopped that trial's last effort-lowering solve: `Optimal` if that solve converged, else
/// `Acceptable`. A best trial short of Success keeps its last solve's status, or `Stalled` if
/// that solve converged to the solver's tolerances but not to the file's (exit 3).
pub fn run_status(best: &trials::TrialResult) -> Status {
    let success = best.status == trials::TrialStatus::Success;
    match best.solver_status {
        Status::Optimal if success => Status::Optimal,
        _ if success => Status::Acceptable,
        s if s.is_success() => Status::Stalled,
        s => s,
    }
}

/// The run's status in one sentence (the trial classes of [`trials`]).
fn status_sentence(status: Status, best: trials::TrialStatus) -> &'static str {
    match status {
        Status::Interrupted => Status::Interrupted.sentence(),
        Status::Optimal | Status::Acceptable => {
            "Converged: the best motion meets every pose constraint within the file's tolerance."
        }
        _ if best == trials::TrialStatus::Marginal => {
            "Not converged: the best motion meets every pose constraint only within 10× the \
             file's tolerance; the best point is returned."
        }
        _ => {
            "Not converged: the best motion violates a pose constraint by more than 10× the \
             file's tolerance, or its drawn body passes through the ground; the best point is \
             returned."
        }
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

#[cfg(test)]
mod tests {
    use super::trials::{Assessment, TrialResult, TrialStatus};
    use super::*;
    use crate::solver::Solution;

    fn trial(status: TrialStatus, solver_status: Status) -> TrialResult {
        let end = Assessment {
            cost: 1.0,
            violations: vec![0.0],
        };
        TrialResult {
            trial: 1,
            origin: "hand-made".into(),
            global: None,
            x: vec![],
            start: None,
            end: Some(end),
            fine: None,
            depth: None,
            fine_depth: None,
            downgrade: None,
            status,
            solver_status,
            iterations: 0,
            seconds: 0.0,
            evaluations: Evaluations::default(),
            solution: Solution {
                status: solver_status,
                x: vec![],
                lambda: vec![],
                z: vec![],
                objective: 1.0,
                constraints: vec![],
                max_violation: 0.0,
                optimality: 0.0,
                iterations: 0,
                evaluations: Evaluations::default(),
                seconds: 0.0,
                log: vec![],
            },
        }
    }

    /// The run converged (exit 0) exactly when its best trial is a Success.
    #[test]
    fn a_gait_run_converges_when_its_best_trial_is_a_success() {
        use TrialStatus::*;
        let cases = [
            (Success, Status::Optimal, Status::Optimal),
            (Success, Status::IterationLimit, Status::Acceptable),
            (Success, Status::Stalled, Status::Acceptable),
            (Marginal, Status::Optimal, Status::Stalled),
            (Failure, Status::IterationLimit, Status::IterationLimit),
            (Unimproved, Status::Interrupted, Status::Interrupted),
        ];
        for (class, solver, want) in cases {
            let status = run_status(&trial(class, solver));
            assert_eq!(status, want, "{class:?} {solver:?}");
            assert_eq!(
                status.is_success(),
                class == Success,
                "{class:?} {solver:?}"
            );
        }
    }
}
