//! A hand-written sparse SQP solver with quasi-Newton Hessians, plus global methods.
//!
//! Problem form (see [`Nlp`]):
//! ```text
//!     min f(x)   s.t.   xl ≤ x ≤ xu,   cl ≤ c(x) ≤ cu
//! ```
//! Entry point: [`solve`]`(&nlp, &options) -> Solution`. Not converging is a [`Status`] in the
//! [`Solution`], never an `Err`.
//!
//! The method (see `sqp/`) is a line-search SQP on an automatically scaled problem: convex
//! QP subproblems solved by a dual active-set method (small n) or a sparse interior-point
//! method (large n, see [`qp::QpMethod`]), an ℓ1 merit function with second-order
//! correction, elastic mode for inconsistent linearizations (ending `Infeasible` at a
//! stationary point of the violation), and damped BFGS, L-BFGS or the exact Hessian with
//! inertia correction ([`HessianMode`]). Multipliers follow the Lagrangian
//! `f + Σ λᵢ cᵢ + Σ zⱼ xⱼ` (see [`Solution`]).
//!
//! # Example
//! ```
//! use optimize::solver::{solve, Dims, EvalError, Nlp, Options, Status};
//!
//! /// min x₀² + x₁²  s.t.  x₀ + x₁ = 1,  x ≥ 0.
//! struct Split;
//!
//! impl Nlp for Split {
//!     fn dims(&self) -> Dims {
//!         Dims { n: 2, m: 1, jac_nnz: 2, hess_nnz: 0 }
//!     }
//!     fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
//!         xl.fill(0.0);
//!         xu.fill(f64::INFINITY);
//!         cl[0] = 1.0;
//!         cu[0] = 1.0;
//!     }
//!     fn start(&self, x: &mut [f64]) {
//!         x.copy_from_slice(&[2.0, 0.0]);
//!     }
//!     fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
//!         rows.copy_from_slice(&[0, 0]);
//!         cols.copy_from_slice(&[0, 1]);
//!     }
//!     fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
//!         *f = x[0] * x[0] + x[1] * x[1];
//!         c[0] = x[0] + x[1];
//!         Ok(())
//!     }
//!     fn eval_derivatives(&self, x: &[f64], g: &mut [f64], jac: &mut [f64]) -> Result<(), EvalError> {
//!         g.copy_from_slice(&[2.0 * x[0], 2.0 * x[1]]);
//!         jac.copy_from_slice(&[1.0, 1.0]);
//!         Ok(())
//!     }
//! }
//!
//! let solution = solve(&Split, &Options { verbosity: 0, ..Options::default() });
//! assert_eq!(solution.status, Status::Optimal);
//! assert!((solution.x[0] - 0.5).abs() < 1e-6 && (solution.x[1] - 0.5).abs() < 1e-6);
//! assert!((solution.objective - 0.5).abs() < 1e-6);
//! // ∇f + λ∇c = 0 at the solution: (1, 1) + λ(1, 1) = 0.
//! assert!((solution.lambda[0] + 1.0).abs() < 1e-6);
//! ```

mod columns;
pub mod derivatives;
mod elastic;
mod evaluator;
pub mod global;
pub mod hessian;
pub mod interrupt;
pub mod kkt;
pub mod log;
mod merit;
mod multipliers;
mod nlp;
mod noise;
mod options;
pub mod qp;
mod remembered;
mod solution;
mod sqp;
mod status;
mod termination;
mod tuning;

pub use interrupt::{Interrupt, Interruptible};
pub(crate) use nlp::forward_nlp;
pub use nlp::{Bounds, Dims, EvalError, Nlp};
pub use options::{Globalization, HessianMode, InvalidSetting, Options};
pub use solution::{Evaluations, IterationRecord, Solution};
pub use sqp::solve;
pub use status::Status;
pub use tuning::Tuning;
