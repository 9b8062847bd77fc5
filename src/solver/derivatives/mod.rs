//! Derivative tools: finite-difference gradients and sparse Jacobians, a wrapper that gives
//! derivative-free models finite-difference derivatives, and the derivative checker.
//!
//! - [`interval`]: forward and central stencils, difference intervals from the function's
//!   accuracy (seed §3.6, eq. 3.31; Gill, Murray & Wright §8.6), bound-respecting steps.
//! - [`coloring`]: Curtis–Powell–Reid column grouping so one perturbation serves many columns.
//! - [`FiniteDifferences`]: the estimator (parallel over column groups, thread-count
//!   independent results).
//! - [`FiniteDifferenceNlp`]: an [`crate::solver::Nlp`] whose `eval_derivatives` comes from
//!   finite differences (the seed's baseline, §3.7), with the caller-controlled
//!   forward → central switch SNOPT uses.
//! - [`check_derivatives`]: the `--check` comparison with a printable [`DerivativeReport`].

mod check;
pub mod coloring;
mod engine;
pub mod interval;
mod wrapper;

#[cfg(test)]
mod tests;

pub use check::{
    Block, BlockCheck, CheckOptions, DerivativeReport, EntryCheck, check_derivatives,
    relative_error,
};
pub use coloring::ColumnGroups;
pub use engine::FiniteDifferences;
pub use interval::{DifferenceScheme, FiniteDifferenceOptions};
pub use wrapper::{FiniteDifferenceNlp, solve_forward_then_central};
