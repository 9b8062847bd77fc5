//! Solves the generated chained problem of `tests/common/large.rs` once and prints the
//! status, time, iterations, distance to the manufactured KKT point and peak memory.
//!
//! `cargo run --release --example large_solve -- [n] [lbfgs|exact] [max_iterations]`
//! (defaults: n = 50000, exact; m = ⌊2n/5⌋ nonlinear equalities). Peak memory is the
//! process's resident high-water mark `VmHWM` from /proc/self/status (Linux). `VERBOSITY=0`
//! silences the iteration log; `QP=dense|sparse` forces the QP method.

#[path = "../../tests/common/large.rs"]
#[allow(dead_code)]
mod large;

use large::ChainedRosenbrock;
use optimize::solver::qp::QpMethod;
use optimize::solver::{HessianMode, Nlp, Options, solve};

fn peak_memory() -> String {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .map(|l| l["VmHWM:".len()..].trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into())
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(50_000);
    let mode = match args.get(2).map(String::as_str) {
        Some("lbfgs") => HessianMode::Lbfgs,
        _ => HessianMode::Exact,
    };
    let max_iterations = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(1000);
    let verbosity = std::env::var("VERBOSITY")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    let nlp = ChainedRosenbrock::new(n);
    let options = Options {
        hessian: mode,
        max_iterations,
        verbosity,
        qp_method: match std::env::var("QP").as_deref() {
            Ok("dense") => QpMethod::Dense,
            Ok("sparse") => QpMethod::Sparse,
            _ => QpMethod::Auto,
        },
        ..Options::default()
    };
    let s = solve(&nlp, &options);
    let error =
        s.x.iter()
            .zip(nlp.solution())
            .fold(0.0_f64, |a, (x, y)| a.max((x - y).abs()));
    println!(
        "n = {n}, m = {}, {mode:?}: {:?} in {:.2} s, {} iterations, {} evaluations, f = {:.10e} (f* = {:.10e}), violation {:.1e}, optimality {:.1e}, max|x − x*| = {error:.1e}, peak memory {}",
        nlp.dims().m,
        s.status,
        s.seconds,
        s.iterations,
        s.evaluations.functions,
        s.objective,
        nlp.optimal_objective(),
        s.max_violation,
        s.optimality,
        peak_memory()
    );
}
