//! The shaping solves that open each trial (`[[task]] shaping = true` rows, `[trials]
//! shaping_stages`): they lead the start to the kind of motion the task implies before the
//! trial's own solves, which use the task's rows alone.
//!
//! Without `shaping_stages` (0) there is one shaped solve: the task's rows and the shaping
//! rows together, minimizing the effort `∫ΣF²dt` (seed eq. 3.1).
//!
//! With `shaping_stages = N ≥ 1` the rows are met in stages of growing horizon: stage `k`
//! holds every row (task or shaping) at times up to `t_k`, the `k`-th distinct shaping time
//! before the task's last row, and the last stage holds all rows. A stage is simulated only to
//! its last row's time. Each stage is a feasibility problem (zero objective: any point meeting
//! its rows is optimal, and the SQP's steps are the least changes that meet their
//! linearization), so the effort plays no part until the trial's own solves. Within a stage
//! the rows' bounds move in `N` steps from the stage's start to the rows' own: with `v` a row's
//! value at the stage's start and `[ℓ, u]` its bounds, step `s = 1…N` asks for
//! ```text
//!   [ℓ + (1 − s/N)·min(v − ℓ, 0),  u + (1 − s/N)·max(v − u, 0)]
//! ```
//! (a homotopy in the bounds, so each step's target is near what the previous step reached;
//! step `N` is the stage itself). A row already met keeps its bounds. A step whose rows are not
//! met within the trial's tolerance is discarded and retried at half the step (twice at most,
//! down to a quarter of `1/N`); if that fails too, the stage ends at the failed step's end
//! point and the next stage starts from there. If the last stage is not met, the stages are
//! run once more from the trial's start with `2N` steps per stage ([`ATTEMPTS`]), and the
//! attempt with the lower violation sum over all rows is kept.

use super::formulation::Formulation;
use super::spec::Problem;
use super::trials::{append_log, assess};
use crate::solver::{Evaluations, IterationRecord, Nlp, Options, solve};

/// What the shaping solves leave: the end point and the work done.
#[derive(Debug, Clone, Default)]
pub struct Shaped {
    /// Spline parameters (physical units) at the end of the last solve.
    pub x: Vec<f64>,
    /// Solver iterations.
    pub iterations: usize,
    /// Evaluation counts.
    pub evaluations: Evaluations,
    /// The solves' iteration log, numbered on.
    pub log: Vec<IterationRecord>,
}

/// `problem` with the bounds of each row moved towards its value `values[i]` by the fraction
/// `1 − w` of its violation there (module header); `w = 1` is `problem` itself.
pub fn relaxed(problem: &Problem, values: &[f64], w: f64) -> Problem {
    let mut p = problem.clone();
    for (c, &v) in p.constraints.iter_mut().zip(values) {
        let keep = 1.0 - w;
        if v < c.lower {
            c.lower += keep * (v - c.lower);
        }
        if v > c.upper {
            c.upper += keep * (v - c.upper);
        }
    }
    p
}

/// Staged shaping attempts per trial: an attempt whose last stage is not met is followed by
/// one from the trial's start with twice the steps per stage (module header).
pub const ATTEMPTS: usize = 2;

/// Runs the shaping solves (module header) from spline parameters `x0` (physical units);
/// `tol` is the trial's tolerance, by which a step's rows count as met.
pub fn shape(problem: &Problem, x0: &[f64], tol: f64, options: &Options) -> Shaped {
    let mut out = Shaped {
        x: x0.to_vec(),
        ..Shaped::default()
    };
    let steps = problem.trials.shaping_stages;
    if steps == 0 {
        out.x = solve_into(&mut out, &problem.shaped(), x0, true, options);
        return out;
    }
    let shaped = problem.shaped();
    let all = Formulation::new(&shaped);
    let mut best: Option<(Vec<f64>, f64)> = None;
    for attempt in 0..ATTEMPTS {
        if problem.interrupt.is_raised() {
            break;
        }
        let x = staged(problem, x0, steps << attempt, tol, options, &mut out);
        let Some(a) = assess(&all, &x) else {
            continue;
        };
        if best.as_ref().is_none_or(|(_, sum)| a.sum() < *sum) {
            best = Some((x, a.sum()));
        }
        if a.max() <= tol {
            break;
        }
    }
    if let Some((x, _)) = best {
        out.x = x;
    }
    out
}

/// One staged attempt from `x0` with `steps` steps per stage (module header), adding the work
/// to `out`; returns its end point.
fn staged(
    problem: &Problem,
    x0: &[f64],
    steps: usize,
    tol: f64,
    options: &Options,
    out: &mut Shaped,
) -> Vec<f64> {
    let mut x = x0.to_vec();
    let horizons = problem.shaping_horizons();
    for horizon in horizons.iter().copied().chain([f64::INFINITY]) {
        if problem.interrupt.is_raised() {
            break;
        }
        let stage = problem.shaped_until(horizon);
        let Some(values) = constraint_values(&Formulation::new(&stage), &x) else {
            x = solve_into(out, &stage, &x, false, options);
            continue;
        };
        // The homotopy in the bounds, its step halved (twice at most) when a step's rows are
        // not met; a step that still fails ends the stage at its end point.
        let (mut w, mut dw) = (0.0, 1.0 / steps as f64);
        while w < 1.0 && !problem.interrupt.is_raised() {
            let target = (w + dw).min(1.0);
            let sub = relaxed(&stage, &values, target);
            let next = solve_into(out, &sub, &x, false, options);
            let met = assess(&Formulation::new(&sub), &next).is_some_and(|a| a.max() <= tol);
            if met || dw <= 0.25 / steps as f64 {
                x = next;
                if !met {
                    break;
                }
                w = target;
            } else {
                dw *= 0.5;
            }
        }
    }
    x
}

/// Solves `problem` (with the effort or without) from spline parameters `x0`, adding the work
/// to `out`; returns the end point's spline parameters (physical units).
fn solve_into(
    out: &mut Shaped,
    problem: &Problem,
    x0: &[f64],
    effort: bool,
    options: &Options,
) -> Vec<f64> {
    let f = Formulation::new(problem).starting_at(x0);
    let nlp = if effort { f } else { f.without_effort() };
    let solution = solve(&nlp, options);
    out.iterations += solution.iterations;
    out.evaluations.functions += solution.evaluations.functions;
    out.evaluations.derivatives += solution.evaluations.derivatives;
    out.evaluations.hessians += solution.evaluations.hessians;
    append_log(&mut out.log, &solution.log);
    let mut x = nlp.physical(&solution.x);
    x.truncate(x0.len());
    x
}

/// The constraint values of the motion of spline parameters `x`, `None` if it cannot be
/// simulated.
fn constraint_values(f: &Formulation<'_>, x: &[f64]) -> Option<Vec<f64>> {
    let nlp = f.reduced();
    let d = nlp.dims();
    let (mut effort, mut c) = (0.0, vec![0.0; d.m]);
    nlp.eval(&x[..d.n], &mut effort, &mut c).ok()?;
    Some(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gait::golden_problem as golden;

    /// Violated bounds move towards the value by the fraction 1 − w; met ones stay.
    #[test]
    fn relaxed_bounds_interpolate_from_the_value_to_the_row() {
        let mut p = golden("pogo_crouch_short");
        let mut row = p.constraints[0].clone();
        (row.lower, row.upper) = (0.3, 0.5);
        p.constraints = vec![row.clone(), row.clone(), row];
        let r = relaxed(&p, &[0.1, 0.9, 0.4], 0.25);
        let b: Vec<(f64, f64)> = r.constraints.iter().map(|c| (c.lower, c.upper)).collect();
        assert!((b[0].0 - 0.15).abs() < 1e-12 && b[0].1 == 0.5, "{b:?}");
        assert!(b[1].0 == 0.3 && (b[1].1 - 0.8).abs() < 1e-12, "{b:?}");
        assert_eq!(b[2], (0.3, 0.5));
        let same = relaxed(&p, &[0.1, 0.9, 0.4], 1.0);
        assert_eq!(same.constraints[0].lower, 0.3);
        assert_eq!(same.constraints[1].upper, 0.5);
    }

    /// Stage horizons are the shaping times before the task's last row, only when staged.
    #[test]
    fn horizons_are_the_shaping_times_before_the_last_row() {
        let mut p = golden("pogo_crouch_short");
        let row = |t: f64| {
            let mut r = p.constraints[0].clone();
            (r.time, r.step) = (t, (t / p.dt).round() as usize);
            r
        };
        p.shaping = vec![row(0.1), row(0.25), row(0.25), row(0.5)];
        assert!(p.shaping_horizons().is_empty());
        p.trials.shaping_stages = 2;
        assert_eq!(p.shaping_horizons(), vec![0.1, 0.25]);
        let stage = p.shaped_until(0.25);
        assert_eq!(stage.constraints.len(), 3);
        assert!(stage.shaping.is_empty());
        assert_eq!(p.shaped_until(f64::INFINITY).constraints.len(), 7);
    }

    /// Without the effort the objective and its gradient are zero; the constraints are kept.
    #[test]
    fn a_problem_without_effort_has_a_zero_objective() {
        let p = golden("pogo_crouch_short");
        let f = Formulation::new(&p);
        let d = f.dims();
        let mut z = vec![0.0; d.n];
        f.start(&mut z);
        let g = |nlp: &Formulation<'_>| {
            let (mut obj, mut c) = (0.0, vec![0.0; d.m]);
            nlp.eval(&z, &mut obj, &mut c).unwrap();
            let (mut grad, mut jac) = (vec![0.0; d.n], vec![0.0; d.jac_nnz]);
            nlp.eval_derivatives(&z, &mut grad, &mut jac).unwrap();
            (obj, c, grad, jac)
        };
        let (a, b) = (g(&f), g(&f.clone().without_effort()));
        assert!(a.0 > 0.0 && a.2.iter().any(|v| *v != 0.0));
        assert_eq!(b.0, 0.0);
        assert!(b.2.iter().all(|v| *v == 0.0));
        assert_eq!((a.1, a.3), (b.1, b.3));
    }

    /// Staged shaping on the short pogo crouch with a shaping row 2 cm above the start's head
    /// height at t = 0.25 s ends at a point meeting the shaping row and the task's rows.
    #[test]
    fn staged_shaping_meets_every_row() {
        let mut p = golden("pogo_crouch_short");
        let f = Formulation::new(&p);
        let x0 = f.hand_made_start()[..f.reduced().parameters()].to_vec();
        let mut row = p.constraints[0].clone();
        (row.time, row.step) = (0.25, (0.25 / p.dt).round() as usize);
        let mut probe = p.clone();
        probe.constraints = vec![row.clone()];
        let v = constraint_values(&Formulation::new(&probe), &x0).unwrap()[0];
        (row.lower, row.upper) = (v + 0.02, f64::INFINITY);
        p.shaping = vec![row];
        p.trials.shaping_stages = 2;
        let options = Options {
            max_iterations: 40,
            verbosity: 0,
            ..Options::default()
        };
        let tol = p.trials.tolerance;
        let out = shape(&p, &x0, tol, &options);
        let all = p.shaped();
        let a = assess(&Formulation::new(&all), &out.x).unwrap();
        assert!(a.max() <= tol, "{:?}", a.violations);
        assert!(out.iterations > 0 && !out.log.is_empty());
    }
}
