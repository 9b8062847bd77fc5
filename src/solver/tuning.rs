//! Tuning constants of the SQP method (see `sqp/`): step limits, line-search and
//! trust-region constants, elastic-mode and penalty-weight limits, the exact Hessian's
//! safeguards, the acceptable-termination test and the noise measurement.
//!
//! [`Tuning::default`] holds the values the solver is documented and tested with; they are
//! fields (not constants) so that a test can vary one through [`super::Options::tuning`].
//! All quantities refer to the scaled problem (see `evaluator`) unless stated otherwise.

/// The SQP method's tuning constants. `Default` gives the values in use.
#[derive(Debug, Clone, PartialEq)]
pub struct Tuning {
    /// Largest n for which `HessianMode::Auto` picks dense BFGS over L-BFGS.
    pub dense_bfgs_limit: usize,
    /// Variables above which [`super::qp::QpMethod::Auto`] sends problems solved with their exact
    /// Hessian to the sparse QP method, below [`super::qp::DENSE_LIMIT`]: the dense method's
    /// O(m·n²) work per QP dominates from a few hundred variables (double bubble, n ≈ 600 and 1668:
    /// sparse 15–22× faster, same optimum to 3e-12; hanging chain of 100 links: 15×; see
    /// docs/notes/solver.md). Kept at 1000, not lower, because a small octahedral film (the
    /// `cmc_octahedron_square_short` golden case) still reaches its iteration limit on the sparse
    /// path where the dense one converges.
    pub exact_sparse_limit: usize,
    /// Under the trust region, a QP that fails is retried with a tenth of the radius while the
    /// radius exceeds this times `1 + ‖x‖∞`.
    pub qp_retry_radius: f64,
    /// Armijo constant of the line search.
    pub armijo: f64,
    /// Smallest step length tried before the line search gives up.
    pub min_step: f64,
    /// Smallest trust-region radius, relative to `1 + ‖x‖∞`: below it a trial fails. Steps of that
    /// size change the iterate in its tenth digit; the merit differences they produce are rounding,
    /// and a truss round accepted steps of 1e-11 for hundreds of iterations (30 s each) at a point
    /// already feasible to 3e-14.
    pub min_radius: f64,
    /// Largest constraint force `|λᵢ|·‖∇cᵢ‖∞`, relative to `max(1, ‖∇f‖∞)`, accepted from the
    /// ordinary QP; beyond it the linearization is treated as nearly inconsistent and the elastic
    /// subproblem is solved instead (SNOPT switches on large multipliers likewise). At a regular
    /// point the forces balance the objective gradient, so this only happens near degenerate or
    /// infeasible points. Also the cap of the elastic weights.
    pub elastic_weight: f64,
    /// Largest step `‖αd‖∞` relative to `1 + ‖x‖∞` tried by the line search (SNOPT's major step
    /// limit), so that a huge QP step cannot throw the iterate far away in one go.
    pub step_limit: f64,
    /// With the exact Hessian, a trial point may multiply the ℓ1 violation by at most this factor
    /// once it exceeds [`Self::violation_floor`]: the ℓ1 merit is exact only near a solution, and a
    /// long Newton step along a nearly singular reduced Hessian can lower it with weights ρᵢ = |λᵢ|
    /// while the true constraint forces far from x are much larger (truss: a step from violation
    /// 0.05 to 2.6 lowered φ, after which the weights diverged). Backtracking cuts such steps.
    pub violation_growth: f64,
    /// Largest scaled constraint violation (∞-norm) at which the sparse path decouples the
    /// variables held at a bound from the exact Hessian (see `hessian::held`): the held set
    /// predicts the active bounds near a feasible point only. Far from it (the gait ball
    /// collocation at violation 2.2e2) a held variable may have to leave its bound by a long step,
    /// and the model without its couplings then gave QP multipliers of 9e7 (forces beyond
    /// `elastic_weight`: elastic mode, Stalled) where the coupled one gave 1e3. The truss layout
    /// starts are within 2e-2.
    pub held_violation: f64,
    /// Scaled ℓ1 violation below which the growth cap does not apply.
    pub violation_floor: f64,
    /// An objective below this on a feasible point ends the solve `Unbounded` (SNOPT's
    /// "unbounded objective").
    pub unbounded_objective: f64,
    /// Iterates larger than this (‖x‖∞) on a feasible point end the solve `Unbounded` (SNOPT's
    /// "unbounded step size"): a well-scaled problem never needs them.
    pub unbounded_step: f64,
    /// Penalty weight beyond which an exact-Hessian iteration counts as stuck; after
    /// `exact_patience` such iterations in a row the solve switches to quasi-Newton updates.
    pub exact_weight_limit: f64,
    /// See `exact_weight_limit`.
    pub exact_patience: usize,
    /// Returns to the least violated iterate before `Infeasible` is declared elsewhere.
    pub max_retreats: usize,
    /// Factor on the quasi-Newton matrix and the penalty weights after such a return.
    pub retreat_stiffness: f64,
    /// Elastic-penalty increases per iteration.
    pub max_steering: usize,
    /// QPs in a row with the same active set after which the sparse exact-Hessian step is the
    /// Newton step on that active set without convexification, when it needs none (see
    /// `qp::WarmStart::newton_step`); 0 switches it off.
    pub endgame_after: usize,
    /// Decay of the exact-Hessian step damping after a full step (see `damp_exact_steps`).
    pub damping_decay: f64,
    /// Largest accepted step length that raises the exact-Hessian step damping.
    pub damping_cut: f64,
    /// Damping below which it is dropped (absolute, on the scaled problem).
    pub damping_min: f64,
    /// Consecutive iterations within 100× the tolerances, without progress, before `Acceptable`.
    pub acceptable_iterations: usize,
    /// Progress that keeps an acceptable run going: the best KKT ratio of the last
    /// `acceptable_iterations` iterations below this fraction of the best one before them (a
    /// quasi-Newton method converging linearly, not a stall).
    pub acceptable_progress: f64,
    /// A line search that rejects a step whose predicted merit decrease is below this multiple of
    /// `10·ε_mach·|φ|` measures the noise of φ along the step (see `noise`).
    pub noise_trigger: f64,
    /// Spacing of the noise samples: x moves by this times `1 + ‖x‖∞` per sample.
    pub noise_spacing: f64,
    /// Noise allowance of the relaxed Armijo tests, in standard deviations of the measured noise.
    pub noise_allowance: f64,
}

impl Default for Tuning {
    fn default() -> Self {
        Tuning {
            dense_bfgs_limit: 500,
            exact_sparse_limit: 1000,
            qp_retry_radius: 1e-8,
            armijo: 1e-4,
            min_step: 1e-12,
            min_radius: 1e-10,
            elastic_weight: 1e4,
            step_limit: 2.0,
            violation_growth: 10.0,
            held_violation: 1.0,
            violation_floor: 0.1,
            unbounded_objective: -1e20,
            unbounded_step: 1e10,
            exact_weight_limit: 1e8,
            exact_patience: 10,
            max_retreats: 3,
            retreat_stiffness: 10.0,
            max_steering: 8,
            endgame_after: 2,
            damping_decay: 3.0,
            damping_cut: 0.1,
            damping_min: 1e-8,
            acceptable_iterations: 15,
            acceptable_progress: 0.9,
            noise_trigger: 1e3,
            noise_spacing: 1e-6,
            noise_allowance: 3.0,
        }
    }
}
