//! Solver options: tolerances, limits, Hessian mode, verbosity.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use serde::{Deserialize, Serialize};

use super::log::LogTarget;
use super::qp::QpMethod;

/// How the solver obtains second-order information.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum HessianMode {
    /// Exact if the problem provides it, else dense damped BFGS for small n, L-BFGS for large n.
    #[default]
    Auto,
    /// Dense damped (Powell) BFGS (L-BFGS is used instead above `qp::DENSE_LIMIT` variables).
    Bfgs,
    /// Limited-memory BFGS (no dense n×n matrix).
    Lbfgs,
    /// The problem's exact Lagrangian Hessian with inertia correction.
    Exact,
}

/// How the SQP method makes sure a step improves the ℓ1 merit function.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Globalization {
    /// Backtracking Armijo line search along the QP step (with a second-order correction).
    #[default]
    LineSearch,
    /// Fletcher's Sℓ1QP trust region: the QP step is bounded by an ℓ∞ radius that shrinks
    /// when the merit function's actual decrease falls short of the model's prediction and
    /// grows when it matches; the elastic penalty steering only asks for what the linearized
    /// constraints can reach within the radius.
    TrustRegion,
}

/// Everything that steers a solve. `Default` gives the documented defaults.
#[derive(Debug, Clone)]
pub struct Options {
    /// Scaled dual-optimality tolerance.
    pub tolerance: f64,
    /// Scaled primal-feasibility tolerance.
    pub constraint_tolerance: f64,
    /// Major-iteration limit.
    pub max_iterations: usize,
    /// Wall-clock limit in seconds.
    pub max_time: Option<f64>,
    /// Hessian mode.
    pub hessian: HessianMode,
    /// Correction pairs kept by L-BFGS.
    pub lbfgs_memory: usize,
    /// QP subproblem method: `Auto` (dense Goldfarb–Idnani for n ≤ [`crate::solver::qp::DENSE_LIMIT`],
    /// sparse interior point above), or either one forced (`Sparse` never forms an n×n matrix).
    pub qp_method: QpMethod,
    /// Line search (default) or trust region.
    pub globalization: Globalization,
    /// 0 silent, 1 one line per iteration, 2 more detail. The log goes to `log`.
    pub verbosity: u8,
    /// Where the log goes, who observes the iterations, how the objective is shown (default:
    /// nowhere; the command line passes stderr).
    pub log: LogTarget,
    /// Set from outside (Ctrl-C) to stop at the end of the current iteration with status
    /// `Interrupted`, returning the best point so far.
    pub interrupt: Option<Arc<AtomicBool>>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            tolerance: 1e-6,
            constraint_tolerance: 1e-6,
            max_iterations: 1000,
            max_time: None,
            hessian: HessianMode::Auto,
            lbfgs_memory: 10,
            qp_method: QpMethod::Auto,
            globalization: Globalization::LineSearch,
            verbosity: 1,
            log: LogTarget::default(),
            interrupt: None,
        }
    }
}
