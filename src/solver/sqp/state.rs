//! The iterate and what the loop remembers between iterations: the start, the acceptable-level
//! watch, retreats to the least violated iterate, and evaluations at trial points.

use std::collections::VecDeque;
use std::ops::ControlFlow;

use nalgebra_sparse::CsrMatrix;

use super::super::evaluator::{Derivatives, Values};
use super::super::merit;
use super::super::multipliers::{self, LinearizedPoint};
use super::super::termination::{self, Kkt, KktInput};
use super::super::{EvalError, Solution, Status, Tuning};
use super::Sqp;

/// Consecutive iterations within 100× the tolerances (`Acceptable` level), in windows of
/// `Tuning::acceptable_iterations`: a window that does not improve the best KKT ratio
/// `max(primal/ctol, optimality/tol)` before it by the factor `Tuning::acceptable_progress` ends
/// the solve (IPOPT's acceptable test, which ends after a fixed count, would stop an L-BFGS solve
/// that converges linearly: the 100-link chain on the sparse path went from 2e-5 to 1e-6 in
/// 45 such iterations).
#[derive(Default)]
pub(super) struct AcceptableRun {
    /// Iterations in the current window (0: not at the acceptable level).
    length: usize,
    /// Best ratio before the current window.
    before: f64,
    /// Best ratio within the current window.
    within: f64,
}

impl AcceptableRun {
    /// Records the KKT ratio of an iteration; true when progress has stopped at the
    /// acceptable level.
    pub(super) fn stalled(&mut self, ratio: f64, tuning: &Tuning) -> bool {
        if ratio > 100.0 {
            *self = AcceptableRun::default();
            return false;
        }
        if self.length == 0 {
            // The run's first iteration is the reference of its first window.
            self.before = ratio;
            self.within = f64::INFINITY;
            self.length = 1;
            return false;
        }
        self.length += 1;
        self.within = self.within.min(ratio);
        if self.length < tuning.acceptable_iterations {
            return false;
        }
        if self.within > tuning.acceptable_progress * self.before {
            return true;
        }
        // Progress: judge the next window against the best ratio so far.
        self.before = self.within;
        self.within = f64::INFINITY;
        self.length = 1;
        false
    }
}

/// Feasible iterations in a row and the objective at the start of the current window (see
/// `Options::progress_window`), and the objective over the last two stretches (see
/// `Options::progress_stretch`).
#[derive(Default)]
pub(super) struct ProgressWatch {
    /// Feasible iterations in the current window (0: the last iterate was infeasible).
    length: usize,
    /// Objective (the solver's scaling) at the window's first iterate.
    reference: f64,
    /// The objective at the last feasible iterates in a row, at most 2·stretch + 1 of them.
    recent: VecDeque<f64>,
}

impl ProgressWatch {
    /// Records an iterate with objective `f`; true when `window` feasible iterations in a row
    /// lowered the objective by no more than `tolerance·max(1, |f₀|)`, or (`stretch` > 0) when
    /// the decrease over the last `stretch` feasible iterations is at most half the decrease
    /// over the `stretch` before them and at most `tolerance·max(1, |f|)`: decreases that
    /// shrink at least geometrically by ½ per stretch leave less than the last one to gain; or
    /// (`extrapolate`) when the last two stretches' decreases Δ₁ > 0 and 0 ≤ Δ₂ ≤ Δ₁, continued
    /// geometrically over the next `window` iterations, add up to at most that tolerance
    /// (`Options::progress_extrapolate`). Never when `window` is 0.
    pub(super) fn creeping(
        &mut self,
        feasible: bool,
        f: f64,
        window: usize,
        tolerance: f64,
        stretch: usize,
        extrapolate: bool,
    ) -> bool {
        if window == 0 || !feasible {
            self.length = 0;
            self.recent.clear();
            return false;
        }
        if stretch > 0 {
            self.recent.push_back(f);
            if self.recent.len() > 2 * stretch + 1 {
                self.recent.pop_front();
            }
            if self.recent.len() == 2 * stretch + 1 {
                let older = self.recent[0] - self.recent[stretch];
                let last = self.recent[stretch] - f;
                let allowed = tolerance * f.abs().max(1.0);
                if older > 0.0 && last <= 0.5 * older && last <= allowed {
                    return true;
                }
                if extrapolate
                    && older > 0.0
                    && (0.0..=older).contains(&last)
                    && geometric_tail(last, last / older, window / stretch) <= allowed
                {
                    return true;
                }
            }
        }
        if self.length == 0 {
            self.reference = f;
        }
        self.length += 1;
        if self.length <= window {
            return false;
        }
        if self.reference - f <= tolerance * self.reference.abs().max(1.0) {
            return true;
        }
        self.reference = f;
        self.length = 1;
        false
    }
}

/// `Σⱼ₌₁..ₙ Δ·rʲ`: the next n decreases of a sequence whose last decrease is Δ and whose
/// decreases shrink by the ratio r each.
fn geometric_tail(last: f64, ratio: f64, n: usize) -> f64 {
    (1..=n).map(|j| last * ratio.powi(j as i32)).sum()
}

/// One accepted point with everything evaluated there.
#[derive(Clone)]
pub(super) struct Point {
    pub(super) x: Vec<f64>,
    pub(super) values: Values,
    pub(super) derivatives: Derivatives,
}

/// The loop's memory between iterations.
pub(super) struct State {
    /// The current iterate.
    pub(super) point: Point,
    /// The least violated iterate so far (where a retreat returns).
    pub(super) least_violated: Point,
    /// Iteration number (repeated iterations count).
    pub(super) iteration: usize,
    /// Step length α that led to `point` (0 after a repeated iteration), for the log.
    pub(super) alpha: f64,
    /// QP iterations spent on the step that led to `point`, for the log.
    pub(super) qp_iterations: usize,
    /// The acceptable-level watch.
    pub(super) acceptable: AcceptableRun,
    /// The creep watch (`Options::progress_window`).
    pub(super) progress: ProgressWatch,
    /// Whether the model was reset (or the exact Hessian abandoned) since the last accepted
    /// step: a second failure then ends the solve.
    pub(super) model_reset: bool,
    /// Retreats still allowed ([`Tuning::max_retreats`]).
    pub(super) retreats_left: usize,
    /// Consecutive iterations with an exact Hessian and a penalty weight above
    /// [`Tuning::exact_weight_limit`].
    pub(super) heavy_weights: usize,
    /// The multipliers of the QP whose step led to `point` (None at the start and after a
    /// repeated iteration): the termination test tries them before a new QP is solved.
    pub(super) arrival_multipliers: Option<Vec<f64>>,
}

impl State {
    fn new(point: Point, retreats: usize) -> Self {
        State {
            least_violated: point.clone(),
            point,
            iteration: 0,
            alpha: 0.0,
            qp_iterations: 0,
            acceptable: AcceptableRun::default(),
            progress: ProgressWatch::default(),
            model_reset: false,
            retreats_left: retreats,
            heavy_weights: 0,
            arrival_multipliers: None,
        }
    }

    /// On to the next iteration, reached by a step of length `alpha` (0: repeated) whose QPs
    /// took `qp_iterations`.
    pub(super) fn advance(&mut self, alpha: f64, qp_iterations: usize) {
        self.alpha = alpha;
        self.qp_iterations = qp_iterations;
        self.iteration += 1;
    }
}

impl Sqp<'_> {
    /// Before the first iteration: the problem checked, the start evaluated, the log's size
    /// line and header, initial multipliers and the exact Hessian. `Break` carries the
    /// solution when the start cannot be used.
    pub(super) fn begin(&mut self) -> ControlFlow<Solution, State> {
        if let Err(msg) = self.ev.check_input() {
            self.say(&format!("invalid problem: {msg}"));
            let x = self.ev.start();
            return ControlFlow::Break(self.failed_start(Status::EvaluationError, x));
        }
        let point = match self.initial_point() {
            Ok(p) => p,
            Err((status, x)) => return ControlFlow::Break(self.failed_start(status, x)),
        };
        if self.options.verbosity >= 1 {
            self.say_size();
            self.live.borrow_mut().header();
        }
        if !self.model.is_quasi_newton() {
            self.lambda = multipliers::least_squares(&LinearizedPoint {
                grad: &point.derivatives.grad,
                jac_rows: self.jac_pattern.entries().0,
                jac_cols: self.jac_pattern.entries().1,
                jac: &point.derivatives.jac,
                c: &point.values.c,
                cl: &self.ev.cl,
                cu: &self.ev.cu,
            });
            // The first QP's multipliers are judged against these (see `MULTIPLIER_JUMP`).
            self.last_qp_multipliers = super::largest(&self.lambda);
        }
        if let Err(e) = self.update_exact(&point) {
            let status = self.eval_status(&e);
            return ControlFlow::Break(self.finish(status, &point, None));
        }
        ControlFlow::Continue(State::new(point, self.tuning.max_retreats))
    }

    /// The start: clamp into the bounds, choose scales, evaluate.
    pub(super) fn initial_point(&mut self) -> Result<Point, (Status, Vec<f64>)> {
        let mut x = self.ev.start();
        for ((x, &l), &u) in x.iter_mut().zip(&self.ev.xl).zip(&self.ev.xu) {
            *x = x.clamp(l, u);
        }
        let raw = self
            .ev
            .raw_derivatives(&x)
            .map_err(|_| (Status::EvaluationError, x.clone()))?;
        self.ev.set_scaling(&raw.grad, &raw.jac);
        let values = self
            .ev
            .values(&x)
            .map_err(|_| (Status::EvaluationError, x.clone()))?;
        let derivatives = self.ev.seed_derivatives(&x, raw);
        Ok(Point {
            x,
            values,
            derivatives,
        })
    }

    /// Before `Infeasible` is declared at a stationary point of the violation that is clearly
    /// worse than an earlier iterate (reached by a long step into a region where the
    /// linearization misled), goes back to the least violated iterate with a stiffer
    /// quasi-Newton model (shorter steps) and heavier penalty weights. Returns whether it did.
    pub(super) fn retreat(&mut self, state: &mut State) -> bool {
        if state.retreats_left == 0
            || self.violation(&state.least_violated) >= 0.9 * self.violation(&state.point)
        {
            return false;
        }
        state.retreats_left -= 1;
        state.point = state.least_violated.clone();
        self.model.reset_stiffer(self.tuning.retreat_stiffness);
        for w in &mut self.rho {
            *w = (*w * self.tuning.retreat_stiffness).max(1.0);
        }
        self.warm.clear();
        if let Err(e) = self.update_exact(&state.point) {
            self.say(&format!("exact Hessian failed after a retreat: {e}"));
        }
        true
    }

    /// Unweighted ℓ1 violation of the scaled constraints at a point.
    pub(super) fn violation(&self, p: &Point) -> f64 {
        merit::l1_violation(&p.values.c, &self.ev.cl, &self.ev.cu)
    }

    pub(super) fn kkt(
        &self,
        point: &Point,
        jac: &CsrMatrix<f64>,
        lambda: &[f64],
    ) -> (Kkt, Vec<f64>) {
        termination::measure(&KktInput {
            x: &point.x,
            xl: &self.ev.xl,
            xu: &self.ev.xu,
            c: &point.values.c,
            cl: &self.ev.cl,
            cu: &self.ev.cu,
            scale_c: &self.ev.scale_c,
            grad: &point.derivatives.grad,
            jac,
            lambda,
        })
    }

    /// x + αd, clamped into the bounds (the QP respects them; this removes rounding).
    pub(super) fn trial(&self, x: &[f64], d: &[f64], alpha: f64) -> Vec<f64> {
        (0..x.len())
            .map(|j| (x[j] + alpha * d[j]).clamp(self.ev.xl[j], self.ev.xu[j]))
            .collect()
    }

    /// Evaluates values and derivatives at a trial point: Ok(None) for a domain failure.
    pub(super) fn evaluate(&mut self, x: Vec<f64>) -> Result<Option<(Values, Vec<f64>)>, ()> {
        match self.ev.values(&x) {
            Ok(v) => Ok(Some((v, x))),
            Err(EvalError::Domain(_)) => Ok(None),
            Err(EvalError::Fatal(_)) => Err(()),
        }
    }

    pub(super) fn complete(&mut self, x: Vec<f64>, values: Values) -> Result<Option<Point>, ()> {
        match self.ev.derivatives(&x) {
            Ok(derivatives) => Ok(Some(Point {
                x,
                values,
                derivatives,
            })),
            Err(EvalError::Domain(_)) => Ok(None),
            Err(EvalError::Fatal(_)) => Err(()),
        }
    }

    pub(super) fn lagrangian_gradient(&self, p: &Point) -> Vec<f64> {
        let mut g = p.derivatives.grad.clone();
        let (rows, cols) = self.jac_pattern.entries();
        for (k, (&r, &c)) in rows.iter().zip(cols).enumerate() {
            g[c] += self.lambda[r] * p.derivatives.jac[k];
        }
        g
    }
}

#[cfg(test)]
mod tests {
    use super::ProgressWatch;

    /// Feeds objective values (all feasible unless NaN, which stands for an infeasible
    /// iterate) and returns the index of the first iterate judged creeping.
    fn first_creep(values: &[f64], window: usize, tolerance: f64) -> Option<usize> {
        first_creep_by(values, window, tolerance, 0)
    }

    /// As `first_creep`, with the geometric test over stretches of `stretch` iterations.
    fn first_creep_by(
        values: &[f64],
        window: usize,
        tolerance: f64,
        stretch: usize,
    ) -> Option<usize> {
        first_creep_extrapolated(values, window, tolerance, stretch, false)
    }

    /// As `first_creep_by`, the stretch test extrapolating when `extrapolate`.
    fn first_creep_extrapolated(
        values: &[f64],
        window: usize,
        tolerance: f64,
        stretch: usize,
        extrapolate: bool,
    ) -> Option<usize> {
        let mut watch = ProgressWatch::default();
        values
            .iter()
            .position(|&f| watch.creeping(!f.is_nan(), f, window, tolerance, stretch, extrapolate))
    }

    #[test]
    fn a_feasible_window_without_enough_decrease_is_a_creep() {
        // 100 → 99.95 over 3 iterations: 5e-4 relative, below 1e-3.
        let creep = [100.0, 99.99, 99.97, 99.95, 99.94];
        assert_eq!(first_creep(&creep, 3, 1e-3), Some(3));
        // A decrease of 2e-3 per window keeps going, then a flat stretch ends it.
        let progress = [100.0, 99.9, 99.85, 99.8, 99.78, 99.76, 99.75, 99.75];
        assert_eq!(first_creep(&progress, 3, 1e-3), Some(6));
    }

    #[test]
    fn infeasible_iterates_and_a_zero_window_never_creep() {
        let flat = [1.0; 10];
        assert_eq!(first_creep(&flat, 0, 1e-3), None);
        // An infeasible iterate restarts the window.
        let mut interrupted = [1.0; 7];
        interrupted[2] = f64::NAN;
        interrupted[5] = f64::NAN;
        assert_eq!(first_creep(&interrupted, 3, 1e-3), None);
        // Relative to max(1, |f|): an objective near zero needs an absolute decrease of 1e-3.
        assert_eq!(first_creep(&[1e-6, 0.0, -5e-4, -9e-4], 3, 1e-3), Some(3));
        assert_eq!(first_creep(&[1e-6, 0.0, -5e-4, -2e-3], 3, 1e-3), None);
    }

    #[test]
    fn decreases_halving_per_stretch_end_before_the_window() {
        // Decrements 1, ½, ¼, … (objective 1000 − 2(1 − 2^−k)): over stretches of 2 the
        // decrease shrinks ×¼, so the test fires at the first iterate with two full stretches
        // behind it (index 4). The window alone sees a decrease of 2 > 1e-3·1000 over its
        // first 50 iterations and has not judged a second one by index 59.
        let geometric: Vec<f64> = (0..60)
            .map(|k| 1000.0 - 2.0 * (1.0 - 0.5_f64.powi(k)))
            .collect();
        assert_eq!(first_creep_by(&geometric, 50, 1e-3, 2), Some(4));
        assert_eq!(first_creep_by(&geometric, 50, 1e-3, 0), None);
        // A steady decrease (no shrinking) is left to the window, as is a shrinking one whose
        // last stretch still gains more than the tolerance (2 per stretch against 1e-3·1000).
        let steady: Vec<f64> = (0..60).map(|k| 1000.0 - 1e-3 * k as f64).collect();
        assert_eq!(first_creep_by(&steady, 50, 1e-3, 2), Some(50));
        let large = [1000.0, 990.0, 980.0, 976.0, 972.0, 970.0, 968.0];
        assert_eq!(first_creep_by(&large, 50, 1e-3, 2), None);
        // An infeasible iterate restarts the stretches too.
        let mut interrupted = geometric.clone();
        interrupted[3] = f64::NAN;
        assert_eq!(first_creep_by(&interrupted, 50, 1e-3, 2), Some(8));
    }

    #[test]
    fn a_slower_geometric_tail_ends_when_its_extrapolation_is_within_the_tolerance() {
        // Decrements shrinking ×0.9 per iteration (objective 1000 − 20(1 − 0.9^k)): ×0.59 per
        // stretch of 5, never the ½ the plain stretch test asks for, and 20 gained over the
        // first window of 50. The last stretch's decrease 8.19·0.9^(k−5), continued at ×0.59
        // over the ten stretches of a window, is ≈ 1.43 times it: at most 1e-3·1000 from k = 29.
        let slow: Vec<f64> = (0..60)
            .map(|k| 1000.0 - 20.0 * (1.0 - 0.9_f64.powi(k)))
            .collect();
        assert_eq!(first_creep_extrapolated(&slow, 50, 1e-3, 5, true), Some(29));
        assert_eq!(first_creep_extrapolated(&slow, 50, 1e-3, 5, false), None);
        // A steady decrease continues at its rate (ratio 1): 1e-3 per iteration is the
        // window's creep (0.05 over 50), judged as soon as two stretches are full; 0.1 per
        // iteration is progress for both tests.
        let steady: Vec<f64> = (0..60).map(|k| 1000.0 - 1e-3 * k as f64).collect();
        assert_eq!(
            first_creep_extrapolated(&steady, 50, 1e-3, 5, true),
            Some(10)
        );
        assert_eq!(
            first_creep_extrapolated(&steady, 50, 1e-3, 5, false),
            Some(50)
        );
        let progress: Vec<f64> = (0..60).map(|k| 1000.0 - 0.1 * k as f64).collect();
        assert_eq!(first_creep_extrapolated(&progress, 50, 1e-3, 5, true), None);
    }
}
