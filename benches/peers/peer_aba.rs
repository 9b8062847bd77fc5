//! Exports a gait character and our articulated-body algorithm's results for a side-by-side
//! comparison with another rigid-body library (benches/peers/pinocchio_aba.py).
//!
//! Usage: `cargo run --release --example peer_aba -- PROBLEM.toml STATES SEED > out.json`
//!
//! Writes JSON to stdout: the model (per link: parent, joint kind and unit axis, joint origin in
//! the parent frame (m), mass (kg), centre of mass (m) and rotational inertia about it (kg·m²)
//! in link coordinates; gravity (m/s²)), `STATES` random states `(q, v, τ)` drawn uniformly
//! (ChaCha8 seeded with `SEED`; joint coordinates in ±1 rad or m, velocities in ±2, forces in
//! ±5), our accelerations `v̇ = ABA(q, v, τ)` (no contact or passive joint forces), and the
//! median time of one ABA call (kinematics + accelerations, ns) over 41 rounds of all states.
//! Coordinate conventions: src/gait/character.rs (planar root: q = (x, y, θ),
//! v = (ω_z, v_x, v_y) in link coordinates).

use std::path::PathBuf;
use std::time::Instant;

use optimize::gait::aba::Dynamics;
use optimize::gait::character::JointKind;
use optimize::gait::spatial::Force;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [path, states, seed] = args.as_slice() else {
        return Err("usage: peer_aba PROBLEM.toml STATES SEED".into());
    };
    let count: usize = states.parse().map_err(|e| format!("STATES: {e}"))?;
    let seed: u64 = seed.parse().map_err(|e| format!("SEED: {e}"))?;
    let problem = optimize::gait::load(&PathBuf::from(path)).map_err(|e| e.to_string())?;
    let m = &problem.model;
    let links: Vec<_> = m
        .links
        .iter()
        .map(|l| {
            let (kind, axis) = match l.joint {
                JointKind::Revolute { axis } => ("revolute", axis),
                JointKind::Prismatic { axis } => ("prismatic", axis),
                JointKind::Planar => ("planar", [0.0, 0.0, 1.0]),
                JointKind::Floating => ("floating", [0.0; 3]),
            };
            serde_json::json!({
                "name": l.name,
                "parent": l.parent,
                "joint": kind,
                "axis": axis,
                "origin": l.origin,
                "mass": l.inertia.mass,
                "com": l.inertia.com.0,
                "inertia": l.inertia.inertia_com.0,
            })
        })
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut draw =
        |n: usize, a: f64| -> Vec<f64> { (0..n).map(|_| rng.random_range(-a..a)).collect() };
    let samples: Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> = (0..count)
        .map(|_| (draw(m.nq, 1.0), draw(m.nv, 2.0), draw(m.nv, 5.0)))
        .collect();
    let mut d = Dynamics::<f64>::new(m);
    let f_ext = vec![Force::zero(); m.links.len()];
    let mut vdot = vec![0.0; m.nv];
    let accelerations: Vec<Vec<f64>> = samples
        .iter()
        .map(|(q, v, tau)| {
            d.kinematics(m, q, v);
            d.accelerations(m, tau, &f_ext, &mut vdot);
            vdot.clone()
        })
        .collect();
    let mut rounds = Vec::new();
    for _ in 0..41 {
        let clock = Instant::now();
        for (q, v, tau) in &samples {
            d.kinematics(m, q, v);
            d.accelerations(m, tau, &f_ext, &mut vdot);
            std::hint::black_box(&vdot);
        }
        rounds.push(clock.elapsed().as_secs_f64() * 1e9 / count.max(1) as f64);
    }
    rounds.sort_by(f64::total_cmp);
    let out = serde_json::json!({
        "problem": problem.name(),
        "gravity": m.gravity,
        "nq": m.nq,
        "nv": m.nv,
        "links": links,
        "q": samples.iter().map(|s| &s.0).collect::<Vec<_>>(),
        "v": samples.iter().map(|s| &s.1).collect::<Vec<_>>(),
        "tau": samples.iter().map(|s| &s.2).collect::<Vec<_>>(),
        "vdot": accelerations,
        "aba_ns_median": rounds[rounds.len() / 2],
    });
    println!("{out}");
    Ok(())
}
