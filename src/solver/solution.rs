//! What a solve returns.

use serde::Serialize;

use super::Status;

/// One row of the iteration log (and of `iterations.csv`).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct IterationRecord {
    /// The stage of a longer run the solve belonged to, e.g. "round 2" (empty for a lone solve;
    /// see `LogTarget::stage`).
    pub stage: String,
    /// Major iteration, 0 = the start.
    pub iter: usize,
    /// Objective f(x) unscaled, times the shown unit's factor (`LogTarget::objective`; the
    /// NLP's own f by default).
    pub objective: f64,
    /// Largest bound or constraint violation (unscaled).
    pub infeasibility: f64,
    /// Scaled dual-optimality measure.
    pub optimality: f64,
    /// Step length accepted by the line search (0 at the start).
    pub step: f64,
    /// Merit-function value.
    pub merit: f64,
    /// Inner (QP) iterations spent on this step.
    pub qp_iterations: usize,
    /// Seconds since the solve began.
    pub elapsed: f64,
}

/// Evaluation counts.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Evaluations {
    /// Calls of `Nlp::eval`.
    pub functions: usize,
    /// Calls of `Nlp::eval_derivatives`.
    pub derivatives: usize,
    /// Calls of `Nlp::eval_hessian`.
    pub hessians: usize,
}

/// The result of a solve. Multipliers follow the Lagrangian `f + Σ λᵢ cᵢ + Σ zⱼ xⱼ`; at a KKT
/// point `∇f + Jᵀλ + z = 0`, with λᵢ ≤ 0 on an active lower bound and ≥ 0 on an active upper one.
#[derive(Debug, Clone)]
pub struct Solution {
    /// How the solve ended.
    pub status: Status,
    /// Final point (the best one found for non-optimal endings).
    pub x: Vec<f64>,
    /// Constraint multipliers (length m).
    pub lambda: Vec<f64>,
    /// Bound multipliers (length n).
    pub z: Vec<f64>,
    /// f(x).
    pub objective: f64,
    /// c(x).
    pub constraints: Vec<f64>,
    /// Largest bound or constraint violation at x (unscaled).
    pub max_violation: f64,
    /// Final scaled dual-optimality measure.
    pub optimality: f64,
    /// Major iterations taken.
    pub iterations: usize,
    /// Evaluation counts.
    pub evaluations: Evaluations,
    /// Wall time of the solve in seconds.
    pub seconds: f64,
    /// The iteration log.
    pub log: Vec<IterationRecord>,
}
