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
    println!(
        "BFGS: {} of {} solved",
        hs::all().len() - failures.len(),
        hs::all().len()
    );
    assert!(failures.is_empty(), "unsolved with BFGS: {failures:?}");
}

#[test]
fn hs_set_with_exact_hessians() {
    let failures = run_set(HessianMode::Exact);
    println!(
        "exact: {} of {} solved",
        hs::all().len() - failures.len(),
        hs::all().len()
    );
    assert!(
        failures.is_empty(),
        "unsolved with exact Hessians: {failures:?}"
    );
}

#[path = "common/central.rs"]
mod central;

/// Points at which derivatives are checked: the start and a nearby perturbed point.
fn check_points(p: &hs::Hs) -> Vec<Vec<f64>> {
    let perturbed =
        p.x0.iter()
            .enumerate()
            .map(|(j, &x)| x * (1.0 + 0.05 * (j as f64 + 1.0).sin()) + 0.01 * (j as f64).cos())
            .collect();
    vec![p.x0.clone(), perturbed]
}

#[test]
fn hs_gradients_and_jacobians_match_central_differences() {
    for p in hs::all() {
        let nlp = p.nlp(false);
        let d = nlp.dims();
        for x in check_points(&p) {
            let mut grad = vec![0.0; d.n];
            let mut jac = vec![0.0; d.jac_nnz];
            nlp.eval_derivatives(&x, &mut grad, &mut jac).unwrap();
            let fd = central::jacobian(
                |x| {
                    let (f, mut c) = p.values(x);
                    c.insert(0, f);
                    c
                },
                &x,
            );
            for j in 0..d.n {
                assert!(
                    central::close(grad[j], fd[0][j], 1e-6),
                    "{} ∂f/∂x{j}",
                    p.name
                );
                for i in 0..d.m {
                    let v = jac[i * d.n + j];
                    assert!(
                        central::close(v, fd[i + 1][j], 1e-6),
                        "{} ∂c{i}/∂x{j}",
                        p.name
                    );
                }
            }
        }
    }
}

#[test]
fn hs_lagrangian_hessians_match_central_differences() {
    for p in hs::all() {
        let nlp = p.nlp(true);
        let d = nlp.dims();
        let sigma = 0.7;
        let lambda: Vec<f64> = (0..d.m).map(|i| 1.0 - 0.3 * i as f64).collect();
        let lagrangian_gradient = |x: &[f64]| {
            let mut grad = vec![0.0; d.n];
            let mut jac = vec![0.0; d.jac_nnz];
            nlp.eval_derivatives(x, &mut grad, &mut jac).unwrap();
            let mut g: Vec<f64> = grad.iter().map(|v| sigma * v).collect();
            for i in 0..d.m {
                for j in 0..d.n {
                    g[j] += lambda[i] * jac[i * d.n + j];
                }
            }
            g
        };
        let (mut rows, mut cols) = (vec![0; d.hess_nnz], vec![0; d.hess_nnz]);
        nlp.hessian_structure(&mut rows, &mut cols);
        for x in check_points(&p) {
            let mut values = vec![0.0; d.hess_nnz];
            nlp.eval_hessian(&x, sigma, &lambda, &mut values).unwrap();
            let fd = central::jacobian(lagrangian_gradient, &x);
            for k in 0..d.hess_nnz {
                assert!(rows[k] >= cols[k]);
                let (r, c) = (rows[k], cols[k]);
                assert!(
                    central::close(values[k], fd[r][c], 1e-5),
                    "{} H[{r}][{c}] = {} vs {}",
                    p.name,
                    values[k],
                    fd[r][c]
                );
            }
        }
    }
}
