//! Newton systems kept on their thread between solvers of the same pattern.
//!
//! A problem solved in rounds (cmc normal coordinates rebuild the NLP, and with it the SQP's
//! [`super::SparseQp`], after each converged round) poses QPs of one sparsity pattern to a
//! new solver each round. Building a [`NewtonSystem`] — the KKT pattern from triplets, the
//! scatter positions of H and A, the factor's buffers — costs about half a numeric
//! factorization at a few hundred rows, so a solver that is dropped leaves its system here
//! and the next solver of the same pattern on the same thread takes it, reset to the state of
//! a new one ([`NewtonSystem::reset`]): same pattern, same positions, no factorization held,
//! no regularization choice carried over. The steps are therefore the same bit for bit as
//! with a new system; nothing crosses threads, so results do not depend on `--threads`.
//!
//! At most [`KEPT`] systems are kept per thread (the oldest forgotten first), and only those
//! whose factor has at most [`KEPT_FACTOR_ENTRIES`] entries: a large problem's system is freed
//! with its solver, where its construction is small beside its factorizations anyway.

use std::cell::RefCell;

use super::newton::NewtonSystem;
use crate::solver::qp::QpProblem;

/// Systems kept per thread.
pub const KEPT: usize = 2;

/// Largest factor (entries of L) of a kept system: 2²⁰ entries, 8 MiB of values.
pub const KEPT_FACTOR_ENTRIES: usize = 1 << 20;

thread_local! {
    /// This thread's kept systems, oldest first.
    static SYSTEMS: RefCell<Vec<NewtonSystem>> = const { RefCell::new(Vec::new()) };
}

/// A kept system of `qp`'s pattern, reset, if this thread has one (it is no longer kept).
pub fn take(qp: &QpProblem<'_>) -> Option<NewtonSystem> {
    SYSTEMS.with_borrow_mut(|systems| {
        let k = systems.iter().position(|s| s.matches(qp))?;
        let mut system = systems.remove(k);
        system.reset();
        Some(system)
    })
}

/// Keeps `system` for a later solver of its pattern on this thread (see the module header).
pub fn keep(system: NewtonSystem) {
    if system.factor_nnz() > KEPT_FACTOR_ENTRIES {
        return;
    }
    // A thread being torn down has no later solver: the system is simply dropped.
    let _ = SYSTEMS.try_with(|systems| {
        let mut systems = systems.borrow_mut();
        if systems.len() == KEPT {
            systems.remove(0);
        }
        systems.push(system);
    });
}
