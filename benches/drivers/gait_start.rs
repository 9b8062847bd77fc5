//! Hand-made starts for the gait task files, found by derivative-free search, and the passive
//! springs' set points that make a file's initial pose an equilibrium.
//!
//! `search FILE ROLLOUTS SEED [--knots A..B] [--mirror N] [--until T]`: the searched values are the
//! knot values at knots `A..B` (default: all but the first and the last) of every actuator; with
//! `--mirror N` only the first `N` actuators are searched and actuators `N..2N` copy them (a
//! symmetric gait: the biped's right leg copies its left). The other knots keep the file's `start`,
//! all slopes are zero, and every value is clamped into the spline box the solver uses
//! ([`optimize::gait::formulation::Formulation::physical_bounds`]). The score is the sum of squared
//! pose-constraint violations (task and shaping rows; m², rad², m²/s², rad²/s²) of one rollout plus 1e-6 × the effort
//! `∫ΣF²dt` (N²·s), minimized by a (1+1) evolution strategy (Gaussian steps from a `ChaCha8Rng`,
//! step size ×1.5 after a success and ×0.975 after a failure, within [0.02, 3] N·m). With
//! `--until T` only the pose constraints at times ≤ T s are scored (and simulated), e.g. a take-off searched
//! before its landing. Starting from the file's `start`, it prints the knot values per searched
//! actuator (N·m), to be written into the file's `start` arrays.
//!
//! `settle FILE SECONDS ROUNDS`: fixed-point iteration on the joint springs' `rest` values and the
//! root's initial pose so that the file's joint angles are held with zero actuator force. Each
//! round simulates SECONDS of zero-force motion from the current start and moves every sprung
//! joint's rest angle by the joint's drift `q₀ − q(T)`, and a planar root's height and pitch to
//! their values at `T` (the base sinks onto its contact springs). It prints the rest values, the
//! root pose and the largest drift and speed at `T` of the last round.
//!
//! `show FILE`: the file's start, one rollout: every pose constraint's value and bounds, and every
//! 0.05 s the root pose, the joint angles and the lowest contact point's height.
//!
//! Usage: `cargo run --release --example gait_start -- search problems/gait/biped_hop.toml 2000 1
//! --knots 1..7 --mirror 3`, `… -- settle problems/gait/luxo_leap.toml 2 20`. About 0.02 s (Luxo)
//! to 0.03 s (biped) of CPU per 1 s rollout at dt = 2e-4 s.

use optimize::gait::Problem;
use optimize::gait::character::JointKind;
use optimize::gait::formulation::Formulation;
use optimize::gait::reduced::Reduced;
use optimize::gait::sim::{Simulator, State};
use optimize::gait::spatial::Vec3;
use optimize::gait::spline::SplineControls;
use optimize::solver::{Bounds, Nlp};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let usage = || -> ! {
        eprintln!(
            "usage: gait_start search FILE ROLLOUTS SEED [--knots A..B] [--mirror N] [--until T]\n       \
             gait_start settle FILE SECONDS ROUNDS\n       gait_start show FILE"
        );
        std::process::exit(2)
    };
    if args.len() < 3 {
        usage();
    }
    // The file's shaping rows (`[[task]] shaping = true`) are scored like its task rows.
    let mut problem = optimize::gait::load(std::path::Path::new(&args[2]))
        .unwrap_or_else(|e| {
            eprintln!("{e}");
            std::process::exit(2)
        })
        .shaped();
    match args[1].as_str() {
        "show" => show(&problem),
        _ if args.len() < 5 => usage(),
        "search" => {
            let rollouts: usize = args[3].parse().unwrap_or_else(|_| usage());
            let seed: u64 = args[4].parse().unwrap_or_else(|_| usage());
            let mut knots = 1..problem.knots.saturating_sub(1);
            let mut mirror = None;
            let mut rest = args[5..].iter();
            while let Some(flag) = rest.next() {
                let value = rest.next().unwrap_or_else(|| usage());
                match flag.as_str() {
                    "--knots" => {
                        let (a, b) = value.split_once("..").unwrap_or_else(|| usage());
                        knots = a.parse().unwrap_or_else(|_| usage())
                            ..b.parse().unwrap_or_else(|_| usage());
                    }
                    "--mirror" => mirror = Some(value.parse().unwrap_or_else(|_| usage())),
                    "--until" => {
                        let until: f64 = value.parse().unwrap_or_else(|_| usage());
                        problem.constraints.retain(|c| c.time <= until);
                    }
                    _ => usage(),
                }
            }
            search(&problem, rollouts, seed, knots, mirror);
        }
        "settle" => {
            let seconds: f64 = args[3].parse().unwrap_or_else(|_| usage());
            let rounds: usize = args[4].parse().unwrap_or_else(|_| usage());
            settle(problem, seconds, rounds);
        }
        _ => usage(),
    }
}

/// The (1+1) evolution strategy over knot values (module header).
fn search(
    problem: &Problem,
    rollouts: usize,
    seed: u64,
    knots: std::ops::Range<usize>,
    mirror: Option<usize>,
) {
    let actuators = problem.model.actuators.len();
    let searched = mirror.unwrap_or(actuators);
    assert!(
        mirror.is_none_or(|n| 2 * n == actuators),
        "--mirror N needs 2N actuators"
    );
    assert!(
        knots.end <= problem.knots,
        "--knots beyond the file's knots"
    );
    let nlp = Reduced::new(problem);
    let d = nlp.dims();
    let block = nlp.grid().per_actuator();
    let formulation = Formulation::new(problem);
    let (lo, hi) = formulation.physical_bounds();
    let rows = Bounds::of(&nlp);
    let mut x0 = vec![0.0; d.n];
    nlp.start(&mut x0);
    let params = |z: &[f64]| {
        let mut x = x0.clone();
        for a in 0..searched {
            for (i, knot) in knots.clone().enumerate() {
                let v = z[a * knots.len() + i];
                x[a * block + knot] = v;
                if mirror.is_some() {
                    x[(a + searched) * block + knot] = v;
                }
            }
        }
        for j in 0..d.n {
            x[j] = x[j].clamp(lo[j], hi[j]);
        }
        x
    };
    let score = |x: &[f64]| -> f64 {
        let (mut effort, mut c) = (0.0, vec![0.0; d.m]);
        if nlp.eval(x, &mut effort, &mut c).is_err() {
            return f64::INFINITY;
        }
        let violation: f64 = (0..d.m)
            .map(|r| (rows.cl[r] - c[r]).max(c[r] - rows.cu[r]).max(0.0).powi(2))
            .sum();
        violation + 1e-6 * effort
    };
    let mut z: Vec<f64> = (0..searched)
        .flat_map(|a| knots.clone().map(move |knot| a * block + knot))
        .map(|j| x0[j])
        .collect();
    let mut best = score(&params(&z));
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut sigma = 1.0;
    for n in 0..rollouts {
        let candidate: Vec<f64> = z
            .iter()
            .map(|&v| {
                // Irwin–Hall approximation of a standard normal deviate.
                let g: f64 = (0..12).map(|_| rng.random_range(0.0..1.0)).sum::<f64>() - 6.0;
                v + sigma * g
            })
            .collect();
        let s = score(&params(&candidate));
        if s < best {
            (best, z) = (s, candidate);
            sigma *= 1.5;
        } else {
            sigma *= 0.975;
        }
        sigma = sigma.clamp(0.02, 3.0);
        if n % 200 == 0 {
            eprintln!("rollout {n}: score {best:.4e}, step {sigma:.3} N·m");
        }
    }
    let x = params(&z);
    for (a, actuator) in problem.model.actuators.iter().enumerate().take(searched) {
        let values: Vec<f64> = (0..problem.knots)
            .map(|i| (x[a * block + i] * 100.0).round() / 100.0)
            .collect();
        println!("{}: start = {values:?}", actuator.name);
    }
    println!("score {best:.4e}");
}

/// Fixed-point iteration on the springs' rest values and the root pose (module header).
fn settle(mut problem: Problem, seconds: f64, rounds: usize) {
    let target = problem.initial.q.clone();
    let steps = (seconds / problem.dt).round() as usize;
    let (mut drift, mut speed) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..rounds {
        let mut x: State<f64> = problem.initial.clone();
        let mut sim = Simulator::new(&problem.model);
        let zero = |_: f64, out: &mut [f64]| out.fill(0.0);
        if let Err(e) = sim.rollout(&mut x, problem.dt, &[steps], &zero, |_, _, _| ()) {
            eprintln!("{e}");
            std::process::exit(1);
        }
        drift = 0.0;
        for link in problem.model.links.iter_mut() {
            let i = link.q_index;
            match (&link.joint, link.spring.as_mut()) {
                (JointKind::Planar, _) => {
                    drift = drift.max((x.q[i + 1] - problem.initial.q[i + 1]).abs());
                    drift = drift.max((x.q[i + 2] - problem.initial.q[i + 2]).abs());
                    problem.initial.q[i + 1] = x.q[i + 1];
                    problem.initial.q[i + 2] = x.q[i + 2];
                }
                (_, Some(spring)) => {
                    drift = drift.max((target[i] - x.q[i]).abs());
                    spring.rest += target[i] - x.q[i];
                }
                _ => {}
            }
        }
        speed = x.v.iter().fold(0.0, |m, v| m.max(v.abs()));
        eprintln!("drift {drift:.3e}, speed {speed:.3e}");
    }
    for link in &problem.model.links {
        let i = link.q_index;
        match (&link.joint, link.spring) {
            (JointKind::Planar, _) => println!(
                "{}: position = [{:.5}, {:.5}], angle = {:.5}",
                link.name,
                problem.initial.q[i],
                problem.initial.q[i + 1],
                problem.initial.q[i + 2]
            ),
            (_, Some(spring)) => println!("{}: rest = {:.5}", link.name, spring.rest),
            _ => {}
        }
    }
    println!("last round: drift {drift:.3e} (m, rad), speed {speed:.3e} (m/s, rad/s)");
}

/// One rollout of the file's start, printed (module header).
fn show(problem: &Problem) {
    let nlp = Reduced::new(problem);
    let d = nlp.dims();
    let mut x = vec![0.0; d.n];
    nlp.start(&mut x);
    let (mut effort, mut c) = (0.0, vec![0.0; d.m]);
    if let Err(e) = nlp.eval(&x, &mut effort, &mut c) {
        eprintln!("{e:?}");
        std::process::exit(1);
    }
    for (row, constraint) in problem.constraints.iter().enumerate() {
        println!(
            "{:40} {:+.5}  [{}, {}]",
            constraint.name, c[row], constraint.lower, constraint.upper
        );
    }
    println!("effort {effort:.4} N²·s");
    let controls = SplineControls {
        grid: nlp.grid(),
        params: x[..nlp.parameters()].to_vec(),
    };
    let model = &problem.model;
    let every = (0.05 / problem.dt).round() as usize;
    let samples: Vec<usize> = (0..=(problem.horizon / 0.05).round() as usize)
        .map(|k| k * every)
        .collect();
    let mut state = problem.initial.clone();
    let mut sim = Simulator::new(model);
    let result = sim.rollout(&mut state, problem.dt, &samples, &controls, |k, x, sim| {
        let lowest = model
            .links
            .iter()
            .enumerate()
            .flat_map(|(i, l)| l.contacts.iter().map(move |p| (i, p)))
            .map(|(i, p)| sim.dynamics.point_position(i, &Vec3::from_f64(*p)).0[1])
            .fold(f64::INFINITY, f64::min);
        let q: Vec<String> = x.q.iter().map(|v| format!("{v:+.3}")).collect();
        println!(
            "t {:.2}  q [{}]  lowest contact {lowest:+.3}",
            samples[k] as f64 * problem.dt,
            q.join(" ")
        );
    });
    if let Err(e) = result {
        println!("{e}");
    }
}
