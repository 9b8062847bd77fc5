//! A hand-written sparse SQP solver with quasi-Newton Hessians, plus global methods.
//!
//! Problem form (see [`Nlp`]):
//! ```text
//!     min f(x)   s.t.   xl ≤ x ≤ xu,   cl ≤ c(x) ≤ cu
//! ```
//! Entry point: [`solve`]`(&nlp, &options) -> Solution`. Not converging is a [`Status`] in the
//! [`Solution`], never an `Err`.

pub mod derivatives;
mod elastic;
mod evaluator;
pub mod global;
pub mod hessian;
pub mod kkt;
mod log;
mod merit;
mod nlp;
mod options;
pub mod qp;
mod solution;
mod sqp;
mod status;
mod termination;

pub use nlp::{Dims, EvalError, Nlp};
pub use options::{HessianMode, Options};
pub use solution::{Evaluations, IterationRecord, Solution};
pub use sqp::solve;
pub use status::Status;
