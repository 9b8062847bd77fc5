//! The global phase (`[global]`): a derivative-free search over rollouts leads a trial's
//! low-knowledge start (`[start]`: zero forces, random splines or the hand-made guess) towards
//! the kind of motion the task asks for, so that the SQP starts near it (seed chapter 6:
//! "automatically generate better initial guesses", a global–local hybrid). It runs before the
//! trial's solves, or with `fallback` only after solves from the start itself fell short of
//! Success (the order is [`crate::gait::trials`]').
//!
//! The search is CMA-ES ([`crate::gait::cmaes`]) over the knot values of every actuator
//! (slopes stay at the start's), in units of half each actuator's force range, from the
//! trial's start with step size `[global] sigma`. A candidate's fitness comes from one rollout
//! and the rows `r` of the task and the shaping rows (`[[task]] shaping = true`) together, the
//! rows the trial's staged shaping then meets, with `v_r(t)` the violation of row `r`'s bounds
//! by its quantity at time `t` (m, rad, m/s, rad/s as the rows are):
//! ```text
//!   fitness = Σ_r v_r(t_r) + Σ_r min_{t ≤ t_r} v_r(t) + Σ_j (u_j − clamp(u_j))²
//! ```
//! The first sum is the rows' violation at their key times. The second, sampled every
//! [`SAMPLE_INTERVAL`] and at the key times, is a time-relaxed stage of the same rows: a hop
//! that reaches the task's height too early already scores better than none (a motion that
//! never leaves the ground sees no change in the first sum, seed §6.1), and the first sum then
//! moves it to the key time. The third keeps knot values `u` within the spline box of
//! [`crate::gait::formulation`] (the rollout uses the clamped values).
//!
//! **By stages** (`[global] staged = true`, with `[trials] shaping_stages`): the rows fall
//! into the staged shaping's `S` stages ([`crate::gait::shaping`]: stage `s` holds the rows
//! after horizon `t_{s−1}` up to `t_s`, the last stage the rest). With `k` the first stage
//! having a row whose key-time violation exceeds the trial's tolerance (`k = S` when none),
//! ```text
//!   fitness = W·(S − k) + Σ_{r in stages ≤ k} (v_r(t_r) + min_{t ≤ t_r} v_r(t)) + box term
//! ```
//! with `W` = [`STAGE_WEIGHT`] above any stage's sum: a candidate that meets one more stage
//! ranks above every candidate that does not, whatever their later rows (CMA-ES uses ranks
//! only), so the search meets the take-off before it is scored on the landing, as the staged
//! solves do. A sum over all rows lets a flailing motion that misses every row a little beat
//! one that meets the early stage and misses a later one by much. The staged fitness of a
//! rollout is settled once a row of stage `k` is unmet and every row of the stages up to `k`
//! has passed its key time: the rollout ends there (the later steps change no term; a
//! rollout of a tumble that fails the take-off costs its first 0.3 s, not the whole horizon).
//! With shaping stages the staged search's target is [`SHAPED_TARGET`] (every shaping stage
//! met; the task's last rows are the solves' job).
//!
//! **Restart on a stalled stage** ([`STALL_RESTARTS`]): a staged search that stops (budget,
//! stall or collapse) without a candidate meeting a stage its start does not meet — its best
//! fitness has the start's `⌊fitness/W⌋` — runs once more from the start, with the same
//! budget, step size and population, on a fresh random stream; the better best of the two
//! runs is kept and their rollouts add up. CMA-ES's own stall test watches the best value,
//! which keeps falling by small amounts within the take-off stage's sum while no candidate
//! meets it, so IPOP's population doubling never fired on such a run (docs/notes/gait.md,
//! "round 3"); the stage count is the progress that matters. The first run's stream is the
//! one without restarts, so a search that meets a stage is unchanged.
//!
//! A rollout that fails before its fitness is settled scores +∞. The search stops when the
//! fitness reaches its target (unstaged: within the trial's tolerance, every row met), after `generations` generations or `evaluations` rollouts, when the distribution
//! collapses, or on an interrupt; the best candidate seen (the start itself, bit for bit, if
//! none beat it) is returned.
//!
//! Deterministic: trial `k`'s search is seeded with the run's seed and `k`, each generation
//! on its own stream, and its candidates are rolled out in parallel into their own slots.

use std::time::Instant;

use super::cmaes::{Budget, Minimum, Stop, minimize};
use super::formulation::Formulation;
use super::sim::Simulator;
use super::spec::{GlobalSettings, Problem};
use super::spline::SplineControls;
use super::step_check::coarsened;
use crate::solver::log::LogTarget;

/// Generations between progress lines.
pub const PROGRESS_EVERY: usize = 10;

/// The weight of one unmet stage in the staged fitness (module header); the rows' units.
pub const STAGE_WEIGHT: f64 = 1e3;

/// The staged search's target when there are shaping stages: a fitness below `2·W` has every
/// shaping stage met (only the last stage, the task's rows after the last shaping horizon, may
/// be unmet), and the search hands that candidate to the solves (module header).
pub const SHAPED_TARGET: f64 = 2.0 * STAGE_WEIGHT;

/// Time between the samples of the time-relaxed term (s).
pub const SAMPLE_INTERVAL: f64 = 0.01;

/// The rows' stages for the staged fitness (module header): the stage of each row, the
/// number of stages, and the tolerance by which a row is met.
struct Stages {
    of_row: Vec<usize>,
    count: usize,
    tol: f64,
    /// For each stage `s`, the last key step of the rows in stages `≤ s`.
    settled_at: Vec<usize>,
}

impl Stages {
    /// The stages of `shaped`'s rows under `problem`'s shaping horizons.
    fn new(problem: &Problem, shaped: &Problem) -> Self {
        let horizons = problem.shaping_horizons();
        let of_row: Vec<usize> = shaped
            .constraints
            .iter()
            .map(|c| horizons.iter().filter(|&&h| h < c.time).count())
            .collect();
        let count = horizons.len() + 1;
        let mut settled_at = vec![0; count];
        for (c, &s) in shaped.constraints.iter().zip(&of_row) {
            settled_at[s] = settled_at[s].max(c.step);
        }
        for s in 1..count {
            settled_at[s] = settled_at[s].max(settled_at[s - 1]);
        }
        Stages {
            of_row,
            count,
            tol: problem.trials.tolerance,
            settled_at,
        }
    }

    /// The first stage with a row unmet at its key time among `at_key` (`count` when none;
    /// rows not yet reached hold 0, met).
    fn first_unmet(&self, at_key: &[f64]) -> usize {
        (0..at_key.len())
            .filter(|&r| at_key[r] > self.tol)
            .map(|r| self.of_row[r])
            .min()
            .unwrap_or(self.count)
    }

    /// Whether a rollout sampled up to step `step` has its fitness settled: a row of stage `s`
    /// is unmet and every row of the stages up to `s` has passed its key time, so the later
    /// steps change no term of the fitness (module header).
    fn settled(&self, at_key: &[f64], step: usize) -> bool {
        let first = self.first_unmet(at_key);
        first < self.count && step >= self.settled_at[first]
    }

    /// The staged fitness of rows with violations `at_key` at their key times and `least`
    /// at any time up to them (module header).
    fn fitness(&self, at_key: &[f64], least: &[f64]) -> f64 {
        let first = self.first_unmet(at_key);
        let sum: f64 = (0..at_key.len())
            .filter(|&r| self.of_row[r] <= first)
            .map(|r| at_key[r] + least[r])
            .sum();
        STAGE_WEIGHT * (self.count - first) as f64 + sum
    }
}

/// The rows' fitness of one rollout of motion parameters `x` (module header, without the box
/// term), by `stages` when given; +∞ when the rollout fails.
fn row_fitness(shaped: &Problem, steps: &[usize], x: &[f64], stages: Option<&Stages>) -> f64 {
    let controls = SplineControls {
        grid: shaped.knot_grid(),
        params: x[..shaped.spline_parameters()].to_vec(),
    };
    let rows = &shaped.constraints;
    let mut state = shaped.initial_of(x);
    let mut sim = Simulator::<f64>::new(&shaped.model).interruptible(&shaped.interrupt);
    let (mut at_key, mut least) = (vec![0.0; rows.len()], vec![f64::INFINITY; rows.len()]);
    let rolled = sim.rollout_while(&mut state, shaped.dt, steps, &controls, |k, s, sim| {
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
        !stages.is_some_and(|st| st.settled(&at_key, steps[k]))
    });
    match rolled {
        Ok(()) => match stages {
            Some(stages) => stages.fitness(&at_key, &least),
            None => at_key.iter().chain(&least).sum(),
        },
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
    /// Best motion parameters found (physical units): the search's start, bit for bit, when
    /// no candidate scored better.
    pub x: Vec<f64>,
    /// Its fitness (module header; the rows' units).
    pub fitness: f64,
    /// Rollouts.
    pub evaluations: usize,
    /// Generations.
    pub generations: usize,
    /// Why the search stopped.
    pub stop: Stop,
    /// Wall time (s).
    pub seconds: f64,
}

/// Restarts of a staged search that met no stage beyond its start's (module header).
pub const STALL_RESTARTS: usize = 1;

/// The stream of run `restart` of a search seeded `seed` (run 0: `seed` itself).
fn restart_seed(seed: u64, restart: usize) -> u64 {
    seed ^ (restart as u64).wrapping_mul(0xD1B5_4A32_D192_ED03)
}

/// The seed of trial `trial`'s search, from the run's `seed`.
pub fn trial_seed(seed: u64, trial: usize) -> u64 {
    seed ^ (trial as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
}

/// Runs the global phase of trial `trial` from motion parameters `x0` (physical units;
/// [`crate::gait::trials::starts`]). With `log` it writes a progress line every
/// [`PROGRESS_EVERY`] generations and one at the end, prefixed with `stage`.
pub fn search(
    problem: &Problem,
    settings: &GlobalSettings,
    x0: &[f64],
    seed: u64,
    trial: usize,
    log: Option<&LogTarget>,
) -> GlobalReport {
    let clock = Instant::now();
    let shaped = coarsened(&problem.shaped(), settings.coarsening);
    let steps = sample_steps(&shaped);
    let stages = settings.staged.then(|| Stages::new(problem, &shaped));
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
            let [lo, hi] = act.control_range();
            scale.push(0.5 * (hi - lo));
        }
    }
    let fitness = |u: &[f64]| -> f64 {
        let mut x = x0.to_vec();
        let mut outside = 0.0;
        for ((&j, &s), &uj) in index.iter().zip(&scale).zip(u) {
            let v = (uj * s).clamp(lower[j], upper[j]);
            outside += (uj - v / s).powi(2);
            x[j] = v;
        }
        row_fitness(&shaped, &steps, &x, stages.as_ref()) + outside
    };
    let u0: Vec<f64> = index.iter().zip(&scale).map(|(&j, &s)| x0[j] / s).collect();
    let budget = Budget {
        generations: settings.generations,
        evaluations: settings.evaluations,
        target: match &stages {
            Some(st) if st.count > 1 => SHAPED_TARGET,
            _ => problem.trials.tolerance,
        },
    };
    let say = |text: String| {
        if let Some(log) = log {
            log.line(&format!("{} global: {text}", log.stage));
        }
    };
    // A staged search that ends without meeting a stage its start does not meet runs again
    // from the start on a fresh stream (module header), [`STALL_RESTARTS`] times at most.
    let level = |v: f64| (v / STAGE_WEIGHT).floor();
    let start_level = stages.as_ref().map(|_| level(fitness(&u0)));
    let mut best: Option<Minimum> = None;
    for restart in 0..=STALL_RESTARTS {
        if restart > 0 {
            say(format!(
                "no stage met beyond the start's: restart {restart} from the start"
            ));
        }
        let run = minimize(
            fitness,
            &u0,
            settings.sigma,
            settings.population,
            budget,
            restart_seed(trial_seed(seed, trial), restart),
            |g| {
                if g.generation.is_multiple_of(PROGRESS_EVERY) {
                    say(format!(
                        "generation {}, {} rollouts, best fitness {:.3e}, σ {:.3}, {:.1} s",
                        g.generation,
                        g.evaluations,
                        g.best,
                        g.sigma,
                        clock.elapsed().as_secs_f64()
                    ));
                }
                !problem.interrupt.is_raised()
            },
        );
        let stalled = start_level.is_some_and(|l| level(run.value) >= l)
            && !matches!(run.stop, Stop::Target | Stop::Stopped);
        best = Some(match best {
            None => run,
            Some(b) => Minimum {
                generations: b.generations + run.generations,
                evaluations: b.evaluations + run.evaluations,
                stop: run.stop,
                ..if run.value < b.value { run } else { b }
            },
        });
        if !stalled {
            break;
        }
    }
    let best = best.expect("at least one run");
    // The start itself, bit for bit, when no candidate beat it.
    let mut x = x0.to_vec();
    if best.x != u0 {
        for ((&j, &s), &uj) in index.iter().zip(&scale).zip(&best.x) {
            x[j] = (uj * s).clamp(lower[j], upper[j]);
        }
    }
    let seconds = clock.elapsed().as_secs_f64();
    say(format!(
        "{:?} after {} generations, {} rollouts, {seconds:.1} s: fitness {:.3e}",
        best.stop, best.generations, best.evaluations, best.value
    ));
    GlobalReport {
        x,
        fitness: best.value,
        evaluations: best.evaluations,
        generations: best.generations,
        stop: best.stop,
        seconds,
    }
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
            staged: false,
            fallback: false,
            coarsening: 1,
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

    /// A restart's stream differs from the first run's, which is the search's own seed.
    #[test]
    fn restarts_draw_fresh_streams_and_the_first_run_keeps_the_seed() {
        let seed = trial_seed(8, 6);
        assert_eq!(restart_seed(seed, 0), seed);
        assert_ne!(restart_seed(seed, 1), seed);
        assert_ne!(restart_seed(seed, 1), trial_seed(8, 7));
    }

    /// Four rows at key steps 10 (stage 0), 20 and 25 (stage 1) and 40 (stage 2).
    fn three_stages() -> Stages {
        Stages {
            of_row: vec![0, 1, 1, 2],
            count: 3,
            tol: 1e-3,
            settled_at: vec![10, 25, 40],
        }
    }

    /// The staged fitness ranks by the first unmet stage: meeting the early stage beats any
    /// later rows, and among candidates failing the same stage the smaller sum wins.
    #[test]
    fn the_staged_fitness_ranks_the_first_unmet_stage_first() {
        let stages = three_stages();
        let zero = [0.0; 4];
        // Stage 0 met, stage 1 missed by much; against stage 0 missed a little.
        let early_met = stages.fitness(&[0.0, 2.0, 2.0, 5.0], &zero);
        let early_missed = stages.fitness(&[0.01, 0.0, 0.0, 0.0], &zero);
        assert!(early_met < early_missed, "{early_met} vs {early_missed}");
        assert_eq!(early_met, STAGE_WEIGHT * 2.0 + 4.0);
        // All met: the sum over every row, below the tolerance sum.
        let all = stages.fitness(&[1e-4, 0.0, 2e-4, 0.0], &[1e-4, 0.0, 0.0, 0.0]);
        assert!((all - 4e-4).abs() < 1e-15, "{all}");
        // The time-relaxed term counts within the deciding stage.
        let a = stages.fitness(&[0.5, 0.0, 0.0, 0.0], &[0.5, 0.0, 0.0, 0.0]);
        let b = stages.fitness(&[0.5, 0.0, 0.0, 0.0], &[0.1, 0.0, 0.0, 0.0]);
        assert!(b < a);
    }

    /// A rollout's staged fitness is settled once a row of stage `s` is unmet and the last key
    /// step of the stages up to `s` is reached; not while every reached row is met.
    #[test]
    fn the_staged_fitness_settles_after_the_first_unmet_stage_key_times() {
        let stages = three_stages();
        let take_off_missed = [0.5, 0.0, 0.0, 0.0];
        assert!(!stages.settled(&take_off_missed, 9));
        assert!(stages.settled(&take_off_missed, 10));
        let landing_missed = [0.0, 0.2, 0.0, 0.0];
        assert!(!stages.settled(&landing_missed, 20));
        assert!(stages.settled(&landing_missed, 25));
        assert!(!stages.settled(&[0.0; 4], 40));
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
            staged: false,
            fallback: false,
            coarsening: 1,
        };
        let x0 = vec![0.0; p.motion_parameters()];
        let r = search(&p, &settings, &x0, 8, 1, None);
        assert_eq!((r.stop, r.generations), (Stop::Stopped, 1));
        assert_eq!(r.x, x0);
    }
}
