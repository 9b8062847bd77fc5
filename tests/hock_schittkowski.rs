//! Hock–Schittkowski problems solved from their standard starts with dense BFGS and with
//! exact Hessians; derivatives of every problem checked against central differences.

#[path = "common/hs.rs"]
mod hs;

use optimize::solver::qp::QpMethod;
use optimize::solver::{Globalization, HessianMode, Nlp, Options, Solution, Status, solve};

fn options(mode: HessianMode) -> Options {
    Options {
        hessian: mode,
        verbosity: 0,
        max_iterations: 3000,
        ..Options::default()
    }
}

/// Outcomes of the set through one QP method.
struct SetOutcome {
    /// Problems whose outcome is not the expected one (see `run_set`).
    failures: Vec<String>,
    /// Problems solved to the book's optimum.
    solved: usize,
    /// Problems ending with a success status at a point that is not a verified KKT point.
    false_successes: Vec<String>,
}

/// Problems where the standard start leads descent methods to another local minimizer than
/// the book's (verified: the solver's point satisfies the KKT conditions checked below).
/// HS2: the x₁ < 0 valley (f = 4.9412); HS16: f = 3.9821; HS20: the start is clamped to
/// x₁ = −0.5, whose bound holds another minimizer (f = 40.1987); HS33: x = (0, 0, 2), f = −4;
/// HS55: the other end of its feasible segment, f = 20/3. HS25: the start lies on a plateau
/// where every partial derivative is below 1e-8 (the model term is exp(−22) or smaller), so
/// it is itself stationary to the tolerance.
const OTHER_LOCAL_MINIMUM: [&str; 6] = ["HS2", "HS16", "HS20", "HS25", "HS33", "HS55"];
/// With the exact Hessian, HS108 (the largest hexagon of diameter 1) ends at another KKT point,
/// f = −0.5, rather than the book's −0.866: once no row augmentation alone makes the Hessian
/// definite, the shift confined to the null space of the expected-active rows comes with the
/// augmentation term over those rows, inequalities included, which holds the first QPs on
/// rows the uniformly shifted model left (see `hessian::exact`). A verified KKT point is
/// required.
const EXACT_OTHER_LOCAL_MINIMUM: [&str; 1] = ["HS108"];
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
    for (rj, zj) in r.iter_mut().zip(&s.z) {
        *rj += zj;
        err = err.max(rj.abs() / size);
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
    for (i, &ci) in c.iter().enumerate() {
        err = err.max(side_error(s.lambda[i], ci, p.cl[i], p.cu[i]));
    }
    for (j, &xj) in s.x.iter().enumerate() {
        err = err.max(side_error(s.z[j], xj, p.xl[j], p.xu[j]));
    }
    err
}

fn run_set(mode: HessianMode) -> Vec<String> {
    run_set_with(mode, QpMethod::Auto, Globalization::LineSearch).failures
}

fn run_set_with(
    mode: HessianMode,
    qp_method: QpMethod,
    globalization: Globalization,
) -> SetOutcome {
    let mut failures = Vec::new();
    let mut false_successes = Vec::new();
    let mut count = 0;
    for p in hs::all() {
        let nlp = p.nlp(mode == HessianMode::Exact);
        let s = solve(
            &nlp,
            &Options {
                qp_method,
                globalization,
                ..options(mode)
            },
        );
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
        let expected = if mode == HessianMode::Exact && EXACT_OTHER_LOCAL_MINIMUM.contains(&p.name)
        {
            s.status.is_success() && p.violation(&s.x) <= 1e-6 && kkt <= KKT_TOLERANCE
        } else if NO_KKT_POINT.contains(&p.name) {
            (s.objective - p.fstar).abs() <= 1e-2 && p.violation(&s.x) <= 1e-6
        } else if OTHER_LOCAL_MINIMUM.contains(&p.name) {
            s.status.is_success() && !ok && p.violation(&s.x) <= 1e-6 && kkt <= KKT_TOLERANCE
        } else if mode == HessianMode::Lbfgs {
            // L-BFGS (meant for large problems) follows other paths than dense BFGS; it must
            // end at a verified KKT point, the book's or another local one.
            s.status.is_success() && p.violation(&s.x) <= 1e-6 && kkt <= KKT_TOLERANCE
        } else {
            ok && kkt <= KKT_TOLERANCE
        };
        if !expected {
            failures.push(p.name.to_string());
        }
        // `Acceptable` promises the tolerances within a factor 100 only.
        let slack = if s.status == Status::Acceptable {
            100.0
        } else {
            1.0
        };
        if s.status.is_success()
            && !NO_KKT_POINT.contains(&p.name)
            && (p.violation(&s.x) > 1e-6 * slack || kkt > KKT_TOLERANCE * slack)
        {
            false_successes.push(p.name.to_string());
        }
    }
    println!(
        "{mode:?} ({qp_method:?} QP, {globalization:?}): {count} of {} solved to the book's optimum",
        hs::all().len()
    );
    SetOutcome {
        failures,
        solved: count,
        false_successes,
    }
}

/// The whole set through the sparse interior-point QP (the large-problem path, forced):
/// every success must be a verified KKT point (to the factor 100 `Acceptable` allows), and at
/// least `least` problems must reach the book's optimum (the counts measured with the
/// active-set polish of degenerate QP solutions, which brought BFGS to the dense path's 77;
/// docs/notes/solver.md lists the problems that differ from the dense path).
fn sparse_path(mode: HessianMode, least: usize) {
    let outcome = run_set_with(mode, QpMethod::Sparse, Globalization::LineSearch);
    println!(
        "{mode:?} sparse-path outcomes differing from the dense path: {:?}",
        outcome.failures
    );
    assert!(
        outcome.false_successes.is_empty(),
        "false successes through the sparse QP with {mode:?}: {:?}",
        outcome.false_successes
    );
    assert!(
        outcome.solved >= least,
        "{mode:?} through the sparse QP: {} solved, expected at least {least}",
        outcome.solved
    );
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

/// The trust region instead of the line search: the same expected outcomes with BFGS (where
/// the line search needs the noise allowance on HS116, 1000 iterations, the trust region takes
/// 169); with exact Hessians two misses are allowed, both seen while the steering rule was
/// tuned: HS111 stalling at f − f* = −4.6e-7, violation 1.6e-8 (the QP step near the solution
/// increased the linearized violation), HS108 at its other KKT point f = −0.5 (see
/// `EXACT_OTHER_LOCAL_MINIMUM`), and HS116 stalling at f − f* = 1e-7 or ending at another
/// verified KKT point (f = 97.5910 against the book's 97.5875; a false success would fail the
/// second condition).
#[test]
fn hs_set_with_trust_region() {
    let bfgs = run_set_with(
        HessianMode::Bfgs,
        QpMethod::Auto,
        Globalization::TrustRegion,
    );
    assert!(
        bfgs.failures.is_empty() && bfgs.false_successes.is_empty(),
        "trust region with BFGS: unexpected {:?}, false successes {:?}",
        bfgs.failures,
        bfgs.false_successes
    );
    let exact = run_set_with(
        HessianMode::Exact,
        QpMethod::Auto,
        Globalization::TrustRegion,
    );
    assert!(
        exact
            .failures
            .iter()
            .all(|name| ["HS108", "HS111", "HS116"].contains(&name.as_str()))
            && exact.false_successes.is_empty(),
        "trust region with exact Hessians: unexpected {:?}, false successes {:?}",
        exact.failures,
        exact.false_successes
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

/// From perturbed starts the solver may end anywhere (HS63 from (1.18, 2.98, 1.51) ends
/// `Infeasible` at the vertex (0, 4, 0), a strict local minimizer of the ℓ1 violation), but a
/// success status must be true:
/// every Optimal or Acceptable ending is checked independently for feasibility and the KKT
/// conditions. Also exercises starts where the functions are undefined (NaN). The KKT bound
/// is 10× looser than for the standard starts: the objective scale is fixed from the
/// gradient at the start, and a start near a pole (HS64 at x ≈ 0.6: ‖∇f‖ ≈ 1e5) turns the
/// scaled tolerance into a larger unscaled one.
#[test]
fn hs_random_starts_never_report_false_success() {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2003);
    let mut tally = std::collections::BTreeMap::new();
    for p in hs::all() {
        for trial in 0..4 {
            // Alternate dense BFGS and exact Hessians over the starts.
            let exact = trial % 2 == 1;
            let x0: Vec<f64> = (0..p.n())
                .map(|j| {
                    let scale = p.x0[j].abs().max(1.0);
                    (p.x0[j] + scale * rng.random_range(-0.5..0.5)).clamp(p.xl[j], p.xu[j])
                })
                .collect();
            let moved = p.with_start(x0);
            let mode = if exact {
                HessianMode::Exact
            } else {
                HessianMode::Bfgs
            };
            let s = solve(&moved.nlp(exact), &options(mode));
            *tally.entry(format!("{:?}", s.status)).or_insert(0) += 1;
            if !s.status.is_success() {
                println!("{} ({mode:?}) from {:?}: {:?}", p.name, moved.x0, s.status);
            }
            if s.status.is_success() {
                let loose = if s.status == optimize::solver::Status::Acceptable {
                    100.0
                } else {
                    1.0
                };
                assert!(
                    moved.violation(&s.x)
                        <= 1e-6
                            * loose
                            * moved
                                .cl
                                .iter()
                                .chain(&moved.cu)
                                .filter(|v| v.is_finite())
                                .fold(1.0_f64, |a, v| a.max(v.abs())),
                    "{} from {:?}: violation {}",
                    p.name,
                    moved.x0,
                    moved.violation(&s.x)
                );
                assert!(
                    kkt_error(&moved, &s) <= 10.0 * KKT_TOLERANCE * loose,
                    "{} from {:?}: KKT error {}",
                    p.name,
                    moved.x0,
                    kkt_error(&moved, &s)
                );
            }
        }
    }
    println!("outcomes from perturbed starts: {tally:?}");
}

#[test]
fn hs_set_with_bfgs_through_the_sparse_qp() {
    sparse_path(HessianMode::Bfgs, 77);
}

#[test]
fn hs_set_with_lbfgs_through_the_sparse_qp() {
    sparse_path(HessianMode::Lbfgs, 76);
}

#[test]
fn hs_set_with_exact_hessians_through_the_sparse_qp() {
    sparse_path(HessianMode::Exact, 75);
}

/// Problems whose perturbed starts may lead to another local minimizer than the book's, each
/// seen and verified to be a KKT point by `kkt_error` (the assertions below still require
/// feasibility and the first-order conditions there): the standard-start list, plus HS44 (an
/// indefinite QP with several vertex minima, f = −13), HS116 (f = 97.591, the other KKT point
/// the trust-region test allows as well) and HS108/HS111 (other stationary points of their
/// nonconvex constraints).
const PERTURBED_OTHER_MINIMUM: [&str; 6] = ["HS44", "HS61", "HS81", "HS108", "HS111", "HS116"];

/// Quasi-Newton solves from perturbed starts that end Stalled, left as known weaknesses of the
/// BFGS models on HS116 (13 variables, 15 nonlinear inequalities, curvature along the active
/// rows over six orders of magnitude): BFGS stalls at or next to the local minima f = 97.591
/// and 97.5877 with multipliers it cannot settle, L-BFGS at 122–153. The exact Hessian solves
/// every start.
const QUASI_NEWTON_STALLS: [&str; 1] = ["HS116"];

/// Five starts per problem, each the standard start with 10 % noise
/// (`x0ⱼ + 0.1·max(1, |x0ⱼ|)·u`, u uniform in [−1, 1], clamped to the bounds; seeds fixed):
/// every solve must end with a success status at a feasible KKT point, and at the book's
/// optimum unless the problem is listed as having another local minimum. No Stalled or
/// IterationLimit exit is allowed (HS13, without a KKT point, must still end feasible and
/// within 1e-2 of f*).
fn perturbed_starts(mode: HessianMode) {
    use rand::{RngExt, SeedableRng};
    let mut failures = Vec::new();
    let mut other = 0;
    for p in hs::all() {
        for seed in 0..5 {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(114 + seed);
            let x0: Vec<f64> = (0..p.n())
                .map(|j| {
                    let noise = 0.1 * p.x0[j].abs().max(1.0) * rng.random_range(-1.0..1.0);
                    (p.x0[j] + noise).clamp(p.xl[j], p.xu[j])
                })
                .collect();
            let moved = p.with_start(x0);
            let s = solve(&moved.nlp(mode == HessianMode::Exact), &options(mode));
            let kkt = kkt_error(&moved, &s);
            let feasible = moved.violation(&s.x) <= 1e-6;
            let book = (s.objective - p.fstar).abs() <= 1e-6 * p.fstar.abs().max(1.0);
            let ok = if NO_KKT_POINT.contains(&p.name) {
                feasible && (s.objective - p.fstar).abs() <= 1e-2
            } else if mode != HessianMode::Exact && QUASI_NEWTON_STALLS.contains(&p.name) {
                true
            } else {
                let local = OTHER_LOCAL_MINIMUM.contains(&p.name)
                    || PERTURBED_OTHER_MINIMUM.contains(&p.name)
                    || mode == HessianMode::Lbfgs;
                other += (!book) as usize;
                s.status.is_success() && feasible && kkt <= 10.0 * KKT_TOLERANCE && (book || local)
            };
            if !ok {
                failures.push(format!(
                    "{} seed {seed}: {:?} f = {:.8e} viol {:.1e} kkt {:.1e} in {} it.",
                    p.name,
                    s.status,
                    s.objective,
                    moved.violation(&s.x),
                    kkt,
                    s.iterations
                ));
            }
        }
    }
    println!("{mode:?}: {other} solves ended at another local minimum; failures {failures:#?}");
    assert!(failures.is_empty(), "{mode:?}: {failures:#?}");
}

#[test]
fn hs_perturbed_starts_with_bfgs() {
    perturbed_starts(HessianMode::Bfgs);
}

#[test]
fn hs_perturbed_starts_with_lbfgs() {
    perturbed_starts(HessianMode::Lbfgs);
}

#[test]
fn hs_perturbed_starts_with_exact_hessians() {
    perturbed_starts(HessianMode::Exact);
}

/// HS114 (variables from 1.5 to 16,000) with the exact Hessian: the convexification corrects
/// only the negative curvature of the reduced Hessian in a metric that follows the variables'
/// units, so the Newton steps are not shortened by a shift sized for the smallest variable
/// (with a uniform shift it crawled to the iteration limit, f = −1552.79).
#[test]
fn hs114_with_the_exact_hessian_takes_at_most_50_iterations() {
    let p = hs::all().into_iter().find(|p| p.name == "HS114").unwrap();
    let s = solve(&p.nlp(true), &options(HessianMode::Exact));
    assert!(solved(&p, &s), "{:?} f = {}", s.status, s.objective);
    assert!(s.iterations <= 50, "{} iterations", s.iterations);
}
