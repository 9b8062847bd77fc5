//! Multistart: a local solver from the problem's start and from K other starts, in parallel,
//! keeping the best result; in hybrid mode the other starts come from simulated annealing
//! (the global-then-local hybrid proposed in seed §6.2).
//!
//! Starts: index 0 is the problem's own start. Indices 1..=K are either random perturbations
//! of it (see [`super::start`]: scale `perturbation` relative to each variable's range, all
//! drawn in index order from one ChaCha8 stream seeded with `seed`) or, in hybrid mode, the
//! best states of K annealing runs from the problem's start with seeds `seed + k`.
//!
//! Ranking: a result is feasible when its largest violation is at most `feasibility_tolerance`.
//! Feasible results beat infeasible ones; feasible ones are ranked by objective, infeasible ones
//! by violation; a NaN objective or violation ranks last; exact ties go to the lower start
//! index. Every start runs to completion and the ranking is applied after, so the choice never
//! depends on the number of threads or their timing.

use std::time::Instant;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::annealing::{AnnealOptions, AnnealStats, anneal};
use super::start::{Bounds, WithStart, perturbed};
use crate::solver::{Evaluations, Nlp, Options, Solution};

/// Where the extra starts come from.
#[derive(Debug, Clone)]
pub enum StartGenerator {
    /// Random perturbations of the problem's start.
    Perturb,
    /// Best states of annealing runs (hybrid mode); their `seed` is replaced by `seed + k`.
    Anneal(AnnealOptions),
}

/// Settings of a multistart run. `Default` gives the documented defaults.
#[derive(Debug, Clone)]
pub struct MultistartOptions {
    /// Extra starts K besides the problem's own; default 8.
    pub starts: usize,
    /// Perturbation scale p, relative to each variable's range; default 0.25.
    pub perturbation: f64,
    /// Seed of the random starts; default 0.
    pub seed: u64,
    /// Largest violation of a feasible result (units of c); default 1e-6.
    pub feasibility_tolerance: f64,
    /// Where extra starts come from; default [`StartGenerator::Perturb`].
    pub generator: StartGenerator,
}

impl Default for MultistartOptions {
    fn default() -> Self {
        MultistartOptions {
            starts: 8,
            perturbation: 0.25,
            seed: 0,
            feasibility_tolerance: 1e-6,
            generator: StartGenerator::Perturb,
        }
    }
}

/// How a start was made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum StartKind {
    /// The problem's own start.
    Given,
    /// A random perturbation of it.
    Perturbed,
    /// The best state of an annealing run.
    Annealed,
}

/// One local solve of a multistart run.
#[derive(Debug, Clone, serde::Serialize)]
pub struct StartRun {
    /// Start index (0 = the problem's start).
    pub index: usize,
    /// How the start was made.
    pub kind: StartKind,
    /// Status name of the local solve.
    pub status: crate::solver::Status,
    /// Final objective.
    pub objective: f64,
    /// Final largest violation.
    pub max_violation: f64,
    /// Local iterations.
    pub iterations: usize,
    /// Evaluations of the local solve plus, in hybrid mode, of its annealing run.
    pub evaluations: Evaluations,
    /// Wall time of this start in seconds (annealing included).
    pub seconds: f64,
}

/// What a global run returns.
#[derive(Debug, Clone)]
pub struct GlobalResult {
    /// The best solution (see the ranking in the module header); its counts are its own run's.
    pub solution: Solution,
    /// Index of the start that produced it.
    pub best_start: usize,
    /// Every start, in index order.
    pub runs: Vec<StartRun>,
    /// Annealing counters, one per annealing run, in start order (empty without annealing).
    pub anneal: Vec<AnnealStats>,
    /// Evaluations summed over all runs.
    pub evaluations: Evaluations,
    /// Wall time of the whole run in seconds.
    pub seconds: f64,
}

/// Whether result `a` (start `ia`) ranks before result `b` (start `ib`).
pub fn ranks_before(a: &Solution, ia: usize, b: &Solution, ib: usize, tolerance: f64) -> bool {
    let (infeasible_a, key_a) = rank_key(a, tolerance);
    let (infeasible_b, key_b) = rank_key(b, tolerance);
    infeasible_a
        .cmp(&infeasible_b)
        .then(key_a.total_cmp(&key_b))
        .then(ia.cmp(&ib))
        .is_lt()
}

/// (infeasible?, objective or violation); a NaN objective or violation ranks last.
fn rank_key(s: &Solution, tolerance: f64) -> (bool, f64) {
    if s.objective.is_nan() || s.max_violation.is_nan() {
        (true, f64::INFINITY)
    } else if s.max_violation <= tolerance {
        (false, s.objective)
    } else {
        (true, s.max_violation)
    }
}

fn add(a: Evaluations, b: Evaluations) -> Evaluations {
    Evaluations {
        functions: a.functions + b.functions,
        derivatives: a.derivatives + b.derivatives,
        hessians: a.hessians + b.hessians,
    }
}

/// Multistart with the SQP solver [`crate::solver::solve`] and options `local` (see the module
/// header).
/// Annealing runs in hybrid mode also stop on `local.interrupt` unless they have their own.
pub fn multistart(nlp: &dyn Nlp, settings: &MultistartOptions, local: &Options) -> GlobalResult {
    super::optimize(
        nlp,
        &super::GlobalMethod::Multistart(settings.clone()),
        local,
    )
}

/// Multistart with any local solver: `local` solves the problem it is given from that
/// problem's start.
pub fn multistart_with<F>(nlp: &dyn Nlp, settings: &MultistartOptions, local: F) -> GlobalResult
where
    F: Fn(&dyn Nlp) -> Solution + Sync,
{
    let clock = Instant::now();
    let bounds = Bounds::of(nlp);
    let count = settings.starts + 1;
    // Perturbed starts are drawn up front, in index order, from one stream.
    let perturbed_starts: Vec<Vec<f64>> = match settings.generator {
        StartGenerator::Perturb => {
            let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
            (0..settings.starts)
                .map(|_| perturbed(&bounds, settings.perturbation, &mut rng))
                .collect()
        }
        StartGenerator::Anneal(_) => Vec::new(),
    };
    type Run = (Solution, StartRun, Option<AnnealStats>);
    let results: Vec<Run> = (0..count)
        .into_par_iter()
        .map(|index| {
            let started = Instant::now();
            let (x0, kind, anneal_run) = match (&settings.generator, index) {
                (_, 0) => (bounds.x0.clone(), StartKind::Given, None),
                (StartGenerator::Perturb, k) => {
                    (perturbed_starts[k - 1].clone(), StartKind::Perturbed, None)
                }
                (StartGenerator::Anneal(options), k) => {
                    let options = AnnealOptions {
                        seed: settings.seed.wrapping_add(k as u64),
                        ..options.clone()
                    };
                    let run = anneal(nlp, &options);
                    (run.solution.x.clone(), StartKind::Annealed, Some(run))
                }
            };
            let problem = WithStart::new(nlp, x0);
            let solution = local(&problem);
            let mut evaluations = solution.evaluations;
            if let Some(run) = &anneal_run {
                evaluations = add(evaluations, run.solution.evaluations);
            }
            let summary = StartRun {
                index,
                kind,
                status: solution.status,
                objective: solution.objective,
                max_violation: solution.max_violation,
                iterations: solution.iterations,
                evaluations,
                seconds: started.elapsed().as_secs_f64(),
            };
            (solution, summary, anneal_run.map(|r| r.stats))
        })
        .collect();

    let tolerance = settings.feasibility_tolerance;
    let mut best = 0;
    for (i, (s, _, _)) in results.iter().enumerate().skip(1) {
        if ranks_before(s, i, &results[best].0, best, tolerance) {
            best = i;
        }
    }
    let mut runs = Vec::with_capacity(count);
    let mut anneal_stats = Vec::new();
    let mut evaluations = Evaluations::default();
    let mut solution = None;
    for (i, (s, run, stats)) in results.into_iter().enumerate() {
        evaluations = add(evaluations, run.evaluations);
        runs.push(run);
        anneal_stats.extend(stats);
        if i == best {
            solution = Some(s);
        }
    }
    GlobalResult {
        solution: solution.expect("start 0 always exists"),
        best_start: best,
        runs,
        anneal: anneal_stats,
        evaluations,
        seconds: clock.elapsed().as_secs_f64(),
    }
}
