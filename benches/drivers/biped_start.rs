//! A hand-made start for the biped hop (problems/gait/biped_hop.toml), found by a derivative-free
//! search over a symmetric force profile.
//!
//! Both legs get the same torques: the first three actuators (hip, knee, ankle of the left leg)
//! are searched, the next three (right leg) copy them. The searched values are the knot values
//! at knots 1–6 (t = 0.1…0.6 s with the file's 11 knots); the knot at t = 0 and the knots after
//! 0.6 s stay at zero force (the servo hold brings the biped to rest), all slopes at zero, and
//! every value is clamped into the spline box the solver uses
//! ([`optimize::gait::formulation::Formulation::physical_bounds`]). The score is the sum of
//! squared pose-constraint violations (m², m²/s²) of one rollout plus 1e-6 × the effort
//! `∫ΣF²dt` (N²·s), minimized by a (1+1) evolution strategy (Gaussian steps from a
//! `ChaCha8Rng`, step size ×1.5 after a success and ×0.975 after a failure, within [0.02, 3]
//! N·m). Starting from the file's current start, it prints the knot values per left-leg
//! actuator (N·m), to be written into the file's `start` arrays for both legs.
//!
//! Usage: `cargo run --release --example biped_start -- problems/gait/biped_hop.toml 2000 1`
//! (file, rollouts, seed). About 0.03 s of CPU per rollout at the file's dt = 2e-4 s.

use optimize::gait::formulation::Formulation;
use optimize::gait::reduced::Reduced;
use optimize::solver::{Bounds, Nlp};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Actuators of one leg (hip, knee, ankle); the other leg's follow in the same order.
const LEG: usize = 3;
/// Knots whose values are searched.
const KNOTS: std::ops::Range<usize> = 1..7;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 4 {
        eprintln!("usage: biped_start FILE ROLLOUTS SEED");
        std::process::exit(2);
    }
    let problem = optimize::gait::load(std::path::Path::new(&args[1])).unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(2)
    });
    let rollouts: usize = args[2].parse().expect("ROLLOUTS is a count");
    let seed: u64 = args[3].parse().expect("SEED is an integer");
    assert_eq!(
        problem.model.actuators.len(),
        2 * LEG,
        "a two-legged character"
    );
    let nlp = Reduced::new(&problem);
    let d = nlp.dims();
    let k = nlp.grid().knots;
    let block = nlp.grid().per_actuator();
    let formulation = Formulation::new(&problem);
    let (lo, hi) = formulation.physical_bounds();
    let rows = Bounds::of(&nlp);
    let params = |z: &[f64]| {
        let mut x = vec![0.0; d.n];
        for a in 0..LEG {
            for (i, knot) in KNOTS.enumerate() {
                let v = z[a * KNOTS.len() + i];
                x[a * block + knot] = v;
                x[(a + LEG) * block + knot] = v;
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
    let mut x0 = vec![0.0; d.n];
    nlp.start(&mut x0);
    let mut z: Vec<f64> = (0..LEG)
        .flat_map(|a| KNOTS.map(move |knot| a * block + knot))
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
    let names = ["hip", "knee", "ankle"];
    for (a, name) in names.iter().enumerate() {
        let values: Vec<f64> = (0..k)
            .map(|i| (x[a * block + i] * 100.0).round() / 100.0)
            .collect();
        println!("{name}: start = {values:?}");
    }
    println!("score {best:.4e}");
}
