//! The seed's global methods: simulated annealing on a penalty formulation (seed §3.9) and a
//! multistart driver around the local SQP solver, including the annealing-then-SQP hybrid of
//! seed §6.2.
//!
//! - [`anneal`]: ASA-style simulated annealing; returns the best state as a [`Solution`]
//!   (never `Optimal`: annealing proves nothing) plus [`AnnealStats`].
//! - [`multistart()`] / [`multistart_with`]: local solves from the problem's start and K
//!   perturbed or annealed starts, in parallel, keeping the best feasible result.
//! - [`optimize`]: dispatches a [`GlobalMethod`] (what a `[global]` table asks for).
//!
//! Everything is deterministic for a given seed, whatever the number of rayon threads.

mod annealing;
mod multistart;
mod start;

#[cfg(test)]
mod tests;

pub use annealing::{AnnealOptions, AnnealResult, AnnealStats, AnnealStop, anneal};
pub use multistart::{
    GlobalResult, MultistartOptions, StartGenerator, StartKind, StartRun, multistart,
    multistart_with, ranks_before,
};
pub use start::WithStart;

use super::{Nlp, Options, Solution, solve};

/// A global method with its settings.
#[derive(Debug, Clone)]
pub enum GlobalMethod {
    /// Multistart (hybrid when its generator is [`StartGenerator::Anneal`]).
    Multistart(MultistartOptions),
    /// Simulated annealing alone, no local solve.
    Anneal(AnnealOptions),
}

/// Runs `method` on `nlp` with the SQP solver and options `local` for local solves.
pub fn optimize(nlp: &dyn Nlp, method: &GlobalMethod, local: &Options) -> GlobalResult {
    optimize_with(nlp, method, local, |p| solve(p, local))
}

/// [`optimize`] with any local solver. `local_options` only lends its interrupt flag to
/// annealing runs that have none.
pub fn optimize_with<F>(
    nlp: &dyn Nlp,
    method: &GlobalMethod,
    local_options: &Options,
    local: F,
) -> GlobalResult
where
    F: Fn(&dyn Nlp) -> Solution + Sync,
{
    match method {
        GlobalMethod::Multistart(settings) => {
            let mut settings = settings.clone();
            if let StartGenerator::Anneal(a) = &mut settings.generator
                && a.interrupt.is_none()
            {
                a.interrupt = local_options.interrupt.clone();
            }
            multistart_with(nlp, &settings, local)
        }
        GlobalMethod::Anneal(options) => {
            let mut options = options.clone();
            if options.interrupt.is_none() {
                options.interrupt = local_options.interrupt.clone();
            }
            let run = anneal(nlp, &options);
            let summary = StartRun {
                index: 0,
                kind: StartKind::Annealed,
                status: run.solution.status,
                objective: run.solution.objective,
                max_violation: run.solution.max_violation,
                iterations: run.solution.iterations,
                evaluations: run.solution.evaluations,
                seconds: run.solution.seconds,
            };
            GlobalResult {
                evaluations: run.solution.evaluations,
                seconds: run.solution.seconds,
                solution: run.solution,
                best_start: 0,
                runs: vec![summary],
                anneal: vec![run.stats],
            }
        }
    }
}
