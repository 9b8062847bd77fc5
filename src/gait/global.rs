//! The global phase (`[global]`): before a trial's solves, a derivative-free search over
//! rollouts leads its low-knowledge start (`[start]`: zero forces, random splines or the
//! hand-made guess) towards the kind of motion the task asks for, so that the SQP starts
//! near it (seed chapter 6: "automatically generate better initial guesses", a global–local
//! hybrid).
//!
//! The search is CMA-ES ([`crate::gait::cmaes`]) over the knot values of every actuator
//! (slopes stay at the start's), in units of half each actuator's force range, from the
//! trial's start with step size `[global] sigma`. It is staged like the trial's shaping
//! ([`crate::gait::shaping`]): stage `s` scores the rows (task and shaping rows,
//! `[[task]] shaping = true`) at times up to the `s`-th shaping horizon
//! ([`Problem::shaping_horizons`]), and the last stage every row; a stage's rollouts stop at its
//! last row. A candidate's fitness comes from one rollout, with `v_r(t)` the violation of row
//! `r`'s bounds by its quantity at time `t` (m, rad, m/s, rad/s as the rows are):
//! ```text
//!   fitness = Σ_r v_r(t_r) + Σ_r min_{t ≤ t_r} v_r(t) + Σ_j (u_j − clamp(u_j))²
//! ```
//! The first sum is the rows' violation at their key times. The second, sampled every
//! [`SAMPLE_INTERVAL`] and at the key times, is a time-relaxed stage of the same rows: a hop
//! that reaches the task's height too early already scores better than none (a motion that
//! never leaves the ground sees no change in the first sum, seed §6.1), and the first sum then
//! moves it to the key time. The third keeps knot values `u` within the spline box of
//! [`crate::gait::formulation`] (the rollout uses the clamped values). A rollout that fails
//! scores +∞. A stage stops when its fitness is within the trial's tolerance (its rows met),
//! when the distribution collapses, when the run's `generations` or `evaluations` are spent,
//! or on an interrupt; the next stage starts from its best candidate only if the stage was met
//! (lexicographic: the take-off before the landing), else the search ends there. The best
//! candidate of the last stage run starts the trial's solves. Without shaping stages there is
//! one stage, all rows.
//!
//! Deterministic: trial `k`'s search is seeded with the run's seed and `k`, each generation
//! on its own stream, and its candidates are rolled out in parallel into their own slots.

use std::time::Instant;

use super::cmaes::{Budget, Stop, minimize};
use super::formulation::Formulation;
use super::sim::Simulator;
use super::spec::{GlobalSettings, Problem};
use super::spline::SplineControls;
use crate::solver::log::LogTarget;

/// Generations between progress lines.
pub const PROGRESS_EVERY: usize = 10;

/// Time between the samples of the time-relaxed term (s).
pub const SAMPLE_INTERVAL: f64 = 0.01;

/// The rows' fitness of one rollout of motion parameters `x` (module header, without the box
/// term); +∞ when the rollout fails.
fn row_fitness(shaped: &Problem, steps: &[usize], x: &[f64]) -> f64 {
    let controls = SplineControls {
        grid: shaped.knot_grid(),
        params: x[..shaped.spline_parameters()].to_vec(),
    };
    let rows = &shaped.constraints;
    let mut state = shaped.initial_of(x);
    let mut sim = Simulator::<f64>::new(&shaped.model).interruptible(&shaped.interrupt);
    let (mut at_key, mut least) = (vec![0.0; rows.len()], vec![f64::INFINITY; rows.len()]);
    let rolled = sim.rollout(&mut state, shaped.dt, steps, &controls, |k, s, sim| {
        for (r, c) in rows.iter().enumerate() {
            if steps[k] <= c.step {
                let v = c.quantity.value(&shaped.model, s, &sim.dynamics);
                let violation = (c.lower - v).max(v - c.upper).max(0.0);
                least[r] = least[r].min(violation);
                if steps[k] == c.step {
                    at_key[r] = violation;
                }
            }
        }
    });
    match rolled {
        Ok(()) => at_key.iter().chain(&least).sum(),
        Err(_) => f64::INFINITY,
    }
}

/// The sample steps of [`row_fitness`]: every [`SAMPLE_INTERVAL`] and every key time, up to
/// the last row's, ascending.
fn sample_steps(shaped: &Problem) -> Vec<usize> {
    let last = shaped.constraints.iter().map(|c| c.step).max().unwrap_or(0);
    let every = ((SAMPLE_INTERVAL / shaped.dt).round() as usize).max(1);
    let mut steps: Vec<usize> = (0..=last).step_by(every).collect();
    steps.extend(shaped.constraints.iter().map(|c| c.step));
    steps.sort_unstable();
    steps.dedup();
    steps
}

/// What a trial's global phase did.
#[derive(Debug, Clone, PartialEq)]
pub struct GlobalReport {
    /// Best motion parameters found (physical units), the trial's start.
    pub x: Vec<f64>,
    /// Its fitness (module header; the rows' units).
    pub fitness: f64,
    /// Rollouts.
    pub evaluations: usize,
    /// Generations.
    pub generations: usize,
    /// Stages searched (module header): the shaping horizons' stages up to the first not
    /// met, the last holding every row.
    pub stages: usize,
    /// Why the search's last stage stopped.
    pub stop: Stop,
    /// Wall time (s).
    pub seconds: f64,
}

/// The seed of trial `trial`'s search, from the run's `seed`.
pub fn trial_seed(seed: u64, trial: usize) -> u64 {
    seed ^ (trial as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
}

/// Runs the global phase of trial `trial` from motion parameters `x0` (physical units;
/// [`crate::gait::trials::starts`]). With `log` it writes a progress line every
/// [`PROGRESS_EVERY`] generations and one at the end of each stage, prefixed with `stage`.
pub fn search(
    problem: &Problem,
    settings: &GlobalSettings,
    x0: &[f64],
    seed: u64,
    trial: usize,
    log: Option<&LogTarget>,
) -> GlobalReport {
    let clock = Instant::now();
    let f = Formulation::new(problem);
    let (lower, upper) = f.physical_bounds();
    let grid = problem.knot_grid();
    let (k, block) = (grid.knots, grid.per_actuator());
    // The searched coordinates: every actuator's knot values, with their scale and box.
    let mut index = Vec::new();
    let mut scale = Vec::new();
    for (a, act) in problem.model.actuators.iter().enumerate() {
        for i in 0..k {
            index.push(a * block + i);
            scale.push(0.5 * (act.bounds[1] - act.bounds[0]));
        }
    }
    let physical = |u: &[f64]| -> (Vec<f64>, f64) {
        let mut x = x0.to_vec();
        let mut outside = 0.0;
        for ((&j, &s), &uj) in index.iter().zip(&scale).zip(u) {
            let v = (uj * s).clamp(lower[j], upper[j]);
            outside += (uj - v / s).powi(2);
            x[j] = v;
        }
        (x, outside)
    };
    let say = |text: String| {
        if let Some(log) = log {
            log.line(&format!("{} global: {text}", log.stage));
        }
    };
    let tolerance = problem.trials.tolerance;
    let mut u: Vec<f64> = index.iter().zip(&scale).map(|(&j, &s)| x0[j] / s).collect();
    let mut report = GlobalReport {
        x: x0.to_vec(),
        fitness: f64::INFINITY,
        evaluations: 0,
        generations: 0,
        stages: 0,
        stop: Stop::Target,
        seconds: 0.0,
    };
    let horizons = problem.shaping_horizons();
    for (s, horizon) in horizons.iter().copied().chain([f64::INFINITY]).enumerate() {
        let shaped = problem.shaped_until(horizon);
        let steps = sample_steps(&shaped);
        let fitness = |u: &[f64]| -> f64 {
            let (x, outside) = physical(u);
            row_fitness(&shaped, &steps, &x) + outside
        };
        let budget = Budget {
            generations: settings.generations.saturating_sub(report.generations),
            evaluations: settings.evaluations.saturating_sub(report.evaluations),
            target: tolerance,
        };
        let stage_seed = trial_seed(seed, trial) ^ (s as u64).wrapping_mul(0xD1B5_4A32_D192_ED03);
        let best = minimize(
            fitness,
            &u,
            settings.sigma,
            settings.population,
            budget,
            stage_seed,
            |g| {
                if g.generation.is_multiple_of(PROGRESS_EVERY) {
                    say(format!(
                        "stage {}/{}, generation {}, {} rollouts, best fitness {:.3e}, σ {:.3}, {:.1} s",
                        s + 1,
                        horizons.len() + 1,
                        g.generation,
                        report.evaluations + g.evaluations,
                        g.best,
                        g.sigma,
                        clock.elapsed().as_secs_f64()
                    ));
                }
                !problem.interrupt.is_raised()
            },
        );
        u = best.x;
        report.fitness = best.value;
        report.evaluations += best.evaluations;
        report.generations += best.generations;
        report.stages = s + 1;
        report.stop = best.stop;
        say(format!(
            "stage {}/{} (rows up to {horizon} s): {:?} after {} generations, {} rollouts, {:.1} s: fitness {:.3e}",
            s + 1,
            horizons.len() + 1,
            best.stop,
            best.generations,
            best.evaluations,
            clock.elapsed().as_secs_f64(),
            best.value
        ));
        // Lexicographic: a later stage starts only from a candidate that meets this one.
        if best.value > tolerance {
            break;
        }
    }
    report.x = physical(&u).0;
    report.seconds = clock.elapsed().as_secs_f64();
    report
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gait::golden_problem as golden;

    /// The short pogo jump (both foot corners 5 cm up at t = 0.5 s) from zero force: the search lowers the violation, and the same seed gives the same
    /// search on one thread and on two.
    #[test]
    fn the_search_improves_a_zero_start_whatever_the_thread_count() {
        let p = golden("pogo_jump_short");
        let settings = GlobalSettings {
            generations: 8,
            evaluations: 1000,
            population: Some(8),
            sigma: 0.5,
        };
        let x0 = vec![0.0; p.motion_parameters()];
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| search(&p, &settings, &x0, 8, 1, None))
        };
        let (one, two) = (run(1), run(2));
        assert_eq!(one.x, two.x);
        assert_eq!(one.fitness, two.fitness);
        let start = search(
            &p,
            &GlobalSettings {
                generations: 0,
                ..settings
            },
            &x0,
            8,
            1,
            None,
        );
        assert_eq!(start.evaluations, 1);
        assert!(
            one.fitness < 0.5 * start.fitness,
            "{} vs {}",
            one.fitness,
            start.fitness
        );
        assert_ne!(one.x, search(&p, &settings, &x0, 8, 2, None).x);
    }

    /// Staging: the short pogo jump with a shaping row at t = 0.25 s (and `shaping_stages`)
    /// searches that row's stage first. A stage whose row is met at the start (the foot above
    /// −1 m) leads on to the last stage; one that cannot be met (the foot 10 m up) ends the
    /// search there, with its rollouts only a quarter-second long.
    #[test]
    fn the_search_is_staged_and_stops_at_a_stage_not_met() {
        let staged = |lower: f64| {
            let mut p = golden("pogo_jump_short");
            let mut row = p.constraints[0].clone();
            row.time = 0.25;
            row.step = (0.25 / p.dt).round() as usize;
            row.lower = lower;
            p.shaping.push(row);
            p.trials.shaping_stages = 1;
            p
        };
        let settings = GlobalSettings {
            generations: 6,
            evaluations: 1000,
            population: Some(8),
            sigma: 0.5,
        };
        let reachable = staged(-1.0);
        assert_eq!(reachable.shaping_horizons(), vec![0.25]);
        let x0 = vec![0.0; reachable.motion_parameters()];
        let on = search(&reachable, &settings, &x0, 8, 1, None);
        assert_eq!(on.stages, 2);
        assert!(on.generations <= settings.generations);
        let unreachable = staged(10.0);
        let stopped = search(&unreachable, &settings, &x0, 8, 1, None);
        assert_eq!(stopped.stages, 1);
        assert!(stopped.fitness > 10.0, "{}", stopped.fitness);
    }

    /// A raised interrupt ends the search after its current generation, whose rollouts stop
    /// at once and score +∞: the start is returned.
    #[test]
    fn an_interrupt_stops_the_search() {
        let p = golden("pogo_jump_short");
        p.interrupt.raise();
        let settings = GlobalSettings {
            generations: 100,
            evaluations: 10_000,
            population: Some(8),
            sigma: 0.5,
        };
        let x0 = vec![0.0; p.motion_parameters()];
        let r = search(&p, &settings, &x0, 8, 1, None);
        assert_eq!((r.stop, r.generations), (Stop::Stopped, 1));
        assert_eq!(r.x, x0);
    }
}
