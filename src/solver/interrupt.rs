//! The run's interrupt flag (Ctrl-C): one shared flag handed down from the command line to
//! every loop that can run long, each of which polls it and stops with the best point it has.
//!
//! Polled by: the SQP solver between iterations ([`crate::solver::Options::interrupt`]) and at
//! every evaluation of its problem (wrapped in [`Interruptible`]), so a line search or an
//! assembly stops at its next evaluation; derivative checks, start searches and feasibility
//! phases through the same wrapper; gait rollouts every [`STEPS_BETWEEN_POLLS`] RK4 steps;
//! QP solves (`qp::WarmStart::interruptible`) before every interior-point iteration, that is
//! between two factorizations of the KKT matrix (one factorization is not interrupted), and
//! the truss layout LPs before every simplex pivot and interior-point iteration.
//! An interrupted evaluation returns [`EvalError::Fatal`] with the message [`INTERRUPTED`];
//! the solver then ends with status `Interrupted` at its last accepted point.
//! A poll is one relaxed atomic load.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use super::{EvalError, Nlp, forward_nlp};

/// RK4 steps a rollout takes between two polls of the flag (one Luxo-leap step with dual
/// numbers takes well under a millisecond, so a rollout notices a raised flag within
/// milliseconds).
pub const STEPS_BETWEEN_POLLS: usize = 16;

/// The message of the evaluation error an interrupted evaluation returns.
pub const INTERRUPTED: &str = "interrupted";

/// A shared stop flag: clones share it; raising it stops every holder at its next poll.
#[derive(Debug, Clone, Default)]
pub struct Interrupt {
    flag: Arc<AtomicBool>,
}

impl Interrupt {
    /// A fresh, lowered flag.
    pub fn new() -> Self {
        Self::default()
    }

    /// Raises the flag; returns whether it was already raised.
    pub fn raise(&self) -> bool {
        self.flag.swap(true, Ordering::SeqCst)
    }

    /// Whether the flag is raised.
    pub fn is_raised(&self) -> bool {
        self.flag.load(Ordering::Relaxed)
    }

    /// `Err(EvalError::Fatal("interrupted"))` once the flag is raised: the evaluation stops and
    /// the caller keeps the last point it accepted.
    pub fn poll(&self) -> Result<(), EvalError> {
        if self.is_raised() {
            Err(EvalError::Fatal(INTERRUPTED.into()))
        } else {
            Ok(())
        }
    }

    /// The underlying flag, for [`crate::solver::Options::interrupt`].
    pub fn flag(&self) -> Arc<AtomicBool> {
        Arc::clone(&self.flag)
    }
}

impl From<Arc<AtomicBool>> for Interrupt {
    fn from(flag: Arc<AtomicBool>) -> Self {
        Interrupt { flag }
    }
}

/// An NLP whose every evaluation first polls an [`Interrupt`].
pub struct Interruptible<'a> {
    nlp: &'a dyn Nlp,
    interrupt: &'a Interrupt,
}

impl<'a> Interruptible<'a> {
    /// Wraps `nlp`.
    pub fn new(nlp: &'a dyn Nlp, interrupt: &'a Interrupt) -> Self {
        Interruptible { nlp, interrupt }
    }
}

impl Nlp for Interruptible<'_> {
    forward_nlp!(nlp; dims, bounds, start, jacobian_structure, hessian_structure, constraint_name);
    fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
        self.interrupt.poll()?;
        self.nlp.eval(x, f, c)
    }
    fn eval_derivatives(
        &self,
        x: &[f64],
        grad: &mut [f64],
        jac: &mut [f64],
    ) -> Result<(), EvalError> {
        self.interrupt.poll()?;
        self.nlp.eval_derivatives(x, grad, jac)
    }
    fn eval_hessian(
        &self,
        x: &[f64],
        sigma: f64,
        lambda: &[f64],
        values: &mut [f64],
    ) -> Result<(), EvalError> {
        self.interrupt.poll()?;
        self.nlp.eval_hessian(x, sigma, lambda, values)
    }
}
