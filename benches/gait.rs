//! Gait benchmarks: one ABA call per character, 1 s of simulated Luxo motion, and one full exact
//! gradient of the Luxo leap (all 42 spline parameters; the default path: RK4 forward
//! sensitivities with analytical ABA derivatives), whose time divided by the simulation's is the
//! gradient/simulation ratio; for comparison the dual-number oracle (chunks of 8 duals, one
//! thread) and the discrete-tangent Jacobian. The ratio is also measured directly by timing the
//! simulation and the gradient alternately (medians of 15 pairs, wall and on-CPU time) and
//! printed. The biped hop: one rollout and one exact gradient at its hand-made start.

use std::path::PathBuf;
use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use optimize::gait::aba::Dynamics;
use optimize::gait::reduced::Reduced;
use optimize::gait::sim::Simulator;
use optimize::gait::spatial::Force;
use optimize::gait::spline::{KnotGrid, SplineControls};
use optimize::solver::Nlp;

fn problem(name: &str) -> optimize::gait::Problem {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("problems/gait/{name}.toml"));
    optimize::gait::load(&path).expect("problem file loads")
}

/// Luxo start parameters: a crouch-and-push torque profile (the shipped start is all zeros).
fn luxo_params(nlp: &Reduced<'_>) -> Vec<f64> {
    let n = nlp.dims().n;
    let k = nlp.grid().knots;
    let mut x = vec![0.0; n];
    for a in 0..3 {
        for j in 0..k {
            let t = j as f64 / (k - 1) as f64;
            x[a * 2 * k + j] = [6.0, -4.0, 1.0][a] * (6.0 * t).sin();
        }
    }
    x
}

fn benches(c: &mut Criterion) {
    for name in ["pogo_jump", "luxo_leap", "biped_hop"] {
        let p = problem(name);
        let m = &p.model;
        let mut d = Dynamics::<f64>::new(m);
        let tau = vec![0.1; m.nv];
        let f_ext = vec![Force::zero(); m.links.len()];
        let mut vdot = vec![0.0; m.nv];
        c.bench_function(&format!("aba/{name}"), |b| {
            b.iter(|| {
                d.kinematics(m, &p.initial.q, &p.initial.v);
                d.accelerations(m, &tau, &f_ext, &mut vdot);
                std::hint::black_box(&vdot);
            })
        });
    }

    let p = problem("luxo_leap");
    let nlp = Reduced::new(&p);
    let x = luxo_params(&nlp);
    let grid = KnotGrid {
        knots: p.knots,
        horizon: p.horizon,
    };
    let steps = (1.0 / p.dt).round() as usize;
    let mut group = c.benchmark_group("luxo");
    group.sample_size(10);
    let simulate = || {
        let controls = SplineControls {
            grid,
            params: x.clone(),
        };
        let mut sim = Simulator::<f64>::new(&p.model);
        let mut s = p.initial.clone();
        for n in 0..steps {
            sim.step(n as f64 * p.dt, p.dt, &mut s, &controls)
                .expect("finite");
        }
        std::hint::black_box(s);
    };
    let d = nlp.dims();
    let (mut grad, mut jac) = (vec![0.0; d.n], vec![0.0; d.jac_nnz]);
    let mut gradient = || {
        nlp.eval_derivatives(&x, &mut grad, &mut jac)
            .expect("finite")
    };
    group.bench_function("simulate_1s", |b| b.iter(simulate));
    group.bench_function("exact_gradient", |b| b.iter(&mut gradient));
    // Direct ratio: alternate the two so that machine load affects both alike; wall time and,
    // where Linux reports it, this thread's on-CPU time (robust to other processes' load).
    let (mut t_sim, mut t_grad) = (Vec::new(), Vec::new());
    let (mut c_sim, mut c_grad) = (Vec::new(), Vec::new());
    for _ in 0..15 {
        let (t, c) = (Instant::now(), cpu_seconds());
        simulate();
        t_sim.push(t.elapsed().as_secs_f64());
        c_sim.push(cpu_seconds().zip(c).map(|(b, a)| b - a));
        let (t, c) = (Instant::now(), cpu_seconds());
        gradient();
        t_grad.push(t.elapsed().as_secs_f64());
        c_grad.push(cpu_seconds().zip(c).map(|(b, a)| b - a));
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (ms, mg) = (median(&mut t_sim), median(&mut t_grad));
    println!(
        "luxo interleaved medians: simulation {:.2} ms, exact gradient {:.2} ms, ratio {:.2}",
        ms * 1e3,
        mg * 1e3,
        mg / ms
    );
    let cpu = |v: Vec<Option<f64>>| v.into_iter().collect::<Option<Vec<f64>>>();
    if let (Some(mut cs), Some(mut cg)) = (cpu(c_sim), cpu(c_grad)) {
        let (ms, mg) = (median(&mut cs), median(&mut cg));
        println!(
            "luxo interleaved on-CPU medians: simulation {:.2} ms, exact gradient {:.2} ms, ratio {:.2}",
            ms * 1e3,
            mg * 1e3,
            mg / ms
        );
    }
    let (mut jac1, mut grad1) = (vec![0.0; d.jac_nnz], vec![0.0; d.n]);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("thread pool");
    group.bench_function("dual_oracle_1thread", |b| {
        b.iter(|| {
            one.install(|| {
                nlp.jacobian_by_parameter_duals(&x, &mut jac1, &mut grad1)
                    .expect("finite")
            })
        })
    });
    let mut jac2 = vec![0.0; d.jac_nnz];
    group.bench_function("jacobian_tangents", |b| {
        b.iter(|| {
            nlp.jacobian_by_tangents::<24>(&x, &mut jac2)
                .expect("finite")
        })
    });
    group.finish();

    // The biped hop at its hand-made start: one rollout to the last constraint time (the
    // reduced problem's `eval`) and one exact gradient + Jacobian, on one thread.
    let p = problem("biped_hop");
    let nlp = Reduced::new(&p);
    let d = nlp.dims();
    let mut x = vec![0.0; d.n];
    nlp.start(&mut x);
    let (mut f, mut rows) = (0.0, vec![0.0; d.m]);
    let (mut grad, mut jac) = (vec![0.0; d.n], vec![0.0; d.jac_nnz]);
    let mut group = c.benchmark_group("biped");
    group.sample_size(10);
    group.bench_function("rollout", |b| {
        b.iter(|| nlp.eval(&x, &mut f, &mut rows).expect("finite"))
    });
    group.bench_function("exact_gradient_1thread", |b| {
        b.iter(|| {
            one.install(|| {
                nlp.eval_derivatives(&x, &mut grad, &mut jac)
                    .expect("finite")
            })
        })
    });
    group.finish();
}

/// This thread's on-CPU time (s) from `/proc/thread-self/schedstat` (Linux), `None` elsewhere.
/// The exact gradient and the simulation both run on the calling thread.
fn cpu_seconds() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: f64 = text.split_whitespace().next()?.parse().ok()?;
    Some(ns * 1e-9)
}

criterion_group!(gait, benches);
criterion_main!(gait);
