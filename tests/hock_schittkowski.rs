//! Hock–Schittkowski problems solved from their standard starts with dense BFGS and with
//! exact Hessians; derivatives of every problem checked against central differences.

#[path = "common/hs.rs"]
mod hs;

use optimize::solver::{HessianMode, Nlp, Options, Solution, solve};

fn options(mode: HessianMode) -> Options {
    Options {
        hessian: mode,
        verbosity: 0,
        max_iterations: 3000,
        ..Options::default()
    }
}

/// Problems where the standard start leads descent methods to another local minimizer than
/// the book's (verified: the solver's point satisfies the KKT conditions checked below).
/// HS2: the x₁ < 0 valley (f = 4.9412); HS16: f = 3.9821; HS20: the start is clamped to
/// x₁ = −0.5, whose bound holds another minimizer (f = 40.1987); HS33: x = (0, 0, 2), f = −4;
/// HS55: the other end of its feasible segment, f = 20/3.
const OTHER_LOCAL_MINIMUM: [&str; 5] = ["HS2", "HS16", "HS20", "HS33", "HS55"];
/// HS13's minimizer (1, 0) is a cusp without KKT multipliers; methods based on KKT conditions
/// approach it with diverging multipliers and stall, so only feasibility and closeness
/// (|f − f*| ≤ 1e-2) are asserted.
const NO_KKT_POINT: [&str; 1] = ["HS13"];

/// Bound on `kkt_error`: the solver's tolerances apply to its automatically scaled problem, so
/// this independent unscaled check verifies signs and the convention, not the last digits.
const KKT_TOLERANCE: f64 = 1e-4;

/// |f − f*| ≤ 1e-6·max(1, |f*|) and violation ≤ 1e-6, with a success status.
fn solved(p: &hs::Hs, s: &Solution) -> bool {
    s.status.is_success()
        && (s.objective - p.fstar).abs() <= 1e-6 * p.fstar.abs().max(1.0)
        && p.violation(&s.x) <= 1e-6
}

/// Largest violation of the first-order conditions in the documented convention:
/// `∇f + Jᵀλ + z = 0`, λᵢ ≤ 0 only at an active lower bound, ≥ 0 only at an active upper one,
/// likewise z; relative to the size of the terms.
fn kkt_error(p: &hs::Hs, s: &Solution) -> f64 {
    let nlp = p.nlp(false);
    let d = nlp.dims();
    let mut grad = vec![0.0; d.n];
    let mut jac = vec![0.0; d.jac_nnz];
    nlp.eval_derivatives(&s.x, &mut grad, &mut jac).unwrap();
    let mut r = grad.clone();
    let mut size = grad.iter().fold(1.0_f64, |a, v| a.max(v.abs()));
    for i in 0..d.m {
        for j in 0..d.n {
            r[j] += s.lambda[i] * jac[i * d.n + j];
            size = size.max((s.lambda[i] * jac[i * d.n + j]).abs());
        }
    }
    let mut err = 0.0_f64;
    for j in 0..d.n {
        r[j] += s.z[j];
        err = err.max(r[j].abs() / size);
    }
    let (_, c) = p.values(&s.x);
    let side_error = |mult: f64, value: f64, lo: f64, hi: f64| {
        let gap = if mult < 0.0 {
            value - lo
        } else if mult > 0.0 {
            hi - value
        } else {
            0.0
        };
        if gap.is_finite() {
            (mult.abs() * gap.abs()) / size
        } else {
            mult.abs()
        }
    };
    for i in 0..d.m {
        err = err.max(side_error(s.lambda[i], c[i], p.cl[i], p.cu[i]));
    }
    for j in 0..d.n {
        err = err.max(side_error(s.z[j], s.x[j], p.xl[j], p.xu[j]));
    }
    err
}

fn run_set(mode: HessianMode) -> Vec<String> {
    let mut failures = Vec::new();
    let mut count = 0;
    for p in hs::all() {
        let nlp = p.nlp(mode == HessianMode::Exact);
        let s = solve(&nlp, &options(mode));
        let ok = solved(&p, &s);
        count += ok as usize;
        let kkt = kkt_error(&p, &s);
        println!(
            "{:>6} {:?}: {:?} f = {:.10e} (f* = {:.10e}) viol = {:.1e} kkt = {:.1e} iters = {} evals = {} {}",
            p.name,
            mode,
            s.status,
            s.objective,
            p.fstar,
            p.violation(&s.x),
            kkt,
            s.iterations,
            s.evaluations.functions,
            if ok { "" } else { "(not the book's optimum)" }
        );
        let expected = if NO_KKT_POINT.contains(&p.name) {
            (s.objective - p.fstar).abs() <= 1e-2 && p.violation(&s.x) <= 1e-6
        } else if OTHER_LOCAL_MINIMUM.contains(&p.name) {
            s.status.is_success() && !ok && p.violation(&s.x) <= 1e-6 && kkt <= KKT_TOLERANCE
        } else {
            ok && kkt <= KKT_TOLERANCE
        };
        if !expected {
            failures.push(p.name.to_string());
        }
    }
    println!(
        "{mode:?}: {count} of {} solved to the book's optimum",
        hs::all().len()
    );
    failures
}

#[test]
fn hs_set_with_bfgs() {
    let failures = run_set(HessianMode::Bfgs);
    assert!(
        failures.is_empty(),
        "unexpected outcomes with BFGS: {failures:?}"
    );
}

#[test]
fn hs_set_with_lbfgs() {
    let failures = run_set(HessianMode::Lbfgs);
    assert!(
        failures.is_empty(),
        "unexpected outcomes with L-BFGS: {failures:?}"
    );
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
