//! Trials (seed §3.7, Table 3.7): the same task solved from several initial force profiles,
//! each classified by how well its final motion meets the pose constraints.
//!
//! Trial 1 starts from the hand-made profile (`[[actuator]] start`); trial `k ≥ 2` from that
//! profile plus a uniform random perturbation of every knot value by up to
//! `spread·(hi − lo)/2` (slopes start at zero), clamped into the spline box of
//! [`Formulation`]. All starts are drawn up front, in trial order, from one `ChaCha8Rng` seeded
//! with the run's seed, and trials are solved in parallel (rayon): results do not depend on the
//! number of threads.
//!
//! With `[trials] feasibility_first`, a Levenberg–Marquardt phase on the constraint violations
//! ([`crate::gait::feasibility`]) runs first (after the key-time continuation stages of
//! [`crate::gait::continuation`], if any) and the SQP solve starts from its end point; if the
//! phase ends at a stationary point of the violation short of its target, the SQP solve is
//! skipped and the trial ends there (solver status Stalled, or IterationLimit). A trial
//! that ends short of Success with its solver stopped early (Stalled, Infeasible,
//! Acceptable, ...) is re-solved from its end point (a fresh quasi-Newton model) until
//! `[trials] restarts` restarts have failed to halve the violation sum (a restart that halves it
//! is still converging and is not counted; [`MAX_SOLVES`] solves at most); the better end
//! point is kept: one meeting every constraint within the
//! tolerance over one that does not, then the lower cost among such points, else the lower
//! violation sum. The phase's point is replaced only by a better one. A later solve that ends
//! short of the tolerance at a lower cost than a kept point meeting it is re-solved once from
//! its own end point (whatever stopped it, but a time limit or an interrupt): a fresh
//! quasi-Newton model often brings such a point back onto the rows at the lower effort.
//!
//! Feasibility rescue: when those solves end short of the tolerance on their own (not on a
//! budget or an interrupt) and the file has no `feasibility_first`, the feasibility phase runs
//! from the point the solves started at; if it reaches its target, the effort solves run
//! again from its end point, which is kept unless a later point is better. The ℓ1 merit's
//! penalty weight grows without bound where the rollout is violently nonlinear, while the
//! phase's damping (a trust region) still makes progress there.
//!
//! Shaping rows (`[[task]] shaping = true`) guide the trial's first solves
//! ([`crate::gait::shaping`]): one shaped solve with the task's rows, or with `[trials]
//! shaping_stages` staged feasibility solves. The solves above start from their end point, and
//! the trial is judged on the task's rows only. The end point of staged shaping is a candidate
//! like the feasibility phase's (it meets the task's rows when its last stage is met, and the
//! effort solves that follow may end short of them); that of one shaped solve is not.
//!
//! Classification, with `tol` = `[trials] tolerance` in each constraint's unit and the violation
//! of row `r` = `max(lower − c, c − upper, 0)`:
//! - Success: every violation ≤ tol; Marginal: every violation ≤ 10·tol;
//! - Unimproved: otherwise, if the violation sum did not fall below 99.9% of the start's;
//! - Failure: otherwise.
//!
//! A Success or Marginal is then confirmed at `dt/4` ([`crate::gait::step_check`]) and on its
//! drawn body: if any link's shape passes more than [`crate::gait::penetration::DEPTH_TOLERANCE`]
//! deeper below the ground than the contact points at `dt` or `dt/4`, the trial is a Failure
//! ([`crate::gait::penetration`]).
//!
//! Cost is `∫ΣF²dt` (N²·s, seed eq. 3.1).

use std::fmt::Write as _;
use std::time::Instant;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use super::continuation::stage_problems;
use super::feasibility::{Feasibility, FeasibilitySettings, restore};
use super::formulation::Formulation;
use super::global::{GlobalReport, search};
use super::penetration::{Penetration, judge};
use super::shaping::shape;
use super::spec::{Problem, StartKind};
use super::step_check::confirm;
use super::stepped::solve_stepped;
use crate::solver::log::{Buffer, LogTarget, ObjectiveUnit};
use crate::solver::{Evaluations, IterationRecord, Nlp, Options, Solution, Status, solve};

/// The feasibility phase stops once every violation is within this fraction of the tolerance.
pub const FEASIBILITY_TARGET: f64 = 0.1;

/// How a trial's final motion meets the pose constraints (module header).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum TrialStatus {
    /// Every pose constraint within tolerance.
    Success,
    /// Every pose constraint within 10× tolerance.
    Marginal,
    /// Some constraint beyond 10× tolerance, but the violation fell.
    Failure,
    /// No progress from the start.
    Unimproved,
}

/// How a point meets the pose constraints.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Assessment {
    /// `∫ΣF²dt` (N²·s).
    pub cost: f64,
    /// Violation of each constraint row (its unit).
    pub violations: Vec<f64>,
}

impl Assessment {
    /// Rows violated by more than `tol`.
    pub fn violated(&self, tol: f64) -> usize {
        self.violations.iter().filter(|&&v| v > tol).count()
    }

    /// Sum of the violations.
    pub fn sum(&self) -> f64 {
        self.violations.iter().sum()
    }

    /// The largest violation.
    pub fn max(&self) -> f64 {
        self.violations.iter().copied().fold(0.0, f64::max)
    }
}

/// Evaluates the motion of physical spline parameters `x` (the leading entries; segment start
/// states after them are ignored) by one rollout; `None` if the simulation fails.
/// After the run's interrupt flag is raised, a rollout stops early and the point is not
/// assessed (`None`): a trial then keeps the last point it assessed.
pub fn assess(f: &Formulation<'_>, x: &[f64]) -> Option<Assessment> {
    let nlp = f.reduced();
    let d = nlp.dims();
    let x = &x[..d.n];
    let (mut cost, mut c) = (0.0, vec![0.0; d.m]);
    nlp.eval(x, &mut cost, &mut c).ok()?;
    let crate::solver::Bounds { cl, cu, .. } = crate::solver::Bounds::of(nlp);
    let violations = c
        .iter()
        .zip(cl.iter().zip(&cu))
        .map(|(v, (lo, hi))| (lo - v).max(v - hi).max(0.0))
        .collect();
    Some(Assessment { cost, violations })
}

/// One solved trial.
#[derive(Debug, Clone, Serialize)]
pub struct TrialResult {
    /// Trial number (1-based).
    pub trial: usize,
    /// Where the start came from ([`TrialStart::origin`]).
    pub origin: String,
    /// The global phase, when it ran (the file asks for one; with `fallback`, only after the
    /// solves from the start fell short of Success).
    #[serde(skip)]
    pub global: Option<GlobalReport>,
    /// Final spline parameters (physical units).
    pub x: Vec<f64>,
    /// The start's assessment.
    pub start: Option<Assessment>,
    /// The final assessment.
    pub end: Option<Assessment>,
    /// The final motion's assessment at `dt/4` ([`crate::gait::step_check`]); `None` unless
    /// the trial is a Success or Marginal at `dt`.
    pub fine: Option<Assessment>,
    /// The drawn shapes' deepest point below the ground at `dt` ([`crate::gait::penetration`]);
    /// `None` if the rollout failed.
    pub depth: Option<Penetration>,
    /// The same at `dt/4`.
    pub fine_depth: Option<Penetration>,
    /// Why the class at `dt` fell at `dt/4` or by the drawn shapes' depth, when it did.
    pub downgrade: Option<String>,
    /// Classification (confirmed at `dt/4`).
    pub status: TrialStatus,
    /// Solver status.
    #[serde(skip)]
    pub solver_status: Status,
    /// Solver iterations.
    pub iterations: usize,
    /// Wall time (s).
    pub seconds: f64,
    /// Solver evaluation counts.
    #[serde(skip)]
    pub evaluations: Evaluations,
    /// The solver's iteration log.
    #[serde(skip)]
    pub solution: Solution,
}

impl TrialResult {
    /// Final cost (N²·s), +∞ if the final point could not be simulated.
    pub fn cost(&self) -> f64 {
        self.end.as_ref().map_or(f64::INFINITY, |a| a.cost)
    }

    /// Final violation sum, +∞ if the final point could not be simulated.
    pub fn violation_sum(&self) -> f64 {
        self.end.as_ref().map_or(f64::INFINITY, |a| a.sum())
    }
}

/// Classifies a trial (module header).
pub fn classify(start: Option<&Assessment>, end: Option<&Assessment>, tol: f64) -> TrialStatus {
    let Some(end) = end else {
        return TrialStatus::Unimproved;
    };
    let worst = end.max();
    if worst <= tol {
        return TrialStatus::Success;
    }
    if worst <= 10.0 * tol {
        return TrialStatus::Marginal;
    }
    let before = start.map_or(f64::INFINITY, |s| s.sum());
    if end.sum() >= 0.999 * before {
        TrialStatus::Unimproved
    } else {
        TrialStatus::Failure
    }
}

/// A trial's start before any solve.
#[derive(Debug, Clone, PartialEq)]
pub struct TrialStart {
    /// Motion parameters (physical units; without segment start states:
    /// [`Formulation::starting_at`] rolls them out).
    pub x: Vec<f64>,
    /// "hand-made", "zero" or "random" (`[start] kind`), with "±" when the knots were
    /// perturbed by `[trials] spread` (trials k ≥ 2).
    pub origin: String,
}

/// The start of every trial, in trial order (module header): the `[start]` kind's forces
/// (the hand-made ones, zero, or random knot values of `[start] amplitude`, drawn for every
/// trial), plus for trial `k ≥ 2` a uniform perturbation of every knot value by up to
/// `spread`·(half the force range); slopes zero, clamped into the spline box. Drawn up front
/// from one `ChaCha8Rng` seeded with `seed`.
pub fn starts(problem: &Problem, f: &Formulation<'_>, seed: u64) -> Vec<TrialStart> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let given = f.hand_made_start()[..f.reduced().parameters()].to_vec();
    let grid = f.reduced().grid();
    let (k, block) = (grid.knots, grid.per_actuator());
    let (lo, hi) = f.physical_bounds();
    let spread = problem.trials.spread;
    let kind = problem.starts.kind;
    let name = match kind {
        StartKind::Given => "hand-made",
        StartKind::Zero => "zero",
        StartKind::Random => "random",
    };
    let mut draw = |x: &mut [f64], amplitude: f64| {
        for (a, act) in problem.model.actuators.iter().enumerate() {
            let [low, high] = act.control_range();
            let half = 0.5 * (high - low);
            for i in 0..k {
                let j = a * block + i;
                let r: f64 = rng.random_range(-1.0..=1.0);
                x[j] = (x[j] + r * amplitude * half).clamp(lo[j], hi[j]);
            }
        }
    };
    (0..problem.trials.count)
        .map(|t| {
            let mut x = given.clone();
            if kind != StartKind::Given {
                x[..problem.spline_parameters()].fill(0.0);
            }
            if kind == StartKind::Random {
                draw(&mut x, problem.starts.amplitude);
            }
            let perturbed = t > 0 && spread > 0.0;
            if perturbed {
                draw(&mut x, spread);
            }
            TrialStart {
                x,
                origin: format!("{name}{}", if perturbed { "±" } else { "" }),
            }
        })
        .collect()
}

/// Solves per trial at most (first solve and restarts), however productive the restarts.
pub const MAX_SOLVES: usize = 12;

/// Whether a restart's end point `b` is productive against the kept point `a`: both short of
/// the tolerance and `b`'s violation sum at most half of `a`'s. Such a restart is still
/// converging (stalls on the contact kinks cut its progress, not a stationary point of the
/// violation), so it does not count against `[trials] restarts`.
fn halves_violation(a: Option<&Assessment>, b: Option<&Assessment>, tol: f64) -> bool {
    match (a, b) {
        (Some(a), Some(b)) => a.max() > tol && b.max() > tol && b.sum() <= 0.5 * a.sum(),
        _ => false,
    }
}

/// Whether assessment `b` is better than `a`: meeting every constraint within `tol` first, then
/// the lower cost among such points, else the lower violation sum.
pub(super) fn improves(a: Option<&Assessment>, b: Option<&Assessment>, tol: f64) -> bool {
    match (a, b) {
        (_, None) => false,
        (None, Some(_)) => true,
        (Some(a), Some(b)) => match (a.max() <= tol, b.max() <= tol) {
            (true, true) => b.cost < a.cost,
            (false, false) => b.sum() < a.sum(),
            (a_met, _) => !a_met,
        },
    }
}

/// A trial's kept point and running totals while its phases run.
pub(super) struct Kept {
    /// The best point met so far (physical units: spline parameters, then segment start
    /// states until [`finish`] drops them).
    pub(super) x: Vec<f64>,
    /// Its assessment.
    pub(super) end: Option<Assessment>,
    /// Iterations of every phase and solve so far.
    pub(super) iterations: usize,
    /// Evaluations of every phase and solve so far.
    pub(super) evaluations: Evaluations,
    /// The solves' iteration log so far, numbered on ([`append_log`]).
    pub(super) log: Vec<IterationRecord>,
}

impl Kept {
    /// Adds a feasibility phase's iterations and evaluations.
    fn count_phase(&mut self, phase: &Feasibility) {
        self.iterations += phase.iterations;
        self.evaluations.functions += phase.evaluations.functions;
        self.evaluations.derivatives += phase.evaluations.derivatives;
    }

    /// Adds a solve's (or the shaping solves') iterations and evaluations.
    pub(super) fn count_solves(&mut self, iterations: usize, evaluations: &Evaluations) {
        self.iterations += iterations;
        self.evaluations.functions += evaluations.functions;
        self.evaluations.derivatives += evaluations.derivatives;
        self.evaluations.hessians += evaluations.hessians;
    }
}

/// Solves one trial from physical start `x0`: the feasibility phase first when the problem asks
/// for it ([`crate::gait::feasibility`]), then the shaping solves when the problem has shaping
/// rows, then the SQP solve (and restarts) from their end point; the best point met (by
/// `improves`) is the trial's result.
pub fn solve_trial(
    problem: &Problem,
    f: &Formulation<'_>,
    trial: usize,
    x0: &[f64],
    options: &Options,
) -> TrialResult {
    let clock = Instant::now();
    let mut nlp = f.starting_at(x0);
    let start = assess(f, nlp.hand_made_start());
    let mut kept = Kept {
        x: nlp.hand_made_start().to_vec(),
        end: start.clone(),
        iterations: 0,
        evaluations: Evaluations::default(),
        log: Vec::new(),
    };
    if problem.trials.feasibility_first {
        let phase = feasibility_phase(problem, f, &nlp, options, &mut kept);
        nlp = f.starting_at(&kept.x);
        if !phase.reached {
            // The SQP solve lowers the effort from a feasible point; from a stationary point
            // of the violation it stalls as before (docs/notes/gait.md, feasibility phase).
            let solution = phase_solution(&nlp, &kept, &phase, options, &clock);
            return finish(problem, f, trial, start, kept, solution, &clock);
        }
    }
    let mut shaped_candidate = false;
    if !problem.shaping.is_empty() {
        (nlp, shaped_candidate) = shaping_phase(problem, f, options, &mut kept);
    }
    let solves_start = nlp.hand_made_start().to_vec();
    let mut solution = effort_solves(
        problem,
        f,
        nlp,
        options,
        shaped_candidate,
        &mut kept,
        &clock,
    );
    if needs_rescue(problem, &kept, &solution) {
        solution = rescue(problem, f, trial, &solves_start, options, &mut kept, &clock)
            .unwrap_or(solution);
    }
    finish(problem, f, trial, start, kept, solution, &clock)
}

/// Whether a trial's effort solves ended short of the tolerance on their own (a stationary
/// point of the violation: Infeasible, Stalled, …), not on a budget or an interrupt, without
/// a feasibility phase before them: then the feasibility phase gets its turn ([`rescue`]).
fn needs_rescue(problem: &Problem, kept: &Kept, solution: &Solution) -> bool {
    let short = kept
        .end
        .as_ref()
        .is_none_or(|a| a.max() > problem.trials.tolerance);
    let budget = matches!(
        solution.status,
        Status::IterationLimit | Status::TimeLimit | Status::Interrupted
    );
    short && !budget && !problem.trials.feasibility_first && !problem.interrupt.is_raised()
}

/// The feasibility rescue: the SQP's ℓ1 merit can stall far from the rows (its penalty weight
/// grows without bound where the rollout is violently nonlinear) where Levenberg–Marquardt on
/// the violations alone, a trust region, still reaches them (docs/notes/gait.md, pogo_jump
/// trial 6). The feasibility phase runs from `from`, the point the effort solves started at,
/// and when it reaches its target the effort solves run again from its end point, which is
/// kept unless a later point is better. `None` when the phase stopped short (the kept point
/// stays, and the last solve's solution with it).
fn rescue(
    problem: &Problem,
    f: &Formulation<'_>,
    trial: usize,
    from: &[f64],
    options: &Options,
    kept: &mut Kept,
    clock: &Instant,
) -> Option<Solution> {
    if options.verbosity >= 1 {
        options.log.line(&format!(
            "trial {trial}: the solves stopped short of the rows; feasibility phase from their start"
        ));
    }
    let phase = feasibility_phase(problem, f, &f.starting_at(from), options, kept);
    if !phase.reached {
        return None;
    }
    let nlp = f.starting_at(&kept.x);
    Some(effort_solves(problem, f, nlp, options, true, kept, clock))
}

/// The feasibility phase (module header) from `nlp`'s start: the key-time continuation
/// stages, then Levenberg–Marquardt on the task's violations from their end point, whose end
/// point replaces the kept one when it `improves` it. Returns the last phase's report.
fn feasibility_phase(
    problem: &Problem,
    f: &Formulation<'_>,
    nlp: &Formulation<'_>,
    options: &Options,
    kept: &mut Kept,
) -> Feasibility {
    let tol = problem.trials.tolerance;
    let settings = FeasibilitySettings {
        target: FEASIBILITY_TARGET * tol,
        max_iterations: options.max_iterations,
        max_time: options.max_time.unwrap_or(f64::INFINITY),
        log: if options.verbosity >= 1 {
            options.log.clone()
        } else {
            LogTarget::default()
        },
    };
    let params = &nlp.hand_made_start()[..f.reduced().parameters()];
    let mut current = params.to_vec();
    for stage in stage_problems(problem, params, problem.trials.continuation_stages) {
        if problem.interrupt.is_raised() {
            break;
        }
        let staged = Formulation::new(&stage).starting_at(&current);
        let mut z0 = vec![0.0; staged.dims().n];
        staged.start(&mut z0);
        let phase = restore(&staged, &z0, &settings);
        kept.count_phase(&phase);
        // Spline parameters only: the stages' shooting segments end at different steps,
        // so their start states are rolled out afresh.
        current = staged.physical(&phase.z);
        current.truncate(params.len());
    }
    let nlp = f.starting_at(&current);
    let mut z0 = vec![0.0; nlp.dims().n];
    nlp.start(&mut z0);
    let phase = restore(&nlp, &z0, &settings);
    kept.count_phase(&phase);
    let x_phase = nlp.physical(&phase.z);
    let end_phase = assess(f, &x_phase);
    if improves(kept.end.as_ref(), end_phase.as_ref(), tol) {
        (kept.x, kept.end) = (x_phase, end_phase);
    }
    phase
}

/// The solution reported for a trial whose feasibility phase stopped short of its target
/// (no SQP solve): Stalled, or IterationLimit when the phase used up its iterations; at the
/// kept point `nlp` starts from, with the trial's counts so far.
fn phase_solution(
    nlp: &Formulation<'_>,
    kept: &Kept,
    phase: &Feasibility,
    options: &Options,
    clock: &Instant,
) -> Solution {
    let status = if phase.iterations >= options.max_iterations {
        Status::IterationLimit
    } else {
        Status::Stalled
    };
    Solution {
        status,
        x: nlp.scaled(&kept.x),
        lambda: Vec::new(),
        z: Vec::new(),
        objective: kept.end.as_ref().map_or(f64::NAN, |a| a.cost),
        constraints: Vec::new(),
        max_violation: phase.max_violation,
        optimality: f64::NAN,
        iterations: phase.iterations,
        evaluations: kept.evaluations,
        seconds: clock.elapsed().as_secs_f64(),
        log: Vec::new(),
    }
}

/// The shaping solves ([`crate::gait::shaping`]) from the kept point's spline parameters.
/// Their iteration log opens the trial's. Returns the formulation starting at their end point
/// and whether that end point is a candidate (staged shaping): then it has become the kept
/// point.
fn shaping_phase<'p>(
    problem: &Problem,
    f: &Formulation<'p>,
    options: &Options,
    kept: &mut Kept,
) -> (Formulation<'p>, bool) {
    let tol = problem.trials.tolerance;
    let shaped = shape(problem, &kept.x[..f.reduced().parameters()], tol, options);
    kept.count_solves(shaped.iterations, &shaped.evaluations);
    kept.log = shaped.log;
    let nlp = f.starting_at(&shaped.x);
    // The staged shaping's end point meets the task's rows when its last stage is met: a
    // candidate like the feasibility phase's, replaced only by a better one.
    let candidate = problem.trials.shaping_stages > 0;
    if candidate {
        (kept.x, kept.end) = (
            nlp.hand_made_start().to_vec(),
            assess(f, nlp.hand_made_start()),
        );
    }
    (nlp, candidate)
}

/// The effort-lowering SQP solves from `nlp`'s start (module header): the first solve, then
/// restarts from the kept point while they are productive, and one polish of a cheaper point
/// short of the tolerance. Each end point replaces the kept one when it `improves` it (the
/// first solve's always, unless a phase before it left a candidate), and its iteration log
/// is appended to the trial's. With `kept_candidate` (a phase before them left the kept point)
/// the first solve's end point must improve on it too. Returns the last solve's solution.
pub(super) fn effort_solves<'p>(
    problem: &Problem,
    f: &Formulation<'p>,
    mut nlp: Formulation<'p>,
    options: &Options,
    kept_candidate: bool,
    kept: &mut Kept,
    clock: &Instant,
) -> Solution {
    let tol = problem.trials.tolerance;
    let mut remaining = options.clone();
    let mut polished = false;
    let mut last: Option<Solution> = None;
    let mut unproductive = 0;
    for attempt in 0..MAX_SOLVES {
        if let Some(limit) = options.max_time {
            remaining.max_time = Some((limit - clock.elapsed().as_secs_f64()).max(0.0));
        }
        let solution = solve(&nlp, &remaining);
        kept.count_solves(solution.iterations, &solution.evaluations);
        append_log(&mut kept.log, &solution.log);
        let x_solved = nlp.physical(&solution.x);
        let end_solved = assess(f, &x_solved);
        // Without a feasibility phase the first solve's end point is the trial's result even
        // if it is worse than the start (classified Unimproved); later points must improve.
        let first = attempt == 0 && !problem.trials.feasibility_first && !kept_candidate;
        // A solve that ends short of the tolerance at a lower effort than a kept point that
        // meets it is re-solved once from its own end point (a fresh quasi-Newton model often
        // brings such a point back onto the rows); the kept point stays unless beaten.
        let cheaper_unmet = match (kept.end.as_ref(), end_solved.as_ref()) {
            (Some(a), Some(b)) => a.max() <= tol && b.max() > tol && b.cost < a.cost,
            _ => false,
        };
        let polish = (!polished
            && !first
            && cheaper_unmet
            && !matches!(solution.status, Status::TimeLimit | Status::Interrupted))
        .then(|| x_solved.clone());
        let productive =
            attempt > 0 && halves_violation(kept.end.as_ref(), end_solved.as_ref(), tol);
        if first || improves(kept.end.as_ref(), end_solved.as_ref(), tol) {
            (kept.x, kept.end) = (x_solved, end_solved);
        }
        if attempt > 0 && !productive {
            unproductive += 1;
        }
        // A restart drops the quasi-Newton model, which stalls on the kinks of the contact
        // dynamics; a solve stopped by a budget is not restarted, and only restarts that do
        // not halve the violation count against `[trials] restarts`.
        let budget = matches!(
            solution.status,
            Status::IterationLimit | Status::TimeLimit | Status::Interrupted
        );
        last = Some(solution);
        if let Some(from) = polish {
            polished = true;
            nlp = f.starting_at(&from);
            continue;
        }
        if budget
            || unproductive >= problem.trials.restarts
            || kept.end.as_ref().is_some_and(|a| a.max() <= tol)
        {
            break;
        }
        nlp = f.starting_at(&kept.x);
    }
    last.expect("at least one solve")
}

/// The trial's result: the kept point cut to its spline parameters, classified (module
/// header) and confirmed at `dt/4` ([`confirm`]), with the last solve's `solution` carrying
/// the trial's whole iteration log.
pub(super) fn finish(
    problem: &Problem,
    f: &Formulation<'_>,
    trial: usize,
    start: Option<Assessment>,
    kept: Kept,
    mut solution: Solution,
    clock: &Instant,
) -> TrialResult {
    let tol = problem.trials.tolerance;
    let Kept {
        mut x,
        end,
        iterations,
        evaluations,
        log,
    } = kept;
    solution.log = log;
    x.truncate(f.reduced().parameters());
    let check = confirm(
        problem,
        &x,
        end.as_ref(),
        classify(start.as_ref(), end.as_ref(), tol),
        tol,
    );
    let depth = judge(problem, &x, check.status);
    let downgrade = match (check.downgrade, depth.downgrade) {
        (Some(a), Some(b)) => Some(format!("{a}; {b}")),
        (a, b) => a.or(b),
    };
    TrialResult {
        trial,
        origin: String::new(),
        global: None,
        x,
        start,
        end,
        fine: check.fine,
        depth: depth.coarse,
        fine_depth: depth.fine,
        downgrade,
        status: depth.status,
        solver_status: solution.status,
        iterations,
        seconds: clock.elapsed().as_secs_f64(),
        evaluations,
        solution,
    }
}

/// Appends a solve's iteration log to a trial's, numbering and timing it on from the end.
pub(super) fn append_log(log: &mut Vec<IterationRecord>, more: &[IterationRecord]) {
    let offset = log.last().map_or(0, |r| r.iter + 1);
    let elapsed = log.last().map_or(0.0, |r| r.elapsed);
    log.extend(more.iter().cloned().map(|mut r| {
        r.iter += offset;
        r.elapsed += elapsed;
        r
    }));
}

/// Solves trials `which` (1-based; all when `None`) in parallel. Each trial's solver log goes
/// to its own buffer, written to `options.log` in trial order and followed by the trial's line
/// (number, status, cost, time); without a solver log (verbosity 0) the line is written as soon
/// as the trial finishes. On a terminal a status line counts the finished trials. A single
/// trial logs live.
pub fn run_trials(
    problem: &Problem,
    seed: u64,
    which: Option<usize>,
    options: &Options,
) -> Vec<TrialResult> {
    let f = Formulation::new(problem);
    let all = starts(problem, &f, seed);
    let chosen: Vec<usize> = match which {
        Some(k) => vec![k],
        None => (1..=all.len()).collect(),
    };
    let effort = ObjectiveUnit::new("effort", "N²·s", f.objective_scale());
    let progress = Progress::new(&options.log, chosen.len());
    let trial_options = |k: usize, out: Option<&Buffer>| {
        let mut o = options.clone();
        o.log.objective = effort.clone();
        o.log.stage = format!("trial {k}/{}", all.len());
        if let Some(buffer) = out {
            (o.log.out, o.log.terminal) = (Some(buffer.writer()), false);
        }
        o
    };
    if let [k] = chosen[..] {
        let options = trial_options(k, None);
        let result = run_trial(problem, &f, k, &all[k - 1], seed, &options);
        progress.finished(0, &result, String::new());
        return vec![result];
    }
    chosen
        .par_iter()
        .enumerate()
        .map(|(i, &k)| {
            let buffer = Buffer::default();
            let options = trial_options(k, Some(&buffer));
            let result = run_trial(problem, &f, k, &all[k - 1], seed, &options);
            progress.finished(i, &result, buffer.text());
            result
        })
        .collect()
}

/// Trial `trial` from `start`, with the file's global phase ([`crate::gait::global`];
/// progress lines with a solver log) if it has one. By default the phase leads: it runs from
/// the start and the solves run from its best candidate, at the phase's coarsened step first
/// when it has one ([`solve_stepped`]). With `[global] fallback = true`
/// the solves run from the start itself first, and the phase only when they end short of
/// Success; if its best candidate differs from the start (it scored better), the solves run
/// again from it and the better end counts ([`best`]). The trial's time includes every phase.
///
/// Why a file would ask for the fallback order: where the start already meets most rows (a
/// servo character's held pose meets every rest row), the phase's fitness is not lowered by a
/// hop, and its best candidate can be worse for the SQP than the start: biped_hop trial 2
/// solved from its start (Success, 74.9 s CPU) but failed from the phase's best (fitness
/// 0.13 % below the start's, effort 8.5e3 N²·s against 1.5e2; 298.6 s CPU; docs/notes/gait.md).
/// Where random starts tumble (the Luxo), the solves from the start fail after minutes and
/// the phase must lead.
fn run_trial(
    problem: &Problem,
    f: &Formulation<'_>,
    trial: usize,
    start: &TrialStart,
    seed: u64,
    options: &Options,
) -> TrialResult {
    let Some(settings) = problem.global.as_ref() else {
        let mut local = solve_trial(problem, f, trial, &start.x, options);
        local.origin = start.origin.clone();
        return local;
    };
    let log = (options.verbosity >= 1).then_some(&options.log);
    if !settings.fallback {
        let global = search(problem, settings, &start.x, seed, trial, log);
        let mut result = solve_stepped(problem, f, trial, &global.x, options, settings.coarsening);
        result.origin = format!("{}+CMA", start.origin);
        result.seconds += global.seconds;
        result.global = Some(global);
        return result;
    }
    let k = settings.coarsening;
    let mut local = solve_stepped(problem, f, trial, &start.x, options, k);
    local.origin = start.origin.clone();
    if local.status == TrialStatus::Success {
        return local;
    }
    let global = search(problem, settings, &start.x, seed, trial, log);
    let mut spent = local.seconds + global.seconds;
    let mut result = if global.x == start.x {
        local
    } else {
        let mut again = solve_stepped(problem, f, trial, &global.x, options, k);
        again.origin = format!("{}+CMA", start.origin);
        spent += again.seconds;
        let mut pair = vec![local, again];
        let k = best(&pair).unwrap_or(0);
        pair.swap_remove(k)
    };
    result.seconds = spent;
    result.global = Some(global);
    result
}

/// What parallel trials show while they run (see [`run_trials`]).
struct Progress<'a> {
    log: &'a LogTarget,
    count: usize,
    clock: Instant,
    state: std::sync::Mutex<ProgressState>,
}

#[derive(Default)]
struct ProgressState {
    finished: usize,
    /// The next trial (0-based among those run) whose buffered log is due.
    next_log: usize,
    /// Buffered logs (and their trial lines) of trials that finished before an earlier one.
    waiting: std::collections::BTreeMap<usize, (String, String)>,
    /// Whether the status line is on screen.
    status_shown: bool,
}

impl<'a> Progress<'a> {
    fn new(log: &'a LogTarget, count: usize) -> Self {
        Progress {
            log,
            count,
            clock: Instant::now(),
            state: Default::default(),
        }
    }

    /// Trial `index` (0-based among those run) finished with `result`; `text` is its log.
    fn finished(&self, index: usize, result: &TrialResult, text: String) {
        let Ok(mut state) = self.state.lock() else {
            return;
        };
        if state.status_shown {
            self.log.raw("\r\x1b[2K");
            state.status_shown = false;
        }
        state.finished += 1;
        let line = trial_line(result, state.finished, self.count);
        if text.is_empty() {
            // Nothing buffered: the line at once.
            self.log.line(&line);
        }
        state.waiting.insert(index, (text, line));
        while let Some((text, line)) = {
            let next = state.next_log;
            state.waiting.remove(&next)
        } {
            if !text.is_empty() {
                self.log.raw(&text);
                self.log.line(&line);
            }
            state.next_log += 1;
        }
        if self.log.terminal && state.finished < self.count {
            self.log.raw(&format!(
                "  {}/{} trials finished, {:.0} s",
                state.finished,
                self.count,
                self.clock.elapsed().as_secs_f64()
            ));
            state.status_shown = true;
        }
    }
}

/// One finished trial as a line: "trial 3 (2/8 done): Success, cost 31.5 N²·s, ...".
fn trial_line(r: &TrialResult, finished: usize, count: usize) -> String {
    format!(
        "trial {} ({finished}/{count} done): {:?}, cost {:.6} N²·s, violation sum {:.2e}, \
         {} iterations, {:.1} s",
        r.trial,
        r.status,
        r.cost(),
        r.violation_sum(),
        r.iterations,
        r.seconds
    )
}

/// Index of the best trial: the lowest cost among the best class present (Success, then
/// Marginal), else the lowest violation sum.
pub fn best(results: &[TrialResult]) -> Option<usize> {
    let rank = |r: &TrialResult| match r.status {
        TrialStatus::Success => 0,
        TrialStatus::Marginal => 1,
        _ => 2,
    };
    (0..results.len()).min_by(|&a, &b| {
        let (ra, rb) = (&results[a], &results[b]);
        let key = |r: &TrialResult| {
            if rank(r) < 2 {
                r.cost()
            } else {
                r.violation_sum()
            }
        };
        rank(ra)
            .cmp(&rank(rb))
            .then(key(ra).total_cmp(&key(rb)))
            .then(ra.trial.cmp(&rb.trial))
    })
}

/// The largest violation of an assessment as table text ("-" when there is none).
fn max_text(a: Option<&Assessment>) -> String {
    a.map_or("-".to_string(), |a| format!("{:.2e}", a.max()))
}

/// The drawn shapes' deepest point below the ground as table text in mm ("-" when the rollout
/// failed).
fn depth_text(p: Option<&Penetration>) -> String {
    p.map_or("-".to_string(), |p| format!("{:.2}", 1e3 * p.deepest.depth))
}

/// The larger excess of the shapes' depth over the contact points' at `dt` and `dt/4` as table
/// text in mm ([`crate::gait::penetration`]; "-" when neither rollout ran).
fn excess_text(r: &TrialResult) -> String {
    [r.depth, r.fine_depth]
        .iter()
        .flatten()
        .map(|p| p.excess.depth)
        .reduce(f64::max)
        .map_or("-".to_string(), |d| format!("{:.2}", 1e3 * d))
}

/// The table of the seed's Table 3.7 as text, with the largest violation at the file's step
/// and at `dt/4` ([`crate::gait::step_check`]), the drawn shapes' deepest point below the
/// ground at both and its largest excess over the contact points' ([`crate::gait::penetration`],
/// mm), followed by the reason of every class that fell at `dt/4` or by that excess.
pub fn table(results: &[TrialResult], tol: f64) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:>5}  {:<14}  {:>12}  {:>8}  {:>12}  {:>9}  {:>9}  {:>8}  {:>8}  {:>9}  {:>8}  {:>8}  {:>5}  {:<10}  solver",
        "trial",
        "start",
        "cost N²s",
        "violated",
        "sum viol.",
        "max dt",
        "max dt/4",
        "depth mm",
        "dt/4 mm",
        "beyond mm",
        "global s",
        "time s",
        "iter",
        "status"
    );
    for r in results {
        let violated = r
            .end
            .as_ref()
            .map_or("-".to_string(), |a| a.violated(tol).to_string());
        let _ = writeln!(
            s,
            "{:>5}  {:<14}  {:>12.4}  {:>8}  {:>12.3e}  {:>9}  {:>9}  {:>8}  {:>8}  {:>9}  {:>8}  {:>8.2}  {:>5}  {:<10}  {:?}",
            r.trial,
            r.origin,
            r.cost(),
            violated,
            r.violation_sum(),
            max_text(r.end.as_ref()),
            max_text(r.fine.as_ref()),
            depth_text(r.depth.as_ref()),
            depth_text(r.fine_depth.as_ref()),
            excess_text(r),
            r.global
                .as_ref()
                .map_or("-".to_string(), |g| format!("{:.2}", g.seconds)),
            r.seconds,
            r.iterations,
            format!("{:?}", r.status),
            r.solver_status
        );
    }
    for r in results {
        if let Some(why) = &r.downgrade {
            let _ = writeln!(s, "trial {}: {why}", r.trial);
        }
    }
    s
}

/// The table as JSON rows for `result.json`.
pub fn table_json(results: &[TrialResult], tol: f64) -> serde_json::Value {
    serde_json::Value::Array(
        results
            .iter()
            .map(|r| {
                serde_json::json!({
                    "trial": r.trial,
                    "start": r.origin,
                    "cost": r.cost(),
                    "violated": r.end.as_ref().map(|a| a.violated(tol)),
                    "violation_sum": r.violation_sum(),
                    "max_violation": r.end.as_ref().map(|a| a.max()),
                    "max_violation_quarter_step": r.fine.as_ref().map(|a| a.max()),
                    "depth": r.depth,
                    "depth_quarter_step": r.fine_depth,
                    "downgrade": r.downgrade,
                    "global": r.global.as_ref().map(|g| serde_json::json!({
                        "seconds": g.seconds,
                        "rollouts": g.evaluations,
                        "generations": g.generations,
                        "fitness": g.fitness,
                        "stop": format!("{:?}", g.stop),
                    })),
                    "seconds": r.seconds,
                    "iterations": r.iterations,
                    "status": format!("{:?}", r.status),
                    "solver_status": format!("{:?}", r.solver_status),
                })
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gait::golden_problem as golden;
    use crate::gait::spec::GlobalSettings;

    fn a(v: &[f64]) -> Assessment {
        Assessment {
            cost: 1.0,
            violations: v.to_vec(),
        }
    }

    /// Starts are reproducible, distinct and within the spline box; trial 1 is the hand-made one.
    #[test]
    fn starts_are_seeded_and_bounded() {
        let mut p = golden("luxo_leap_short");
        p.trials.count = 5;
        let f = Formulation::new(&p);
        let a = starts(&p, &f, 8);
        assert_eq!(a, starts(&p, &f, 8));
        assert_ne!(a[1], starts(&p, &f, 9)[1]);
        assert_eq!(a[0].x, f.hand_made_start()[..f.reduced().parameters()]);
        assert_eq!(
            (a[0].origin.as_str(), a[1].origin.as_str()),
            ("hand-made", "hand-made±")
        );
        let (lo, hi) = f.physical_bounds();
        for s in &a {
            for j in 0..s.x.len() {
                assert!(s.x[j] >= lo[j] && s.x[j] <= hi[j]);
            }
        }
        assert!(a[1] != a[2]);
        // Zero starts: trial 1 exactly zero; random starts: every trial drawn, within the
        // amplitude.
        let mut p = p.clone();
        p.starts.kind = StartKind::Zero;
        let z = starts(&p, &Formulation::new(&p), 8);
        assert!(z[0].x.iter().all(|&v| v == 0.0));
        assert_eq!(z[0].origin, "zero");
        p.starts = crate::gait::spec::StartSettings {
            kind: StartKind::Random,
            amplitude: 0.2,
        };
        p.trials.spread = 0.0;
        let r = starts(&p, &Formulation::new(&p), 8);
        assert!(r[0].x.iter().any(|&v| v != 0.0));
        assert_eq!(r[1].origin, "random");
        let grid = p.knot_grid();
        for (a, act) in p.model.actuators.iter().enumerate() {
            let bound = 0.2 * 0.5 * (act.bounds[1] - act.bounds[0]);
            for i in 0..grid.knots {
                assert!(r[0].x[a * grid.per_actuator() + i].abs() <= bound);
            }
        }
    }

    /// A short solve gives bit-identical results on one thread and on two.
    #[test]
    fn results_do_not_depend_on_the_thread_count() {
        let mut p = golden("pogo_crouch_short");
        p.trials.count = 2;
        let options = Options {
            max_iterations: 4,
            verbosity: 0,
            ..Options::default()
        };
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| run_trials(&p, 8, None, &options))
        };
        let (one, two) = (run(1), run(2));
        for (a, b) in one.iter().zip(&two) {
            assert_eq!(a.x, b.x);
            assert_eq!(a.iterations, b.iterations);
            assert_eq!(a.status, b.status);
        }
        assert_eq!(one.len(), 2);
    }

    /// Parallel trials write their solver logs in trial order, each whole and followed by its
    /// trial's line; without solver logs, one line per trial as it finishes. Every record
    /// carries its trial's stage.
    #[test]
    fn parallel_trials_log_in_order_and_report_each_trial() {
        let mut p = golden("pogo_crouch_short");
        p.trials.count = 3;
        let run = |verbosity: u8| {
            let buffer = Buffer::default();
            let options = Options {
                max_iterations: 3,
                verbosity,
                log: LogTarget::to(buffer.writer(), false),
                ..Options::default()
            };
            let results = rayon::ThreadPoolBuilder::new()
                .num_threads(2)
                .build()
                .unwrap()
                .install(|| run_trials(&p, 8, None, &options));
            (results, buffer.text())
        };
        let (results, text) = run(1);
        let blocks: Vec<&str> = text
            .lines()
            .filter(|l| l.contains(" variables,") || l.contains(" done): "))
            .map(|l| l.split([':', '(']).next().unwrap().trim_end())
            .collect();
        let expected = [
            "trial 1/3",
            "trial 1",
            "trial 2/3",
            "trial 2",
            "trial 3/3",
            "trial 3",
        ];
        assert_eq!(blocks, expected, "{text}");
        for r in &results {
            let stage = format!("trial {}/3", r.trial);
            assert!(r.solution.log.iter().all(|rec| rec.stage == stage));
        }
        let (_, text) = run(0);
        assert_eq!(text.lines().count(), 3, "{text}");
        for (j, line) in text.lines().enumerate() {
            assert!(line.contains(&format!("({}/3 done): ", j + 1)), "{text}");
        }
    }

    /// With the feasibility phase (and continuation) first, the short pogo jump raised to
    /// 0.5 m, which the hand-made start misses, ends a Success.
    #[test]
    fn feasibility_phase_then_sqp_solves_a_raised_short_pogo_jump() {
        let mut p = golden("pogo_jump_short");
        for c in &mut p.constraints {
            c.lower = 0.5;
        }
        p.trials.feasibility_first = true;
        p.trials.continuation_stages = 3;
        let options = Options {
            max_iterations: 40,
            verbosity: 0,
            ..Options::default()
        };
        let r = &run_trials(&p, 8, Some(1), &options)[0];
        let start = r.start.as_ref().unwrap();
        assert!(start.max() > 10.0 * p.trials.tolerance, "{}", start.max());
        assert_eq!(r.status, TrialStatus::Success, "{:?}", r.end);
    }

    /// The short pogo jump raised to 0.6 m from random knots (trial 4 at seed 8): the effort
    /// solves alone (first solve and restarts) stop Infeasible short of the rows; the
    /// feasibility rescue then reaches them and the trial ends a Success.
    #[test]
    fn feasibility_rescue_solves_what_the_effort_solves_leave_infeasible() {
        let mut p = golden("pogo_jump_short");
        for c in &mut p.constraints {
            c.lower = 0.6;
        }
        p.starts.kind = StartKind::Random;
        p.trials.count = 4;
        let options = Options {
            max_iterations: 100,
            verbosity: 0,
            ..Options::default()
        };
        let f = Formulation::new(&p);
        let x0 = starts(&p, &f, 8)[3].x.clone();
        let mut kept = Kept {
            x: x0.clone(),
            end: assess(&f, &x0),
            iterations: 0,
            evaluations: Evaluations::default(),
            log: Vec::new(),
        };
        let alone = effort_solves(
            &p,
            &f,
            f.starting_at(&x0),
            &options,
            false,
            &mut kept,
            &Instant::now(),
        );
        let short = kept.end.as_ref().unwrap().max();
        assert!(short > 10.0 * p.trials.tolerance, "{short}");
        assert!(needs_rescue(&p, &kept, &alone), "{:?}", alone.status);
        let r = solve_trial(&p, &f, 4, &x0, &options);
        assert_eq!(r.status, TrialStatus::Success, "{:?}", r.end);
    }

    /// The shipped high pogo jump (both ends 1.0 m up at t = 1 s, twice pogo_jump's), trial 7
    /// at the default seed from random knots and its global phase: a Success at dt and dt/4.
    #[test]
    fn the_high_pogo_jump_solves_from_a_random_start() {
        let path = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("problems/gait/pogo_jump_high.toml");
        let p = crate::gait::load(&path).unwrap();
        assert!(p.constraints.iter().all(|c| c.lower >= 1.0));
        let options = Options {
            verbosity: 0,
            ..p.solver.clone()
        };
        let r = &run_trials(&p, 0, Some(7), &options)[0];
        assert_eq!(r.status, TrialStatus::Success, "{:?} {:?}", r.end, r.fine);
        assert!(r.fine.as_ref().unwrap().max() <= p.trials.tolerance);
    }

    /// The global phase's order: by default it runs before every trial's solves; with
    /// `fallback` a trial whose solves from its start end a Success never runs it, and the end
    /// is the one solved from the start.
    #[test]
    fn a_fallback_global_phase_runs_only_after_solves_that_fall_short() {
        let mut p = golden("pogo_crouch_short");
        let options = Options {
            max_iterations: 60,
            verbosity: 0,
            ..Options::default()
        };
        let alone = &run_trials(&p, 8, Some(1), &options)[0];
        assert_eq!(alone.status, TrialStatus::Success, "{:?}", alone.end);
        let mut settings = GlobalSettings {
            generations: 3,
            evaluations: 100,
            population: Some(6),
            sigma: 0.3,
            staged: false,
            fallback: false,
            coarsening: 1,
        };
        p.global = Some(settings);
        let led = &run_trials(&p, 8, Some(1), &options)[0];
        assert!(
            led.global.is_some() && led.origin.ends_with("+CMA"),
            "{}",
            led.origin
        );
        settings.fallback = true;
        p.global = Some(settings);
        let after = &run_trials(&p, 8, Some(1), &options)[0];
        assert!(after.global.is_none(), "{}", after.origin);
        assert_eq!((&after.x, &after.origin), (&alone.x, &alone.origin));
    }

    /// Meeting the tolerance beats not meeting it; then lower cost, else lower violation sum.
    #[test]
    fn improvement_prefers_feasible_then_cheap_then_less_violated() {
        let tol = 1e-3;
        let with = |cost: f64, v: &[f64]| Assessment {
            cost,
            violations: v.to_vec(),
        };
        let met = with(5.0, &[5e-4, 0.0]);
        let cheaper = with(4.0, &[9e-4, 1e-4]);
        let unmet = with(1.0, &[2e-3, 0.0]);
        let less = with(9.0, &[1.5e-3, 0.0]);
        assert!(improves(Some(&unmet), Some(&met), tol));
        assert!(!improves(Some(&met), Some(&unmet), tol));
        assert!(improves(Some(&met), Some(&cheaper), tol));
        assert!(!improves(Some(&cheaper), Some(&met), tol));
        assert!(improves(Some(&unmet), Some(&less), tol));
        assert!(!improves(Some(&less), Some(&unmet), tol));
        assert!(improves(None, Some(&unmet), tol));
        assert!(!improves(Some(&unmet), None, tol));
    }

    /// Shaping rows add a first solve but are not part of the trial's assessment: an
    /// unreachable one (the head 100 m up) leaves the trial judged on the task's rows.
    #[test]
    fn shaping_rows_guide_the_first_solve_only() {
        let plain = golden("pogo_crouch_short");
        let mut shaped = plain.clone();
        let mut row = plain.constraints[0].clone();
        row.time = 0.25;
        row.step /= 2;
        row.lower = 100.0;
        row.upper = f64::INFINITY;
        shaped.shaping.push(row);
        let options = Options {
            max_iterations: 4,
            verbosity: 0,
            ..Options::default()
        };
        let a = &run_trials(&plain, 8, Some(1), &options)[0];
        let b = &run_trials(&shaped, 8, Some(1), &options)[0];
        let rows = |r: &TrialResult| r.end.as_ref().map(|e| e.violations.len());
        assert_eq!(rows(b), Some(plain.constraints.len()));
        assert_eq!(rows(a), rows(b));
        assert!(
            b.iterations > a.iterations,
            "{} vs {}",
            b.iterations,
            a.iterations
        );
        assert_ne!(a.x, b.x);
    }

    /// With staged shaping the trial ends at a point meeting the task's rows (the staged
    /// end point is kept unless a later one is better), judged on the task's rows alone.
    #[test]
    fn staged_shaping_trial_meets_the_task() {
        let mut p = golden("pogo_crouch_short");
        let mut row = p.constraints[0].clone();
        (row.time, row.step) = (0.25, (0.25 / p.dt).round() as usize);
        (row.lower, row.upper) = (0.2, 0.3);
        p.shaping = vec![row];
        p.trials.shaping_stages = 2;
        let options = Options {
            max_iterations: 40,
            verbosity: 0,
            ..Options::default()
        };
        let r = &run_trials(&p, 8, Some(2), &options)[0];
        let end = r.end.as_ref().unwrap();
        assert_eq!(end.violations.len(), p.constraints.len());
        assert_eq!(r.status, TrialStatus::Success, "{:?}", end.violations);
    }

    /// A restart is productive only if both points miss the tolerance and the violation sum
    /// at least halves (trial 7 of pogo_jump at seed 8: 0.2258 → 0.0225 m).
    #[test]
    fn productive_restarts_halve_an_unmet_violation() {
        let tol = 1e-3;
        let kept = a(&[0.2, 0.0258]);
        assert!(halves_violation(
            Some(&kept),
            Some(&a(&[0.0113, 0.0112])),
            tol
        ));
        assert!(halves_violation(Some(&kept), Some(&a(&[0.1, 0.012])), tol));
        assert!(!halves_violation(Some(&kept), Some(&a(&[0.1, 0.02])), tol));
        assert!(!halves_violation(Some(&kept), Some(&a(&[5e-4, 0.0])), tol));
        assert!(!halves_violation(Some(&a(&[5e-4])), Some(&a(&[2e-4])), tol));
        assert!(!halves_violation(None, Some(&a(&[0.01])), tol));
        assert!(!halves_violation(Some(&kept), None, tol));
    }

    #[test]
    fn classification_follows_the_tolerances() {
        let tol = 1e-3;
        let start = a(&[0.5, 0.2]);
        assert_eq!(
            classify(Some(&start), Some(&a(&[1e-3, 0.0])), tol),
            TrialStatus::Success
        );
        assert_eq!(
            classify(Some(&start), Some(&a(&[9e-3, 0.0])), tol),
            TrialStatus::Marginal
        );
        assert_eq!(
            classify(Some(&start), Some(&a(&[0.1, 0.0])), tol),
            TrialStatus::Failure
        );
        assert_eq!(
            classify(Some(&start), Some(&a(&[0.6, 0.1])), tol),
            TrialStatus::Unimproved
        );
        assert_eq!(classify(Some(&start), None, tol), TrialStatus::Unimproved);
    }
}
