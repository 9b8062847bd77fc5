//! Step-size continuation of a trial's solves (`[global] coarsening = k > 1`).
//!
//! The SQP's cost per iteration is a rollout and its exact Jacobian, both linear in the number
//! of RK4 steps, and a stiff contact (the seed's eq. 3.26–3.27) can ask for a step `dt` finer
//! than the one at which the solves find the motion. So a trial whose file coarsens its global
//! phase solves at the phase's step first:
//! ```text
//!   x_k = trial solves at k·dt from the phase's best     (shaping, effort solves, restarts)
//!   x_k meets the task's rows at dt            ⇒  x = x_k
//!   else  x_f = feasibility solve at dt from x_k          (zero objective)
//!         x_f meets them                        ⇒  x = x_f
//!         else  x = the trial's effort solves at dt from the better of x_k, x_f
//! ```
//! The feasibility solve has no objective, so each of its SQP steps is the least change of the
//! parameters that meets the rows' linearization: it moves `x_k` onto the rows at `dt` and
//! keeps the effort it was given at `k·dt` to first order. The trial is then judged at `dt`
//! and confirmed at `dt/4` as every trial is ([`crate::gait::step_check`]); its iterations,
//! evaluations, log and time count both steps' solves.

use std::time::Instant;

use super::formulation::Formulation;
use super::spec::Problem;
use super::step_check::coarsened;
use super::trials::{
    Kept, TrialResult, append_log, assess, effort_solves, finish, improves, solve_trial,
};
use crate::solver::{Options, solve};

/// Solves trial `trial` from physical start `x0` at step `factor·dt` first and then at the
/// file's `dt` (module header); with `factor = 1`, [`solve_trial`] itself.
pub fn solve_stepped(
    problem: &Problem,
    f: &Formulation<'_>,
    trial: usize,
    x0: &[f64],
    options: &Options,
    factor: usize,
) -> TrialResult {
    if factor <= 1 {
        return solve_trial(problem, f, trial, x0, options);
    }
    let clock = Instant::now();
    let tol = problem.trials.tolerance;
    let coarse_problem = coarsened(problem, factor);
    let coarse = solve_trial(
        &coarse_problem,
        &Formulation::new(&coarse_problem),
        trial,
        x0,
        options,
    );
    let start = assess(f, f.starting_at(x0).hand_made_start());
    let from = f.starting_at(&coarse.x);
    let mut kept = Kept {
        x: from.hand_made_start().to_vec(),
        end: assess(f, from.hand_made_start()),
        iterations: coarse.iterations,
        evaluations: coarse.evaluations,
        log: coarse.solution.log.clone(),
    };
    let met = |k: &Kept| k.end.as_ref().is_some_and(|a| a.max() <= tol);
    if met(&kept) || problem.interrupt.is_raised() {
        return finish(problem, f, trial, start, kept, coarse.solution, &clock);
    }
    if options.verbosity >= 1 {
        options.log.line(&format!(
            "trial {trial}: the motion solved at {} s misses the rows at dt = {} s by {:.3e}; feasibility solve at dt",
            coarse_problem.dt,
            problem.dt,
            kept.end.as_ref().map_or(f64::INFINITY, |a| a.max())
        ));
    }
    let nlp = f.starting_at(&kept.x).without_effort();
    let solution = solve(&nlp, options);
    kept.count_solves(solution.iterations, &solution.evaluations);
    append_log(&mut kept.log, &solution.log);
    let x_fine = nlp.physical(&solution.x);
    let end_fine = assess(f, &x_fine);
    if improves(kept.end.as_ref(), end_fine.as_ref(), tol) {
        (kept.x, kept.end) = (x_fine, end_fine);
    }
    if met(&kept) || problem.interrupt.is_raised() {
        return finish(problem, f, trial, start, kept, solution, &clock);
    }
    let nlp = f.starting_at(&kept.x);
    let solution = effort_solves(problem, f, nlp, options, true, &mut kept, &clock);
    finish(problem, f, trial, start, kept, solution, &clock)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gait::golden_problem as golden;
    use crate::gait::trials::{TrialStatus, starts};

    /// The short pogo crouch solved at 2·dt and continued at dt ends a Success judged at the
    /// file's dt (its end is the rollout at dt of its parameters); with factor 1 the
    /// continuation is the plain trial.
    #[test]
    fn a_trial_solved_at_twice_the_step_is_judged_at_dt() {
        let p = golden("pogo_crouch_short");
        let f = Formulation::new(&p);
        let options = Options {
            max_iterations: 60,
            verbosity: 0,
            ..Options::default()
        };
        let x0 = starts(&p, &f, 8)[0].x.clone();
        let r = solve_stepped(&p, &f, 1, &x0, &options, 2);
        assert_eq!(r.status, TrialStatus::Success, "{:?} {:?}", r.end, r.fine);
        let at_dt = assess(&f, &r.x).unwrap();
        assert_eq!(Some(&at_dt), r.end.as_ref());
        assert!(at_dt.max() <= p.trials.tolerance);
        let coarse = coarsened(&p, 2);
        let at_coarse = assess(&Formulation::new(&coarse), &r.x).unwrap();
        // The head's height and speed rows are equalities: their violations differ with the
        // step (the force splines' effort does not: it is integrated in closed form).
        assert_ne!(at_coarse.violations[..2], at_dt.violations[..2]);
        let plain = solve_trial(&p, &f, 1, &x0, &options);
        let same = solve_stepped(&p, &f, 1, &x0, &options, 1);
        assert_eq!((plain.x, plain.iterations), (same.x, same.iterations));
    }
}
