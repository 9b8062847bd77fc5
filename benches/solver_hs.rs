//! Hock–Schittkowski set: per-problem iterations and solve times (printed as a table), and
//! criterion timings of solving the whole set with dense BFGS and with exact Hessians.
//!
//! Run: `cargo bench --bench solver_hs`.

#[path = "../tests/common/hs.rs"]
mod hs;

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use optimize::solver::{HessianMode, Options, solve};

fn options(mode: HessianMode) -> Options {
    Options {
        hessian: mode,
        verbosity: 0,
        max_iterations: 3000,
        ..Options::default()
    }
}

/// Median wall time of `runs` solves, in milliseconds.
fn median_ms(p: &hs::Hs, mode: HessianMode, runs: usize) -> f64 {
    let mut t: Vec<f64> = (0..runs)
        .map(|_| {
            let start = Instant::now();
            black_box(solve(&p.nlp(mode == HessianMode::Exact), &options(mode)));
            start.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[runs / 2]
}

fn print_table() {
    println!(
        "{:>6} | {:>12} {:>5} {:>6} {:>9} | {:>12} {:>5} {:>6} {:>9}",
        "", "BFGS status", "iter", "evals", "ms", "exact status", "iter", "evals", "ms"
    );
    let (mut total_bfgs, mut total_exact) = (0.0, 0.0);
    for p in hs::all() {
        let mut line = format!("{:>6} |", p.name);
        for mode in [HessianMode::Bfgs, HessianMode::Exact] {
            let s = solve(&p.nlp(mode == HessianMode::Exact), &options(mode));
            let ms = median_ms(&p, mode, 5);
            if mode == HessianMode::Bfgs {
                total_bfgs += ms;
            } else {
                total_exact += ms;
            }
            let ok = (s.objective - p.fstar).abs() <= 1e-6 * p.fstar.abs().max(1.0)
                && p.violation(&s.x) <= 1e-6
                && s.status.is_success();
            let status = format!("{:?}{}", s.status, if ok { "" } else { "*" });
            line += &format!(
                " {:>12} {:>5} {:>6} {:>9.3} |",
                status, s.iterations, s.evaluations.functions, ms
            );
        }
        println!("{line}");
    }
    println!(
        "total ms: BFGS {total_bfgs:.2}, exact {total_exact:.2}   (* = not the book's optimum)"
    );
}

fn bench_hs(c: &mut Criterion) {
    print_table();
    let problems = hs::all();
    let mut group = c.benchmark_group("hs_set");
    group.sample_size(10);
    for (name, mode) in [("bfgs", HessianMode::Bfgs), ("exact", HessianMode::Exact)] {
        group.bench_function(name, |b| {
            b.iter(|| {
                for p in &problems {
                    black_box(solve(&p.nlp(mode == HessianMode::Exact), &options(mode)));
                }
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_hs);
criterion_main!(benches);
