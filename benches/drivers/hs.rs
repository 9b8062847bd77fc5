//! Solves one Hock–Schittkowski problem with the live iteration log on stderr, or all of them
//! with one summary line each (name `all`).
//!
//! `cargo run --release --example hs -- HS71|all [bfgs|lbfgs|exact] [max_iterations] [x0,x1,…]`
//! (`QP=sparse|dense` forces the QP method, `GLOBALIZATION=trust_region` the trust region;
//! verbosity 2 adds the step, penalty and Hessian-shift details under each line).

#[path = "../../tests/common/hs.rs"]
mod hs;

use optimize::solver::log::LogTarget;
use optimize::solver::qp::QpMethod;
use optimize::solver::{Globalization, HessianMode, Options, solve};
use std::sync::{Arc, Mutex};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("HS71", String::as_str);
    let mode = match args.get(2).map(String::as_str) {
        Some("exact") => HessianMode::Exact,
        Some("lbfgs") => HessianMode::Lbfgs,
        _ => HessianMode::Bfgs,
    };
    let iterations = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(1000);
    let verbosity = std::env::var("VERBOSITY")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    let globalization = match std::env::var("GLOBALIZATION").as_deref() {
        Ok("trust_region") => Globalization::TrustRegion,
        _ => Globalization::LineSearch,
    };
    if name == "all" {
        let options = Options {
            hessian: mode,
            verbosity: 0,
            max_iterations: iterations,
            globalization,
            ..Options::default()
        };
        for problem in hs::all() {
            let s = solve(&problem.nlp(mode == HessianMode::Exact), &options);
            println!(
                "{}: {:?}, f = {:.10e} (book: {:.10e}), violation {:.1e}, {} iterations, {} evaluations",
                problem.name,
                s.status,
                s.objective,
                problem.fstar,
                problem.violation(&s.x),
                s.iterations,
                s.evaluations.functions
            );
        }
        return;
    }
    let Some(problem) = hs::all().into_iter().find(|p| p.name == name) else {
        eprintln!("unknown problem {name}");
        std::process::exit(2);
    };
    let problem = match args.get(4) {
        Some(list) => problem.with_start(list.split(',').filter_map(|v| v.parse().ok()).collect()),
        None => problem,
    };
    let options = Options {
        hessian: mode,
        verbosity,
        log: LogTarget::to(Arc::new(Mutex::new(std::io::stderr())), false),
        max_iterations: iterations,
        globalization,
        qp_method: match std::env::var("QP").as_deref() {
            Ok("sparse") => QpMethod::Sparse,
            Ok("dense") => QpMethod::Dense,
            _ => QpMethod::Auto,
        },
        ..Options::default()
    };
    let s = solve(&problem.nlp(mode == HessianMode::Exact), &options);
    println!(
        "{name}: {:?}, f = {:.10e} (book: {:.10e}), violation {:.1e}, {} iterations",
        s.status,
        s.objective,
        problem.fstar,
        problem.violation(&s.x),
        s.iterations
    );
    println!("x = {:?}\nλ = {:?}\nz = {:?}", s.x, s.lambda, s.z);
}
