//! Simulated annealing on a penalty formulation (seed §3.9), after Ingber's Adaptive Simulated
//! Annealing (ASA; Ingber 1989, 1996), without ASA's reannealing.
//!
//! **Cost.** Bounds are kept by the generator; general constraints enter an exact ℓ1 penalty
//!
//! ```text
//!     E(x) = f(x) + μ·Σᵢ max(0, clᵢ − cᵢ(x), cᵢ(x) − cuᵢ)
//! ```
//! with μ₀ = `penalty_weight`·max(1, |f(x₀)|). Weight schedule: every `penalty_interval`
//! generated states, if the current state violates a constraint by more than
//! `feasibility_tolerance`, μ ← `penalty_growth`·μ (at most 10¹² μ₀); costs of the current and
//! best states are re-weighted at once.
//!
//! **Generation** (ASA's law). Every variable moves at once: with u uniform in [0, 1] and T the
//! parameter temperature,
//!
//! ```text
//!     y = sgn(u − ½)·T·[(1 + 1/T)^|2u − 1| − 1] ∈ [−1, 1],     x'_j = x_j + y·r_j
//! ```
//! where r_j is the variable's range (xu − xl, or max(1, |x₀_j|) when a bound is infinite);
//! a value outside the bounds is drawn again (after 100 failed draws the variable keeps its value).
//!
//! **Schedules** (D = n). After k generated states and k_a accepted ones
//!
//! ```text
//!     T(k) = T₀·exp(−c·k^(1/D)),     T_cost(k_a) = T₀,cost·exp(−c·ρ·k_a^(1/D)),
//!     c = −ln(temperature_ratio_scale)·exp(−ln(temperature_anneal_scale)/D)
//! ```
//! so T reaches T₀·`temperature_ratio_scale` after `temperature_anneal_scale`^D states (ASA's
//! Temperature_Ratio_Scale, Temperature_Anneal_Scale, Cost_Parameter_Scale_Ratio = ρ). The
//! initial cost temperature, unless given, is ASA's: the mean |E| over the start and
//! `cost_samples` states generated from it. Acceptance is Metropolis: accept if
//! u < exp(−ΔE/T_cost).
//!
//! **Stopping.** Every `acceptance_check_interval` acceptances (ASA's
//! Acceptance_Frequency_Modulus) the best cost is compared with its value at the previous check:
//! a change of at most `cost_precision`·max(1, |E_best|) counts as a repeat, and
//! `maximum_cost_repeat` repeats in a row stop the run (ASA's Cost_Precision and
//! Maximum_Cost_Repeat). The run also stops after `max_evaluations` states (Limit_Generated),
//! on interrupt, or on a fatal evaluation error; a state whose evaluation fails with
//! [`EvalError::Domain`] or gives a NaN is rejected.
//!
//! **Best state and status.** States are ranked feasibility first (largest violation ≤
//! `feasibility_tolerance`), then by f if feasible, by largest violation if not. Annealing
//! proves nothing about optimality, so the [`Solution`] is never `Optimal`: `Infeasible` when
//! the best state violates the constraints, `IterationLimit` when the evaluation budget ran
//! out, `Stalled` when the cost-repeat test stopped the run, `Interrupted` or
//! `EvaluationError` otherwise. [`AnnealStats::stop`] says precisely why the run ended.
//! Multipliers are zero and `optimality` is NaN (not measured); `iterations` counts generated
//! states and the log has one row per check (`step` holds the parameter temperature and
//! `merit` the best penalized cost).
//!
//! Deterministic: one ChaCha8 stream seeded with `seed` drives every random choice, in a fixed
//! order.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::start::Bounds;
use crate::solver::{EvalError, Evaluations, IterationRecord, Nlp, Solution, Status};

/// Settings of simulated annealing. `Default` gives the documented defaults.
#[derive(Debug, Clone)]
pub struct AnnealOptions {
    /// Seed of the random stream; default 0.
    pub seed: u64,
    /// Initial parameter temperature T₀ (dimensionless; 1 makes early moves span the whole
    /// range); default 1.
    pub initial_temperature: f64,
    /// T/T₀ reached after `temperature_anneal_scale`^n states (ASA's Temperature_Ratio_Scale);
    /// default 1e-5.
    pub temperature_ratio_scale: f64,
    /// ASA's Temperature_Anneal_Scale; default 100.
    pub temperature_anneal_scale: f64,
    /// Ratio ρ of the cost schedule's rate to the parameter schedule's (ASA's
    /// Cost_Parameter_Scale_Ratio); default 1.
    pub cost_parameter_scale_ratio: f64,
    /// Initial cost temperature (units of f); default `None`: mean |E| of sampled states.
    pub initial_cost_temperature: Option<f64>,
    /// States sampled to set the initial cost temperature (ASA's Number_Cost_Samples);
    /// default 5.
    pub cost_samples: usize,
    /// Relative change of the best cost that counts as none (ASA's Cost_Precision); default
    /// 1e-18.
    pub cost_precision: f64,
    /// Repeats of the best cost, in a row, that stop the run (ASA's Maximum_Cost_Repeat);
    /// default 5.
    pub maximum_cost_repeat: usize,
    /// Acceptances between cost-repeat checks and log rows (ASA's
    /// Acceptance_Frequency_Modulus); default 100.
    pub acceptance_check_interval: usize,
    /// Largest number of generated states, i.e. evaluations (ASA's Limit_Generated); default
    /// 100 000.
    pub max_evaluations: usize,
    /// μ₀ / max(1, |f(x₀)|); default 10.
    pub penalty_weight: f64,
    /// Factor by which μ grows while the current state is infeasible; default 10.
    pub penalty_growth: f64,
    /// Generated states between penalty updates; default 1000.
    pub penalty_interval: usize,
    /// Largest constraint violation of a feasible state (units of c); default 1e-6.
    pub feasibility_tolerance: f64,
    /// Set from outside (Ctrl-C) to stop with status `Interrupted`.
    pub interrupt: Option<Arc<AtomicBool>>,
}

impl Default for AnnealOptions {
    fn default() -> Self {
        AnnealOptions {
            seed: 0,
            initial_temperature: 1.0,
            temperature_ratio_scale: 1e-5,
            temperature_anneal_scale: 100.0,
            cost_parameter_scale_ratio: 1.0,
            initial_cost_temperature: None,
            cost_samples: 5,
            cost_precision: 1e-18,
            maximum_cost_repeat: 5,
            acceptance_check_interval: 100,
            max_evaluations: 100_000,
            penalty_weight: 10.0,
            penalty_growth: 10.0,
            penalty_interval: 1000,
            feasibility_tolerance: 1e-6,
            interrupt: None,
        }
    }
}

/// Why an annealing run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum AnnealStop {
    /// `max_evaluations` states were generated.
    EvaluationLimit,
    /// The best cost repeated `maximum_cost_repeat` times in a row.
    CostRepeat,
    /// Stopped from outside.
    Interrupted,
    /// The problem's functions failed fatally (or at the start).
    EvaluationError,
}

/// Counters of an annealing run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AnnealStats {
    /// States generated (= evaluations after the start and the cost samples).
    pub generated: usize,
    /// States accepted.
    pub accepted: usize,
    /// Generated states whose evaluation failed or gave NaN (rejected).
    pub rejected_evaluations: usize,
    /// Parameter temperature at the end.
    pub temperature: f64,
    /// Cost (acceptance) temperature at the end (units of f).
    pub cost_temperature: f64,
    /// Penalty weight μ at the end.
    pub penalty: f64,
    /// Why the run ended.
    pub stop: AnnealStop,
}

/// What [`anneal`] returns: the best state as a [`Solution`], and the run's counters.
#[derive(Debug, Clone)]
pub struct AnnealResult {
    /// The best state (see the module header for the status).
    pub solution: Solution,
    /// Counters.
    pub stats: AnnealStats,
}

/// One evaluated state.
#[derive(Debug, Clone)]
struct State {
    x: Vec<f64>,
    f: f64,
    c: Vec<f64>,
    /// ℓ1 violation (penalized).
    sum: f64,
    /// Largest violation (ranks states).
    max: f64,
}

impl State {
    fn cost(&self, mu: f64) -> f64 {
        self.f + mu * self.sum
    }

    /// Feasibility first, then objective (feasible) or violation (infeasible).
    fn better_than(&self, other: &State, tol: f64) -> bool {
        match (self.max <= tol, other.max <= tol) {
            (true, false) => true,
            (false, true) => false,
            (true, true) => self.f < other.f,
            (false, false) => self.max < other.max,
        }
    }
}

/// Evaluates `x`: `Ok(None)` for a rejected state (domain error or NaN).
fn evaluate(nlp: &dyn Nlp, bounds: &Bounds, x: Vec<f64>) -> Result<Option<State>, EvalError> {
    let mut f = 0.0;
    let mut c = vec![0.0; bounds.cl.len()];
    match nlp.eval(&x, &mut f, &mut c) {
        Ok(()) => {}
        Err(EvalError::Domain(_)) => return Ok(None),
        Err(e) => return Err(e),
    }
    if f.is_nan() || c.iter().any(|v| v.is_nan()) {
        return Ok(None);
    }
    let sum = bounds.violation_sum(&c);
    let max = bounds.violation(&c);
    Ok(Some(State { x, f, c, sum, max }))
}

/// ASA's generating law: a move in [−1, 1] (fraction of the range) at temperature `t`.
fn asa_step(t: f64, rng: &mut ChaCha8Rng) -> f64 {
    let u: f64 = rng.random();
    let sign = if u < 0.5 { -1.0 } else { 1.0 };
    // (1 + 1/T)^a − 1 = expm1(a·ln(1 + 1/T)), stable for tiny T.
    sign * t * ((2.0 * u - 1.0).abs() * (1.0 / t).ln_1p()).exp_m1()
}

/// A new point around `x` at temperature `t`, inside the bounds.
fn generate(x: &[f64], bounds: &Bounds, t: f64, rng: &mut ChaCha8Rng) -> Vec<f64> {
    x.iter()
        .enumerate()
        .map(|(j, &xj)| {
            let range = bounds.range(j);
            for _ in 0..100 {
                let v = xj + asa_step(t, rng) * range;
                if v >= bounds.xl[j] && v <= bounds.xu[j] {
                    return v;
                }
            }
            xj.clamp(bounds.xl[j], bounds.xu[j])
        })
        .collect()
}

/// The temperature schedules of the module header: `T(k) = T₀·exp(−c·k^(1/D))` for the
/// parameters (dimensionless) and `T_cost(k_a) = T₀,cost·exp(−c·ρ·k_a^(1/D))` for the cost
/// (units of f), each at least 1e-300.
struct Schedule {
    /// T₀.
    t0: f64,
    /// T₀,cost.
    t0_cost: f64,
    /// c.
    c: f64,
    /// c·ρ.
    c_cost: f64,
    /// D, the number of variables (at least 1).
    n: f64,
}

impl Schedule {
    /// The parameter temperature after `k` generated states.
    fn temperature(&self, k: f64) -> f64 {
        (self.t0 * (-self.c * k.powf(1.0 / self.n)).exp()).max(1e-300)
    }

    /// The cost temperature after `accepted` acceptances.
    fn cost_temperature(&self, accepted: usize) -> f64 {
        (self.t0_cost * (-self.c_cost * (accepted as f64).powf(1.0 / self.n)).exp()).max(1e-300)
    }
}

/// A run in progress: the current and best states, the penalty weight, the cost-repeat test
/// and the counters.
struct Annealer<'a> {
    nlp: &'a dyn Nlp,
    bounds: Bounds,
    options: &'a AnnealOptions,
    rng: ChaCha8Rng,
    clock: Instant,
    schedule: Schedule,
    /// Evaluations of the functions (the start and cost samples included).
    evaluations: usize,
    /// One row per check.
    log: Vec<IterationRecord>,
    stats: AnnealStats,
    current: State,
    best: State,
    /// Penalty weight μ and its start μ₀.
    mu: f64,
    mu0: f64,
    /// The best cost at the last check, and how many checks in a row repeated it.
    last_checked: f64,
    repeats: usize,
}

/// Runs simulated annealing on `nlp` from its start (see the module header).
pub fn anneal(nlp: &dyn Nlp, options: &AnnealOptions) -> AnnealResult {
    let clock = Instant::now();
    let bounds = Bounds::of(nlp);
    let start = match evaluate(nlp, &bounds, bounds.x0.clone()) {
        Ok(Some(s)) => s,
        Ok(None) | Err(_) => {
            return failed_start(nlp, &bounds, clock.elapsed().as_secs_f64());
        }
    };
    let mut run = Annealer::new(nlp, bounds, options, clock, start);
    let stop = loop {
        if options
            .interrupt
            .as_ref()
            .is_some_and(|i| i.load(Ordering::Relaxed))
        {
            break AnnealStop::Interrupted;
        }
        if run.stats.generated >= options.max_evaluations {
            break AnnealStop::EvaluationLimit;
        }
        if let Some(stop) = run.generate_and_test() {
            break stop;
        }
        run.update_penalty();
    };
    run.finish(stop)
}

impl<'a> Annealer<'a> {
    /// The run at the evaluated `start`: μ₀, the schedules (the initial cost temperature
    /// sampled when not given) and the first log row.
    fn new(
        nlp: &'a dyn Nlp,
        bounds: Bounds,
        options: &'a AnnealOptions,
        clock: Instant,
        start: State,
    ) -> Self {
        let n = bounds.x0.len().max(1) as f64;
        let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
        let mut evaluations = 1;
        let mu0 = options.penalty_weight * start.f.abs().max(1.0);
        let c = -options.temperature_ratio_scale.ln()
            * (-options.temperature_anneal_scale.ln() / n).exp();
        let t0 = options.initial_temperature;
        let t0_cost = match options.initial_cost_temperature {
            Some(t) => t,
            None => sampled_cost_temperature(
                nlp,
                &bounds,
                options,
                &start,
                mu0,
                &mut rng,
                &mut evaluations,
            ),
        };
        let stats = AnnealStats {
            generated: 0,
            accepted: 0,
            rejected_evaluations: 0,
            temperature: t0,
            cost_temperature: t0_cost,
            penalty: mu0,
            stop: AnnealStop::EvaluationLimit,
        };
        let mut run = Annealer {
            nlp,
            bounds,
            options,
            rng,
            clock,
            schedule: Schedule {
                t0,
                t0_cost,
                c,
                c_cost: c * options.cost_parameter_scale_ratio,
                n,
            },
            evaluations,
            log: Vec::new(),
            stats,
            last_checked: start.cost(mu0),
            current: start.clone(),
            best: start,
            mu: mu0,
            mu0,
            repeats: 0,
        };
        run.record(0, t0);
        run
    }

    /// A log row for the best state after `k` generated states at temperature `t`.
    fn record(&mut self, k: usize, t: f64) {
        self.log.push(IterationRecord {
            iter: k,
            objective: self.best.f,
            infeasibility: self.best.max,
            optimality: f64::NAN,
            step: t,
            merit: self.best.cost(self.mu),
            qp_iterations: 0,
            elapsed: self.clock.elapsed().as_secs_f64(),
            stage: String::new(),
        });
    }

    /// Generates and evaluates the next state and applies the Metropolis test; `Some` when
    /// the run stops (a fatal evaluation error, or the cost-repeat test).
    fn generate_and_test(&mut self) -> Option<AnnealStop> {
        self.stats.generated += 1;
        let t = self.schedule.temperature(self.stats.generated as f64);
        self.stats.temperature = t;
        let x = generate(&self.current.x, &self.bounds, t, &mut self.rng);
        self.evaluations += 1;
        let candidate = match evaluate(self.nlp, &self.bounds, x) {
            Ok(candidate) => candidate,
            Err(_) => return Some(AnnealStop::EvaluationError),
        };
        // The acceptance draw is made for every state so the stream does not depend on
        // evaluation failures.
        let u: f64 = self.rng.random();
        let Some(s) = candidate else {
            self.stats.rejected_evaluations += 1;
            return None;
        };
        let t_cost = self.schedule.cost_temperature(self.stats.accepted);
        self.stats.cost_temperature = t_cost;
        let delta = s.cost(self.mu) - self.current.cost(self.mu);
        if !(delta <= 0.0 || u < (-delta / t_cost).exp()) {
            return None;
        }
        self.stats.accepted += 1;
        if s.better_than(&self.best, self.options.feasibility_tolerance) {
            self.best = s.clone();
        }
        self.current = s;
        if self
            .stats
            .accepted
            .is_multiple_of(self.options.acceptance_check_interval.max(1))
        {
            return self.check_repeats(t);
        }
        None
    }

    /// The cost-repeat test at a check (module header), with its log row at temperature `t`.
    fn check_repeats(&mut self, t: f64) -> Option<AnnealStop> {
        self.record(self.stats.generated, t);
        let now = self.best.cost(self.mu);
        if (now - self.last_checked).abs() <= self.options.cost_precision * now.abs().max(1.0) {
            self.repeats += 1;
        } else {
            self.repeats = 0;
        }
        self.last_checked = now;
        (self.repeats >= self.options.maximum_cost_repeat).then_some(AnnealStop::CostRepeat)
    }

    /// Every `penalty_interval` states, μ grows while the current state is infeasible (at
    /// most 10¹² μ₀); the cost-repeat test starts again at the re-weighted best cost.
    fn update_penalty(&mut self) {
        let o = self.options;
        if self
            .stats
            .generated
            .is_multiple_of(o.penalty_interval.max(1))
            && self.current.max > o.feasibility_tolerance
            && self.mu < 1e12 * self.mu0
        {
            self.mu = (self.mu * o.penalty_growth).min(1e12 * self.mu0);
            self.last_checked = self.best.cost(self.mu);
            self.repeats = 0;
        }
    }

    /// The result of a run ended by `stop`: the best state as a [`Solution`] (status in the
    /// module header) and the counters.
    fn finish(mut self, stop: AnnealStop) -> AnnealResult {
        self.stats.stop = stop;
        self.stats.penalty = self.mu;
        if self
            .log
            .last()
            .is_none_or(|r| r.iter != self.stats.generated)
        {
            self.record(self.stats.generated, self.stats.temperature);
        }
        let best = self.best;
        let status = match stop {
            AnnealStop::Interrupted => Status::Interrupted,
            AnnealStop::EvaluationError => Status::EvaluationError,
            _ if best.max > self.options.feasibility_tolerance => Status::Infeasible,
            AnnealStop::EvaluationLimit => Status::IterationLimit,
            AnnealStop::CostRepeat => Status::Stalled,
        };
        let m = best.c.len();
        let solution = Solution {
            status,
            lambda: vec![0.0; m],
            z: vec![0.0; best.x.len()],
            objective: best.f,
            max_violation: best.max,
            constraints: best.c,
            x: best.x,
            optimality: f64::NAN,
            iterations: self.stats.generated,
            evaluations: Evaluations {
                functions: self.evaluations,
                derivatives: 0,
                hessians: 0,
            },
            seconds: self.clock.elapsed().as_secs_f64(),
            log: self.log,
        };
        AnnealResult {
            solution,
            stats: self.stats,
        }
    }
}

/// ASA's initial cost temperature: the mean |E| (units of f) at weight `mu` over `start` and
/// `cost_samples` states generated from it at T₀ (1 when that mean is not a positive number).
fn sampled_cost_temperature(
    nlp: &dyn Nlp,
    bounds: &Bounds,
    options: &AnnealOptions,
    start: &State,
    mu: f64,
    rng: &mut ChaCha8Rng,
    evaluations: &mut usize,
) -> f64 {
    let mut total = start.cost(mu).abs();
    let mut count = 1.0;
    for _ in 0..options.cost_samples {
        let x = generate(&start.x, bounds, options.initial_temperature, rng);
        *evaluations += 1;
        if let Ok(Some(s)) = evaluate(nlp, bounds, x) {
            total += s.cost(mu).abs();
            count += 1.0;
        }
    }
    let mean = total / count;
    if mean > 0.0 && mean.is_finite() {
        mean
    } else {
        1.0
    }
}

/// The result when the start itself cannot be evaluated.
fn failed_start(nlp: &dyn Nlp, bounds: &Bounds, seconds: f64) -> AnnealResult {
    let n = bounds.x0.len();
    let m = nlp.dims().m;
    AnnealResult {
        solution: Solution {
            status: Status::EvaluationError,
            x: bounds.x0.clone(),
            lambda: vec![0.0; m],
            z: vec![0.0; n],
            objective: f64::NAN,
            constraints: vec![f64::NAN; m],
            max_violation: f64::NAN,
            optimality: f64::NAN,
            iterations: 0,
            evaluations: Evaluations {
                functions: 1,
                derivatives: 0,
                hessians: 0,
            },
            seconds,
            log: Vec::new(),
        },
        stats: AnnealStats {
            generated: 0,
            accepted: 0,
            rejected_evaluations: 0,
            temperature: f64::NAN,
            cost_temperature: f64::NAN,
            penalty: f64::NAN,
            stop: AnnealStop::EvaluationError,
        },
    }
}
