//! An [`Nlp`] whose derivatives come from finite differences of another problem's `eval`:
//! the fallback for models without exact derivatives (the seed's baseline, §3.7).
//!
//! SNOPT uses cheap forward differences far from a solution and switches to central ones near
//! it (seed §3.7). Here the caller controls the switch with
//! [`FiniteDifferenceNlp::set_scheme`] (an atomic, so it can be flipped through a shared
//! reference between solves); [`solve_forward_then_central`] packages the usual strategy:
//! a forward-difference solve, then a central-difference solve from its result.
//!
//! The scheme is shared state of one wrapper: concurrent solves that switch schemes (e.g. the
//! starts of a multistart) should each build their own wrapper around the problem they are
//! given, `|p| solve_forward_then_central(&FiniteDifferenceNlp::new(p, options), local)`.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use super::engine::FiniteDifferences;
use super::interval::{DifferenceScheme, FiniteDifferenceOptions};
use crate::solver::global::WithStart;
use crate::solver::{Dims, EvalError, Nlp, Solution, forward_nlp};

/// `inner` with finite-difference gradient and Jacobian (no exact Hessian: `hess_nnz = 0`).
pub struct FiniteDifferenceNlp<'a> {
    inner: &'a dyn Nlp,
    differences: FiniteDifferences,
    central: AtomicBool,
    evaluations: AtomicUsize,
}

impl std::fmt::Debug for FiniteDifferenceNlp<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FiniteDifferenceNlp")
            .field("dims", &self.inner.dims())
            .field("differences", &self.differences)
            .field("scheme", &self.scheme())
            .finish()
    }
}

impl<'a> FiniteDifferenceNlp<'a> {
    /// Wraps `inner`; the objective is assumed to depend on every variable.
    pub fn new(inner: &'a dyn Nlp, options: FiniteDifferenceOptions) -> Self {
        Self::from_differences(inner, FiniteDifferences::new(inner, options))
    }

    /// Wraps `inner` with a prepared [`FiniteDifferences`] (e.g. one with a sparse objective
    /// pattern).
    pub fn from_differences(inner: &'a dyn Nlp, differences: FiniteDifferences) -> Self {
        let central = differences.options().scheme == DifferenceScheme::Central;
        FiniteDifferenceNlp {
            inner,
            differences,
            central: AtomicBool::new(central),
            evaluations: AtomicUsize::new(0),
        }
    }

    /// Selects the difference scheme used by later `eval_derivatives` calls.
    pub fn set_scheme(&self, scheme: DifferenceScheme) {
        self.central
            .store(scheme == DifferenceScheme::Central, Ordering::Relaxed);
    }

    /// The scheme currently in use.
    pub fn scheme(&self) -> DifferenceScheme {
        if self.central.load(Ordering::Relaxed) {
            DifferenceScheme::Central
        } else {
            DifferenceScheme::Forward
        }
    }

    /// Calls of the inner `eval` made for differences so far (not counting plain `eval`s).
    pub fn difference_evaluations(&self) -> usize {
        self.evaluations.load(Ordering::Relaxed)
    }

    /// The finite-difference engine (column groups, options).
    pub fn differences(&self) -> &FiniteDifferences {
        &self.differences
    }
}

impl Nlp for FiniteDifferenceNlp<'_> {
    fn dims(&self) -> Dims {
        Dims {
            hess_nnz: 0,
            ..self.inner.dims()
        }
    }

    forward_nlp!(inner; bounds, start, jacobian_structure, eval, constraint_name);

    fn eval_derivatives(
        &self,
        x: &[f64],
        grad: &mut [f64],
        jac: &mut [f64],
    ) -> Result<(), EvalError> {
        let count = self
            .differences
            .evaluate(self.inner, x, self.scheme(), grad, jac)?;
        self.evaluations.fetch_add(count, Ordering::Relaxed);
        Ok(())
    }
}

/// SNOPT's strategy as two solves: `local` with forward differences from the problem's start,
/// then `local` with central differences from the first solve's point. The returned solution
/// is the second one, with iterations, evaluations, time and log of both (log rows of the
/// second solve keep their own numbering after those of the first).
pub fn solve_forward_then_central<F>(problem: &FiniteDifferenceNlp<'_>, local: F) -> Solution
where
    F: Fn(&dyn Nlp) -> Solution,
{
    problem.set_scheme(DifferenceScheme::Forward);
    let first = local(problem);
    problem.set_scheme(DifferenceScheme::Central);
    let restarted = WithStart::new(problem, first.x.clone());
    let mut second = local(&restarted);
    second.iterations += first.iterations;
    second.evaluations.functions += first.evaluations.functions;
    second.evaluations.derivatives += first.evaluations.derivatives;
    second.evaluations.hessians += first.evaluations.hessians;
    second.seconds += first.seconds;
    let mut log = first.log;
    log.append(&mut second.log);
    second.log = log;
    second
}
