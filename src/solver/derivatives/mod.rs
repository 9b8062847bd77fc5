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
//!
//! ```
//! use optimize::solver::derivatives::{check_derivatives, CheckOptions};
//! use optimize::solver::{Dims, EvalError, Nlp};
//!
//! /// min x0·x1  s.t.  x0² + x1² = 1, with a deliberate slip in ∂c/∂x1.
//! struct Circle;
//! impl Nlp for Circle {
//!     fn dims(&self) -> Dims {
//!         Dims { n: 2, m: 1, jac_nnz: 2, hess_nnz: 0 }
//!     }
//!     fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
//!         xl.fill(f64::NEG_INFINITY);
//!         xu.fill(f64::INFINITY);
//!         cl[0] = 1.0;
//!         cu[0] = 1.0;
//!     }
//!     fn start(&self, x: &mut [f64]) {
//!         x.copy_from_slice(&[0.6, 0.8]);
//!     }
//!     fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
//!         rows.copy_from_slice(&[0, 0]);
//!         cols.copy_from_slice(&[0, 1]);
//!     }
//!     fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
//!         *f = x[0] * x[1];
//!         c[0] = x[0] * x[0] + x[1] * x[1];
//!         Ok(())
//!     }
//!     fn eval_derivatives(&self, x: &[f64], g: &mut [f64], j: &mut [f64])
//!         -> Result<(), EvalError> {
//!         g.copy_from_slice(&[x[1], x[0]]);
//!         j.copy_from_slice(&[2.0 * x[0], x[1]]); // should be 2·x1
//!         Ok(())
//!     }
//!     fn constraint_name(&self, _row: usize) -> String {
//!         "unit circle".into()
//!     }
//! }
//!
//! let report = check_derivatives(&Circle, &[0.6, 0.8], &CheckOptions::default()).unwrap();
//! assert!(!report.passed());
//! let worst = &report.worst_per_function[0];
//! assert_eq!((worst.name.as_str(), worst.row, worst.col), ("unit circle", Some(0), 1));
//! println!("{report}");
//! ```

mod check;
pub mod coloring;
mod engine;
pub mod interval;
mod wrapper;

#[cfg(test)]
mod tests;

pub use check::{
    Block, BlockCheck, CheckOptions, DerivativeReport, EntryCheck, check_derivatives,
    jittered_start, relative_error, spread_columns,
};
pub use coloring::ColumnGroups;
pub use engine::FiniteDifferences;
pub use interval::{DifferenceScheme, FiniteDifferenceOptions};
pub use wrapper::{FiniteDifferenceNlp, solve_forward_then_central};
