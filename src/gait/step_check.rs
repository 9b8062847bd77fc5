//! Step-size honesty: a motion is physically valid only if it meets its rows whatever the
//! integration step. Every trial classified Success or Marginal at the file's step `dt` is
//! rolled out again at `dt/`[`REFINEMENT`] (same force splines, same initial state, same key
//! times, `REFINEMENT`× the RK4 steps) and judged on the task's rows there too:
//! ```text
//!   worst = max(largest violation at dt, largest violation at dt/4)
//!   Success ⇔ worst ≤ tol,   Marginal ⇔ worst ≤ 10·tol,   else Failure
//! ```
//! A trial whose class falls this way keeps the reason ([`StepCheck::downgrade`]). RK4's
//! global error is `O(dt⁴)`, so the refined rollout is within 1/256 of the coarse one's
//! discretization error of the exact motion: a gap between the two bounds how far the coarse
//! motion is from the physical one.

use super::formulation::Formulation;
use super::spec::Problem;
use super::trials::{Assessment, TrialStatus, assess};

/// The refined rollout's step is the file's `dt` divided by this.
pub const REFINEMENT: usize = 4;

/// The outcome of re-simulating a trial's motion at the refined step.
#[derive(Debug, Clone, PartialEq)]
pub struct StepCheck {
    /// The class after the check (never better than the class at `dt`).
    pub status: TrialStatus,
    /// The task's rows at `dt/REFINEMENT`; `None` when the class at `dt` was neither Success
    /// nor Marginal (no check), or the refined rollout failed.
    pub fine: Option<Assessment>,
    /// Why the class fell, when it did.
    pub downgrade: Option<String>,
}

/// `problem` at `dt/factor`: the same key times at `factor`× the steps, single shooting (the
/// motion is one rollout of its parameters).
pub fn refined(problem: &Problem, factor: usize) -> Problem {
    restepped(problem, problem.dt / factor as f64, |n| n * factor)
}

/// `problem` at `factor·dt`: the same key times at `1/factor` of the steps (each a multiple of
/// `factor`, as `[global] coarsening` is validated), single shooting.
pub fn coarsened(problem: &Problem, factor: usize) -> Problem {
    restepped(problem, problem.dt * factor as f64, |n| n / factor)
}

/// `problem` with step `dt` (s), its rows' key steps mapped by `step`, single shooting.
fn restepped(problem: &Problem, dt: f64, step: impl Fn(usize) -> usize) -> Problem {
    let mut p = problem.clone();
    p.dt = dt;
    for c in p.constraints.iter_mut().chain(p.shaping.iter_mut()) {
        c.step = step(c.step);
    }
    p.segments = 1;
    p.shooting_steps.clear();
    p
}

/// The task's rows of the motion with parameters `x` (spline parameters, then the initial state
/// when it is a variable) rolled out at `dt/factor`; `None` if that rollout fails.
pub fn assess_refined(problem: &Problem, x: &[f64], factor: usize) -> Option<Assessment> {
    let fine = refined(problem, factor);
    let f = Formulation::new(&fine);
    assess(&f, x)
}

/// Confirms class `status` of the motion `x`, assessed `coarse` at the file's step, against its
/// rollout at `dt/`[`REFINEMENT`] (module header).
pub fn confirm(
    problem: &Problem,
    x: &[f64],
    coarse: Option<&Assessment>,
    status: TrialStatus,
    tol: f64,
) -> StepCheck {
    let unchecked = StepCheck {
        status,
        fine: None,
        downgrade: None,
    };
    let Some(coarse) = coarse else {
        return unchecked;
    };
    if !matches!(status, TrialStatus::Success | TrialStatus::Marginal) {
        return unchecked;
    }
    let fine = assess_refined(problem, x, REFINEMENT);
    let Some(f) = fine.as_ref() else {
        return StepCheck {
            status: TrialStatus::Failure,
            fine,
            downgrade: Some(format!(
                "{status:?} at dt, but the rollout at dt/{REFINEMENT} failed"
            )),
        };
    };
    let worst = coarse.max().max(f.max());
    let confirmed = if worst <= tol {
        TrialStatus::Success
    } else if worst <= 10.0 * tol {
        TrialStatus::Marginal
    } else {
        TrialStatus::Failure
    };
    let downgrade = (confirmed != status).then(|| {
        format!(
            "{status:?} at dt (largest violation {:.2e}), {confirmed:?} at dt/{REFINEMENT} \
             (largest violation {:.2e})",
            coarse.max(),
            f.max()
        )
    });
    StepCheck {
        status: confirmed,
        fine,
        downgrade,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gait::golden_problem as golden;
    use crate::gait::spline::KnotGrid;
    use crate::gait::task::{PoseConstraint, Quantity};

    /// The short Luxo task with a coarse step (5e-4 s, past the 4e-4 s where its drop test's
    /// error exceeds 1e-3 rad), every joint rate as a row at 0.15 s and 0.4 s, and a motion
    /// that throws the lamp onto the ground; the rows' bounds are set to the coarse rollout's
    /// own values, so the motion meets them exactly at dt.
    fn coarse_only() -> (Problem, Vec<f64>, Assessment) {
        let mut p = golden("luxo_leap_short");
        p.dt = 5e-4;
        p.horizon = 0.4;
        let row = p.constraints[0].clone();
        for time in [0.15, 0.4] {
            for v_index in 0..p.model.nv {
                p.constraints.push(PoseConstraint {
                    time,
                    quantity: Quantity::JointVelocity { v_index },
                    ..row.clone()
                });
            }
        }
        for c in &mut p.constraints {
            c.step = (c.time / p.dt).round() as usize;
        }
        let grid: KnotGrid = p.knot_grid();
        let block = grid.per_actuator();
        let mut x = vec![0.0; p.motion_parameters()];
        // A hard ankle and knee push from t = 0: the lamp leaves the ground and lands.
        for a in 0..2 {
            for k in 0..grid.knots {
                x[a * block + k] = if a == 0 { 12.0 } else { -10.0 };
            }
        }
        let f = Formulation::new(&p);
        let mut c = vec![0.0; p.constraints.len()];
        let mut cost = 0.0;
        crate::solver::Nlp::eval(f.reduced(), &x, &mut cost, &mut c).unwrap();
        for (row, v) in p.constraints.iter_mut().zip(&c) {
            (row.lower, row.upper) = (*v, *v);
        }
        let coarse = assess(&Formulation::new(&p), &x).unwrap();
        (p, x, coarse)
    }

    /// Coarsening undoes refining: the same step and key steps.
    #[test]
    fn coarsening_a_refined_problem_restores_its_steps() {
        let p = golden("luxo_leap_short");
        let back = coarsened(&refined(&p, 4), 4);
        assert_eq!(back.dt, p.dt);
        let steps = |q: &Problem| q.constraints.iter().map(|c| c.step).collect::<Vec<_>>();
        assert_eq!(steps(&back), steps(&p));
        assert_eq!(coarsened(&p, 1).dt, p.dt);
    }

    /// A motion that meets its rows at the file's step only is not reported Success.
    #[test]
    fn a_motion_feasible_at_the_coarse_step_only_is_downgraded() {
        let (p, x, coarse) = coarse_only();
        let tol = p.trials.tolerance;
        assert!(coarse.max() <= 1e-12, "{}", coarse.max());
        let check = confirm(&p, &x, Some(&coarse), TrialStatus::Success, tol);
        let fine = check.fine.as_ref().expect("refined rollout");
        println!("largest violation at dt/4: {:.3e}", fine.max());
        assert!(fine.max() > tol, "dt/4 largest violation {}", fine.max());
        assert_ne!(check.status, TrialStatus::Success);
        let reason = check.downgrade.expect("a reason");
        assert!(reason.starts_with("Success at dt"), "{reason}");
    }

    /// A motion that holds at both steps keeps its class; classes below Marginal are not
    /// re-simulated.
    #[test]
    fn a_motion_converged_in_the_step_keeps_its_class() {
        let (mut p, x, _) = coarse_only();
        p.dt /= 20.0;
        for c in &mut p.constraints {
            c.step *= 20;
        }
        let coarse = assess(&Formulation::new(&p), &x).unwrap();
        let fine = assess_refined(&p, &x, REFINEMENT).unwrap();
        // The rows sit at the 5e-4 s rollout's values: widen them to the 2.5e-5 s one's.
        let tol = coarse.max() + 1e-6;
        let check = confirm(&p, &x, Some(&coarse), TrialStatus::Success, tol);
        assert!(
            (fine.max() - coarse.max()).abs() < 1e-4,
            "{} vs {}",
            fine.max(),
            coarse.max()
        );
        assert_eq!(check.status, TrialStatus::Success, "{:?}", check.downgrade);
        assert!(check.downgrade.is_none());
        let failed = confirm(&p, &x, Some(&coarse), TrialStatus::Failure, tol);
        assert_eq!(failed.status, TrialStatus::Failure);
        assert!(failed.fine.is_none());
    }
}
