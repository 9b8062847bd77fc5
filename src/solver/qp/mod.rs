//! Convex QP subproblems of the SQP method.
//!
//! ```text
//!     min ½ dᵀH d + gᵀd   s.t.   dl ≤ d ≤ du,   bl ≤ A d ≤ bu
//! ```
//! H is positive semidefinite (the SQP makes it so: damped BFGS, L-BFGS, or an exact Hessian
//! with inertia correction). Infinite bounds are ±`f64::INFINITY`; equality rows have
//! `bl == bu`. Two methods share this interface: a dense one for small problems and a sparse
//! interior-point one for large problems.

pub mod dense;
mod reflectors;
mod select;

pub use select::{DENSE_LIMIT, QpMethod, Snapshot, WarmStart, solve};

use nalgebra::DMatrix;
use nalgebra_sparse::{CscMatrix, CsrMatrix};

/// The QP Hessian in one of three representations.
#[derive(Debug, Clone, Copy)]
pub enum QpHessian<'a> {
    /// Dense symmetric n×n.
    Dense(&'a DMatrix<f64>),
    /// Sparse symmetric, lower triangle only (row ≥ col), n×n.
    SparseLower(&'a CscMatrix<f64>),
    /// Compact limited-memory form `H = δ·I − W·M·Wᵀ` with W n×p and M p×p symmetric
    /// (Byrd–Nocedal–Schnabel), never formed densely.
    LowRank {
        /// The diagonal scale δ > 0.
        delta: f64,
        /// n×p.
        w: &'a DMatrix<f64>,
        /// p×p, symmetric.
        m: &'a DMatrix<f64>,
    },
}

/// One QP subproblem. All slices have length n (variables) or m (rows of A).
#[derive(Debug, Clone, Copy)]
pub struct QpProblem<'a> {
    /// Hessian.
    pub h: QpHessian<'a>,
    /// Linear term, length n.
    pub g: &'a [f64],
    /// Constraint matrix, m×n.
    pub a: &'a CsrMatrix<f64>,
    /// Lower bounds on d.
    pub dl: &'a [f64],
    /// Upper bounds on d.
    pub du: &'a [f64],
    /// Lower bounds on A d.
    pub bl: &'a [f64],
    /// Upper bounds on A d.
    pub bu: &'a [f64],
}

/// How a QP solve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum QpStatus {
    /// Solved to tolerance (the sparse method also ends here at a stall within 1e-5 of
    /// feasibility: see `qp::sparse`).
    Optimal,
    /// The constraints are inconsistent (the SQP then switches to elastic mode).
    Infeasible,
    /// Unbounded below along a direction of zero curvature.
    Unbounded,
    /// Iteration limit reached.
    IterationLimit,
    /// Factorization or other numerical failure.
    Numerical,
    /// The run's interrupt flag was raised ([`crate::solver::interrupt`]); the step is the
    /// last iterate reached, not a solution.
    Interrupted,
}

/// The QP solution. Multipliers follow `Hd + g + Aᵀλ + z = 0`, λᵢ ≤ 0 at an active lower row
/// bound and ≥ 0 at an active upper one; likewise z for the bounds on d.
#[derive(Debug, Clone)]
pub struct QpSolution {
    /// How it ended.
    pub status: QpStatus,
    /// Step, length n.
    pub d: Vec<f64>,
    /// Row multipliers, length m.
    pub lambda: Vec<f64>,
    /// Bound multipliers, length n.
    pub z: Vec<f64>,
    /// Inner iterations.
    pub iterations: usize,
}

pub mod sparse;
