//! Solver behaviour beyond the test set: infeasible problems, failing evaluations, the
//! Maratos effect, limits and interruption, the contents of `Solution`.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use optimize::solver::qp::QpMethod;
use optimize::solver::{Dims, EvalError, HessianMode, Nlp, Options, Status, Tuning, solve};

#[path = "common/chain.rs"]
mod chain;

use chain::Chain;

type Values = dyn Fn(&[f64], &mut [f64]) -> Result<f64, EvalError> + Sync;
type Derivs = dyn Fn(&[f64], &mut [f64], &mut [f64]) + Sync;
type Hess = dyn Fn(&[f64], f64, &[f64], &mut [f64]) + Sync;

/// A small problem given by closures; dense row-major Jacobian, dense lower-triangle Hessian.
struct Small {
    x0: Vec<f64>,
    xl: Vec<f64>,
    xu: Vec<f64>,
    cl: Vec<f64>,
    cu: Vec<f64>,
    values: Box<Values>,
    derivatives: Box<Derivs>,
    hessian: Option<Box<Hess>>,
}

impl Nlp for Small {
    fn dims(&self) -> Dims {
        let (n, m) = (self.x0.len(), self.cl.len());
        Dims {
            n,
            m,
            jac_nnz: n * m,
            hess_nnz: if self.hessian.is_some() {
                n * (n + 1) / 2
            } else {
                0
            },
        }
    }
    fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
        xl.copy_from_slice(&self.xl);
        xu.copy_from_slice(&self.xu);
        cl.copy_from_slice(&self.cl);
        cu.copy_from_slice(&self.cu);
    }
    fn start(&self, x: &mut [f64]) {
        x.copy_from_slice(&self.x0);
    }
    fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        let n = self.x0.len();
        for k in 0..rows.len() {
            rows[k] = k / n;
            cols[k] = k % n;
        }
    }
    fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
        *f = (self.values)(x, c)?;
        Ok(())
    }
    fn eval_derivatives(&self, x: &[f64], g: &mut [f64], j: &mut [f64]) -> Result<(), EvalError> {
        (self.derivatives)(x, g, j);
        Ok(())
    }
    fn hessian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        let mut k = 0;
        for i in 0..self.x0.len() {
            for j in 0..=i {
                rows[k] = i;
                cols[k] = j;
                k += 1;
            }
        }
    }
    fn eval_hessian(
        &self,
        x: &[f64],
        sigma: f64,
        lambda: &[f64],
        values: &mut [f64],
    ) -> Result<(), EvalError> {
        (self.hessian.as_ref().expect("offered only with a Hessian"))(x, sigma, lambda, values);
        Ok(())
    }
}

const INF: f64 = f64::INFINITY;

fn quiet() -> Options {
    Options {
        verbosity: 0,
        ..Options::default()
    }
}

/// Two disjoint unit disks, centred at (0, 0) and (3, 0): no point satisfies both. The ℓ1
/// violation (x₁² + x₂² − 1)₊ + ((x₁ − 3)² + x₂² − 1)₊ is least at (1.5, 0).
fn disjoint_disks() -> Small {
    Small {
        x0: vec![0.5, 2.0],
        xl: vec![-INF; 2],
        xu: vec![INF; 2],
        cl: vec![-INF; 2],
        cu: vec![1.0, 1.0],
        values: Box::new(|x, c| {
            c[0] = x[0] * x[0] + x[1] * x[1];
            c[1] = (x[0] - 3.0).powi(2) + x[1] * x[1];
            Ok(x[0] + x[1])
        }),
        derivatives: Box::new(|x, g, j| {
            g.copy_from_slice(&[1.0, 1.0]);
            j.copy_from_slice(&[2.0 * x[0], 2.0 * x[1], 2.0 * (x[0] - 3.0), 2.0 * x[1]]);
        }),
        hessian: None,
    }
}

#[test]
fn locally_infeasible_problem_ends_infeasible_at_least_infeasible_point() {
    for mode in [HessianMode::Bfgs, HessianMode::Lbfgs] {
        let s = solve(
            &disjoint_disks(),
            &Options {
                hessian: mode,
                ..quiet()
            },
        );
        println!(
            "{mode:?}: {:?} at {:?}, violation {}",
            s.status, s.x, s.max_violation
        );
        assert_eq!(s.status, Status::Infeasible);
        assert!(!s.status.is_success());
        assert!(
            (s.x[0] - 1.5).abs() < 1e-4 && s.x[1].abs() < 1e-4,
            "{:?}",
            s.x
        );
        assert!((s.max_violation - 1.25).abs() < 1e-4);
    }
}

#[test]
fn equality_without_real_solution_is_infeasible() {
    // x₁² + 1 = 0: the violation x₁² + 1 is least at x₁ = 0.
    let nlp = Small {
        x0: vec![2.0, 1.0],
        xl: vec![-INF; 2],
        xu: vec![INF; 2],
        cl: vec![0.0],
        cu: vec![0.0],
        values: Box::new(|x, c| {
            c[0] = x[0] * x[0] + 1.0;
            Ok((x[1] - 1.0).powi(2))
        }),
        derivatives: Box::new(|x, g, j| {
            g.copy_from_slice(&[0.0, 2.0 * (x[1] - 1.0)]);
            j.copy_from_slice(&[2.0 * x[0], 0.0]);
        }),
        hessian: None,
    };
    let s = solve(&nlp, &quiet());
    assert_eq!(s.status, Status::Infeasible);
    assert!(s.x[0].abs() < 1e-4, "{:?}", s.x);
    assert!((s.max_violation - 1.0).abs() < 1e-6);
}

/// min x₁² + x₂² − ln x₁ from (3, 1): the first quasi-Newton step leaves the domain x₁ > 0.
/// The minimizer is (1/√2, 0) with f = ½ + ½ ln 2.
fn log_barrier_like(failure: fn() -> Result<f64, EvalError>) -> Small {
    Small {
        x0: vec![3.0, 1.0],
        xl: vec![-INF; 2],
        xu: vec![INF; 2],
        cl: vec![-INF],
        cu: vec![10.0],
        values: Box::new(move |x, c| {
            c[0] = x[0] + x[1];
            if x[0] <= 0.0 {
                return failure();
            }
            Ok(x[0] * x[0] + x[1] * x[1] - x[0].ln())
        }),
        derivatives: Box::new(|x, g, j| {
            g.copy_from_slice(&[2.0 * x[0] - 1.0 / x[0], 2.0 * x[1]]);
            j.copy_from_slice(&[1.0, 1.0]);
        }),
        hessian: None,
    }
}

#[test]
fn nan_and_domain_errors_make_the_line_search_back_off() {
    let nan = || Ok(f64::NAN);
    let domain = || Err(EvalError::Domain("log of a non-positive number".into()));
    for nlp in [log_barrier_like(nan), log_barrier_like(domain)] {
        let s = solve(&nlp, &quiet());
        assert_eq!(s.status, Status::Optimal);
        assert!((s.x[0] - 0.5_f64.sqrt()).abs() < 1e-6, "{:?}", s.x);
        assert!((s.objective - (0.5 + 0.5 * 2.0_f64.ln())).abs() < 1e-9);
        assert!(
            s.log.iter().any(|r| r.step < 1.0),
            "no backtracking happened"
        );
    }
}

#[test]
fn fatal_evaluation_error_stops_with_evaluation_error() {
    let fatal = || Err(EvalError::Fatal("simulation diverged".into()));
    let s = solve(&log_barrier_like(fatal), &quiet());
    assert_eq!(s.status, Status::EvaluationError);
    assert!(
        s.x[0] > 0.0 && s.objective.is_finite(),
        "the last good point is returned"
    );
}

/// Powell's example of the Maratos effect (Nocedal & Wright, Example 15.4):
/// min 2(x₁² + x₂² − 1) − x₁ s.t. x₁² + x₂² = 1, solution (1, 0) with λ* = −3/2.
fn powell_maratos(angle: f64) -> Small {
    Small {
        x0: vec![angle.cos(), angle.sin()],
        xl: vec![-INF; 2],
        xu: vec![INF; 2],
        cl: vec![1.0],
        cu: vec![1.0],
        values: Box::new(|x, c| {
            c[0] = x[0] * x[0] + x[1] * x[1];
            Ok(2.0 * (x[0] * x[0] + x[1] * x[1] - 1.0) - x[0])
        }),
        derivatives: Box::new(|x, g, j| {
            g.copy_from_slice(&[4.0 * x[0] - 1.0, 4.0 * x[1]]);
            j.copy_from_slice(&[2.0 * x[0], 2.0 * x[1]]);
        }),
        hessian: Some(Box::new(|_x, sigma, lambda, h| {
            let d = 4.0 * sigma + 2.0 * lambda[0];
            h.copy_from_slice(&[d, 0.0, d]);
        })),
    }
}

#[test]
fn maratos_example_takes_full_steps_and_converges_superlinearly() {
    // Started on the constraint near the solution, the SQP step raises both the objective
    // and the violation to first order: the ℓ1 merit function rejects it (the Maratos
    // effect), and the second-order correction restores full steps.
    let nlp = powell_maratos(0.3);
    let s = solve(
        &nlp,
        &Options {
            hessian: HessianMode::Exact,
            ..quiet()
        },
    );
    let steps: Vec<f64> = s.log.iter().skip(1).map(|r| r.step).collect();
    let errors: Vec<f64> = s.log.iter().map(|r| (r.objective + 1.0).abs()).collect();
    println!("accepted step lengths: {steps:?}");
    println!("|f − f*| per iteration: {errors:?}");
    println!(
        "{} iterations, {} function evaluations",
        s.iterations, s.evaluations.functions
    );
    assert_eq!(s.status, Status::Optimal);
    assert!(
        (s.x[0] - 1.0).abs() < 1e-6 && s.x[1].abs() < 1e-6,
        "{:?}",
        s.x
    );
    assert!((s.lambda[0] + 1.5).abs() < 1e-6, "λ = {}", s.lambda[0]);
    // Every accepted step is a full one, although unit steps were rejected (the extra
    // evaluations are the corrected trial points).
    assert!(steps.iter().all(|&a| a == 1.0), "{steps:?}");
    assert!(s.evaluations.functions > s.iterations + 1);
    assert!(s.iterations <= 8, "{} iterations", s.iterations);
    // Superlinear: each error is far below the previous one at the end.
    let n = errors.len();
    assert!(n >= 3);
    assert!(errors[n - 1] <= 1e-2 * errors[n - 2], "{errors:?}");
}

/// `min eˣ + e⁻ʸ + 3c − 4c² − 5xc  s.t.  x² + y² = 2,  0 ≤ c ≤ 1`: the optimum (−1, 1, 0) has
/// c held at its lower bound by the gradient 3 − 5x = 8, where the Hessian's curvature in c is
/// −8 (coupled to x by −5); on the free variables (the circle's tangent) it is positive.
fn concave_at_bound() -> Small {
    Small {
        x0: vec![-0.5, 1.5, 0.0],
        xl: vec![-INF, -INF, 0.0],
        xu: vec![INF, INF, 1.0],
        cl: vec![2.0],
        cu: vec![2.0],
        values: Box::new(|x, c| {
            c[0] = x[0] * x[0] + x[1] * x[1];
            Ok(x[0].exp() + (-x[1]).exp() + 3.0 * x[2] - 4.0 * x[2] * x[2] - 5.0 * x[0] * x[2])
        }),
        derivatives: Box::new(|x, g, j| {
            g.copy_from_slice(&[
                x[0].exp() - 5.0 * x[2],
                -(-x[1]).exp(),
                3.0 - 8.0 * x[2] - 5.0 * x[0],
            ]);
            j.copy_from_slice(&[2.0 * x[0], 2.0 * x[1], 0.0]);
        }),
        hessian: Some(Box::new(|x, sigma, lambda, h| {
            let l = 2.0 * lambda[0];
            h.copy_from_slice(&[
                sigma * x[0].exp() + l,
                0.0,
                sigma * (-x[1]).exp() + l,
                -5.0 * sigma,
                0.0,
                -8.0 * sigma,
            ]);
        })),
    }
}

#[test]
fn negative_curvature_blocked_by_a_bound_keeps_full_newton_steps() {
    // The convexification tests the Hessian only on the variables not held at a bound: no
    // shift, so the exact Hessian takes full Newton steps and converges quadratically (dense
    // QP path; the sparse path does not decouple held variables yet).
    {
        let qp_method = QpMethod::Dense;
        let s = solve(
            &concave_at_bound(),
            &Options {
                hessian: HessianMode::Exact,
                qp_method,
                ..quiet()
            },
        );
        let steps: Vec<f64> = s.log.iter().skip(1).map(|r| r.step).collect();
        let errors: Vec<f64> = s
            .log
            .iter()
            .map(|r| (r.objective - 2.0 * (-1.0_f64).exp()).abs())
            .collect();
        println!("{qp_method:?}: steps {steps:?}");
        println!("{qp_method:?}: |f − f*| {errors:?}");
        assert_eq!(s.status, Status::Optimal, "{qp_method:?}");
        assert!(
            (s.x[0] + 1.0).abs() < 1e-5 && (s.x[1] - 1.0).abs() < 1e-5 && s.x[2] == 0.0,
            "{:?}",
            s.x
        );
        assert!(steps.iter().all(|&a| a == 1.0), "{qp_method:?}: {steps:?}");
        assert!(
            s.iterations <= 6,
            "{qp_method:?}: {} iterations",
            s.iterations
        );
        // Quadratic: the last errors fall like e_{k+1} ≤ C·e_k² with a modest C.
        let n = errors.len();
        assert!(n >= 3);
        let (a, b) = (errors[n - 3], errors[n - 2]);
        assert!(b <= 10.0 * a * a, "{qp_method:?}: {errors:?}");
    }
}

#[test]
fn limits_and_interrupt_return_the_best_point() {
    let nlp = powell_maratos(2.0);
    let one = solve(
        &nlp,
        &Options {
            max_iterations: 1,
            ..quiet()
        },
    );
    assert_eq!(one.status, Status::IterationLimit);
    assert_eq!(one.iterations, 1);
    let timed = solve(
        &nlp,
        &Options {
            max_time: Some(0.0),
            ..quiet()
        },
    );
    assert_eq!(timed.status, Status::TimeLimit);
    let flag = Arc::new(AtomicBool::new(true));
    let stopped = solve(
        &nlp,
        &Options {
            interrupt: Some(flag),
            ..quiet()
        },
    );
    assert_eq!(stopped.status, Status::Interrupted);
    assert_eq!(stopped.x, vec![2.0_f64.cos(), 2.0_f64.sin()]);
}

#[test]
fn solution_fields_are_filled() {
    let nlp = powell_maratos(0.5);
    let s = solve(
        &nlp,
        &Options {
            hessian: HessianMode::Bfgs,
            ..quiet()
        },
    );
    assert_eq!(s.status, Status::Optimal);
    assert_eq!(s.log.len(), s.iterations + 1);
    assert_eq!(s.log[0].iter, 0);
    assert!(s.log.windows(2).all(|w| w[1].iter == w[0].iter + 1));
    assert!(s.evaluations.functions > s.iterations);
    assert!(s.evaluations.derivatives > s.iterations);
    assert_eq!(s.evaluations.hessians, 0);
    assert!((s.constraints[0] - 1.0).abs() <= 1e-6);
    assert!((s.max_violation - (s.constraints[0] - 1.0).abs()).abs() < 1e-15);
    assert!(s.optimality <= 1e-6);
    assert!(s.seconds >= 0.0);
    assert_eq!(s.z, vec![0.0, 0.0]);
    let exact = solve(
        &nlp,
        &Options {
            hessian: HessianMode::Auto,
            ..quiet()
        },
    );
    assert!(
        exact.evaluations.hessians > 0,
        "Auto uses the exact Hessian when offered"
    );
}

#[test]
fn hanging_chain_with_sparse_derivatives() {
    let mut objectives = Vec::new();
    for (mode, exact) in [
        (HessianMode::Bfgs, false),
        (HessianMode::Lbfgs, false),
        (HessianMode::Exact, true),
    ] {
        let chain = Chain { links: 20, exact };
        let s = solve(
            &chain,
            &Options {
                hessian: mode,
                verbosity: 2,
                ..quiet()
            },
        );
        println!(
            "chain {mode:?}: {:?}, f = {:.10}, {} iterations, {} evaluations",
            s.status, s.objective, s.iterations, s.evaluations.functions
        );
        assert_eq!(s.status, Status::Optimal, "{mode:?}");
        assert!(s.max_violation <= 1e-6);
        // Symmetric about x = ½: joint k mirrors joint links − k.
        for k in 1..chain.links {
            let (p, q) = (chain.point(&s.x, k), chain.point(&s.x, chain.links - k));
            assert!((p.0 + q.0 - 1.0).abs() < 1e-4 && (p.1 - q.1).abs() < 1e-4);
        }
        objectives.push(s.objective);
    }
    // All three Hessian models find the same minimum.
    assert!((objectives[0] - objectives[2]).abs() <= 1e-6 * objectives[2].abs().max(1.0));
    assert!((objectives[1] - objectives[2]).abs() <= 1e-6 * objectives[2].abs().max(1.0));
}

/// The hanging chain through the sparse interior-point QP (forced): with dense BFGS and with
/// the exact Hessian it reaches the dense path's minimum. (The sparse path used to stall here:
/// a convexification shift just large enough for the inertia test left H + δI nearly singular,
/// and degenerate QP solutions were snapped onto bounds, breaking the linearized equalities.)
#[test]
fn hanging_chain_through_the_sparse_qp() {
    let mut objectives = Vec::new();
    for (mode, exact, qp_method) in [
        (HessianMode::Exact, true, QpMethod::Dense),
        (HessianMode::Exact, true, QpMethod::Sparse),
        (HessianMode::Bfgs, false, QpMethod::Sparse),
    ] {
        let chain = Chain { links: 40, exact };
        let s = solve(
            &chain,
            &Options {
                hessian: mode,
                qp_method,
                ..quiet()
            },
        );
        println!(
            "chain {mode:?} {qp_method:?}: {:?}, f = {:.10}, {} iterations",
            s.status, s.objective, s.iterations
        );
        assert_eq!(s.status, Status::Optimal, "{mode:?} {qp_method:?}");
        assert!(s.max_violation <= 1e-6);
        objectives.push(s.objective);
    }
    for f in &objectives[1..] {
        assert!((f - objectives[0]).abs() <= 1e-6 * objectives[0].abs().max(1.0));
    }
}

/// The hanging chain at 250 links with the exact Hessian through the sparse QP. Its QPs have
/// only equality rows and a convexification shift of ~3e4, so the Schur complement
/// A(H + δI)⁻¹Aᵀ is ~1e-9 with a smallest eigenvalue far below that; before the KKT matrix was
/// equilibrated, the factorization's absolute dual regularization (1e-9) swamped it, the QPs'
/// equality rows were never met, and the solve stalled after three iterations.
#[test]
fn long_hanging_chain_through_the_sparse_qp() {
    let chain = Chain {
        links: 250,
        exact: true,
    };
    let s = solve(
        &chain,
        &Options {
            hessian: HessianMode::Exact,
            qp_method: QpMethod::Sparse,
            ..quiet()
        },
    );
    println!(
        "chain 250: {:?}, f = {:.10}, {} iterations",
        s.status, s.objective, s.iterations
    );
    assert_eq!(s.status, Status::Optimal);
    assert!(s.max_violation <= 1e-6);
    assert!(s.iterations <= 30, "{} iterations", s.iterations);
    for k in 1..chain.links {
        let (p, q) = (chain.point(&s.x, k), chain.point(&s.x, chain.links - k));
        assert!((p.0 + q.0 - 1.0).abs() < 1e-4 && (p.1 - q.1).abs() < 1e-4);
    }
}

/// L-BFGS through the sparse QP on the 100-link chain: the compact-form KKT matrix K₀ must be
/// equilibrated like the others (without it the QPs were reported infeasible after eleven
/// iterations and the solve stalled), and the slow linear convergence of L-BFGS near the
/// solution must not be cut short by the acceptable test (optimality fell from 2e-5 to 1e-6
/// over 45 iterations). Reference: the exact-Hessian solve of the same chain.
#[test]
fn hanging_chain_with_lbfgs_through_the_sparse_qp() {
    let solve_with = |hessian, exact| {
        let chain = Chain { links: 100, exact };
        solve(
            &chain,
            &Options {
                hessian,
                qp_method: QpMethod::Sparse,
                ..quiet()
            },
        )
    };
    let s = solve_with(HessianMode::Lbfgs, false);
    let reference = solve_with(HessianMode::Exact, true);
    println!(
        "chain 100, L-BFGS: {:?}, f = {:.10}, {} iterations (exact: f = {:.10})",
        s.status, s.objective, s.iterations, reference.objective
    );
    assert_eq!(s.status, Status::Optimal);
    assert_eq!(reference.status, Status::Optimal);
    assert!(s.max_violation <= 1e-6);
    assert!((s.objective - reference.objective).abs() <= 1e-6 * reference.objective.abs());
}

/// An objective computed as a sum of large terms that cancel, `Σ (c_j (x_j − 1)² + B_j) − Σ B_j`
/// with B_j ≈ 1e9: its rounding noise (~1e-6) is far above `ε_mach·|f|` near the solution
/// (f* = 0), so a plain Armijo test cannot resolve the decreases the last iterations predict
/// (~1e-12). The line search must measure the noise and accept steps within it; the gradient,
/// computed term by term, is accurate and steers the solve to optimality.
#[test]
fn objective_with_rounding_noise_far_above_machine_precision_converges() {
    let n = 200;
    let curvature = |j: usize| 1.0 + (j % 7) as f64;
    let big = |j: usize| 1e9 * (1.0 + (j as f64).sin());
    let offset: f64 = (0..n).map(big).sum();
    let nlp = Small {
        x0: vec![0.0; n],
        xl: vec![-10.0; n],
        xu: vec![10.0; n],
        cl: vec![],
        cu: vec![],
        values: Box::new(move |x, _c| {
            let sum: f64 = x
                .iter()
                .enumerate()
                .map(|(j, v)| curvature(j) * (v - 1.0) * (v - 1.0) + big(j))
                .sum();
            Ok(sum - offset)
        }),
        derivatives: Box::new(move |x, g, _j| {
            for (j, (gj, v)) in g.iter_mut().zip(x).enumerate() {
                *gj = 2.0 * curvature(j) * (v - 1.0);
            }
        }),
        hessian: None,
    };
    for hessian in [HessianMode::Bfgs, HessianMode::Lbfgs] {
        let s = solve(&nlp, &Options { hessian, ..quiet() });
        let error = s.x.iter().fold(0.0_f64, |a, v| a.max((v - 1.0).abs()));
        println!(
            "{hessian:?}: {:?} after {} iterations, max |x − 1| = {error:.1e}",
            s.status, s.iterations
        );
        assert_eq!(s.status, Status::Optimal, "{hessian:?}");
        assert!(error < 1e-6, "{hessian:?}: {error:e}");
    }
}

#[test]
fn unbounded_objective_is_reported() {
    // min −x₀ − x₁ s.t. x₀ − x₁ = 0: decreases without limit along x₀ = x₁ → ∞.
    let nlp = Small {
        x0: vec![0.0, 0.0],
        xl: vec![-INF; 2],
        xu: vec![INF; 2],
        cl: vec![0.0],
        cu: vec![0.0],
        values: Box::new(|x, c| {
            c[0] = x[0] - x[1];
            Ok(-x[0] - x[1])
        }),
        derivatives: Box::new(|_x, g, j| {
            g.copy_from_slice(&[-1.0, -1.0]);
            j.copy_from_slice(&[1.0, -1.0]);
        }),
        hessian: None,
    };
    let s = solve(&nlp, &quiet());
    println!(
        "{:?} after {} iterations, f = {:e}",
        s.status, s.iterations, s.objective
    );
    assert_eq!(s.status, Status::Unbounded);
    assert!(!s.status.is_success());
}

#[test]
fn a_tuning_constant_varied_through_the_options_takes_effect() {
    // min (x − 100)² from x = 0, no constraints.
    let far_minimum = || Small {
        x0: vec![0.0],
        xl: vec![-INF],
        xu: vec![INF],
        cl: vec![],
        cu: vec![],
        values: Box::new(|x, _c| Ok((x[0] - 100.0).powi(2))),
        derivatives: Box::new(|x, g, _j| g[0] = 2.0 * (x[0] - 100.0)),
        hessian: None,
    };
    let run = |tuning: Tuning| solve(&far_minimum(), &Options { tuning, ..quiet() });
    let free = run(Tuning::default());
    // Steps of at most 0.1·(1 + |x|) need many more iterations to travel from 0 to 100.
    let short = run(Tuning {
        step_limit: 0.1,
        ..Tuning::default()
    });
    assert_eq!(free.status, Status::Optimal);
    assert_eq!(short.status, Status::Optimal);
    assert!((short.x[0] - 100.0).abs() < 1e-4, "{}", short.x[0]);
    assert!(
        short.iterations > free.iterations + 10,
        "{} vs {}",
        short.iterations,
        free.iterations
    );
}

/// A constraint whose natural multiplier is large: min x₁ on the circle 1e-4·(x₁² + x₂²) = 1e-4
/// (its gradient, 2e-4 at the start, is too small for the solver's scaling to touch), so
/// λ* = 5e3. The exact Hessian refuses a QP's multipliers that jump by more than 1e3× from the
/// previous ones; before the first QP the reference is the least-squares estimate at the start
/// (5e3·|x₁|/‖x‖² = 800 from x = (−0.64, 1.8948), ‖x‖ = 2), not 1, so the first QP's
/// multiplier (800·(3‖x‖² − 1)/(2‖x‖²) = 1,100) is followed at once: the second Hessian
/// evaluation uses it, not the start's estimate.
#[test]
fn large_natural_multipliers_are_followed_from_the_first_qp() {
    use std::sync::Mutex;
    let seen: Arc<Mutex<Vec<f64>>> = Arc::new(Mutex::new(Vec::new()));
    let record = Arc::clone(&seen);
    let circle = Small {
        x0: vec![-0.64, 1.894835],
        xl: vec![-INF; 2],
        xu: vec![INF; 2],
        cl: vec![1e-4],
        cu: vec![1e-4],
        values: Box::new(|x, c| {
            c[0] = 1e-4 * (x[0] * x[0] + x[1] * x[1]);
            Ok(x[0])
        }),
        derivatives: Box::new(|x, g, j| {
            g.copy_from_slice(&[1.0, 0.0]);
            j.copy_from_slice(&[2e-4 * x[0], 2e-4 * x[1]]);
        }),
        hessian: Some(Box::new(move |_x, _sigma, lambda, h| {
            record.lock().unwrap().push(lambda[0]);
            h.copy_from_slice(&[2e-4 * lambda[0], 0.0, 2e-4 * lambda[0]]);
        })),
    };
    let s = solve(
        &circle,
        &Options {
            hessian: HessianMode::Exact,
            ..quiet()
        },
    );
    let seen = seen.lock().unwrap();
    println!(
        "{:?}, {} iterations, Hessian multipliers {seen:?}",
        s.status, s.iterations
    );
    assert_eq!(s.status, Status::Optimal);
    assert!((s.x[0] + 1.0).abs() < 1e-6 && s.x[1].abs() < 1e-5);
    assert!(
        (seen[0] - 800.0).abs() < 1.0,
        "start multipliers {}",
        seen[0]
    );
    assert!(
        seen.len() >= 2 && (seen[1] - 1100.0).abs() < 1.0,
        "{seen:?}"
    );
}

/// A strictly convex quadratic with its exact Hessian: one Newton step lands on the minimizer
/// and the solve ends there on arrival. The first derivatives are evaluated once per point
/// (the start's unscaled evaluation that chooses the scales serves iteration 0 too) and the
/// Hessian only where a QP uses it (the start), not at the point where the solve ends.
#[test]
fn a_solve_ending_on_arrival_evaluates_what_it_uses_only() {
    let nlp = Small {
        x0: vec![0.0, 0.0],
        xl: vec![-INF; 2],
        xu: vec![INF; 2],
        cl: vec![],
        cu: vec![],
        values: Box::new(|x, _| {
            Ok((x[0] - 1.0).powi(2) + 2.0 * (x[1] + 2.0).powi(2) + x[0] * x[1])
        }),
        derivatives: Box::new(|x, g, _| {
            g[0] = 2.0 * (x[0] - 1.0) + x[1];
            g[1] = 4.0 * (x[1] + 2.0) + x[0];
        }),
        hessian: Some(Box::new(|_, sigma, _, h| {
            h.copy_from_slice(&[2.0 * sigma, sigma, 4.0 * sigma]);
        })),
    };
    let s = solve(
        &nlp,
        &Options {
            hessian: HessianMode::Exact,
            ..quiet()
        },
    );
    assert_eq!(s.status, Status::Optimal);
    assert_eq!(s.iterations, 1);
    // ∇f = 0 at x = (16/7, −18/7).
    assert!((s.x[0] - 16.0 / 7.0).abs() < 1e-9 && (s.x[1] + 18.0 / 7.0).abs() < 1e-9);
    assert_eq!(
        s.evaluations.derivatives, 2,
        "the start and the point reached"
    );
    assert_eq!(s.evaluations.hessians, 1, "the start's QP only");
}
