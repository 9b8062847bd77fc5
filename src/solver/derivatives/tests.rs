//! Finite differences and the checker on functions with known derivatives.

use super::*;
use crate::solver::{Dims, EvalError, Nlp};

/// How the small test problem misreports its derivatives.
#[derive(Clone, Copy, PartialEq)]
enum Flaw {
    None,
    /// Jacobian value at this position is 1.5× too large.
    WrongEntry(usize),
    /// ∂c0/∂x2 is left out of the pattern.
    MissingEntry,
    /// Hessian value at this position is off by 1.
    WrongHessian(usize),
}

/// f = x0²·x1 + sin x2 + exp(x0·x2/2);  c0 = x0·x1 − x2² ("product");  c1 = x1³ + x2 ("cubic");
/// 0 ≤ x0 ≤ 2, −1 ≤ x1 ≤ 1, x2 free.
struct Small {
    flaw: Flaw,
}

impl Nlp for Small {
    fn dims(&self) -> Dims {
        let jac_nnz = if self.flaw == Flaw::MissingEntry {
            4
        } else {
            5
        };
        Dims {
            n: 3,
            m: 2,
            jac_nnz,
            hess_nnz: 5,
        }
    }
    fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
        xl.copy_from_slice(&[0.0, -1.0, f64::NEG_INFINITY]);
        xu.copy_from_slice(&[2.0, 1.0, f64::INFINITY]);
        cl.fill(0.0);
        cu.fill(0.0);
    }
    fn start(&self, x: &mut [f64]) {
        x.copy_from_slice(&[1.0, 0.5, 0.3]);
    }
    fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        let mut pattern = vec![(0, 0), (0, 1), (0, 2), (1, 1), (1, 2)];
        if self.flaw == Flaw::MissingEntry {
            pattern.remove(2);
        }
        for (k, (r, c)) in pattern.into_iter().enumerate() {
            rows[k] = r;
            cols[k] = c;
        }
    }
    fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
        *f = x[0] * x[0] * x[1] + x[2].sin() + (0.5 * x[0] * x[2]).exp();
        c[0] = x[0] * x[1] - x[2] * x[2];
        c[1] = x[1].powi(3) + x[2];
        Ok(())
    }
    fn eval_derivatives(&self, x: &[f64], g: &mut [f64], j: &mut [f64]) -> Result<(), EvalError> {
        let e = (0.5 * x[0] * x[2]).exp();
        g[0] = 2.0 * x[0] * x[1] + 0.5 * x[2] * e;
        g[1] = x[0] * x[0];
        g[2] = x[2].cos() + 0.5 * x[0] * e;
        let values = [x[1], x[0], -2.0 * x[2], 3.0 * x[1] * x[1], 1.0];
        let mut k = 0;
        for (i, v) in values.into_iter().enumerate() {
            if self.flaw == Flaw::MissingEntry && i == 2 {
                continue;
            }
            j[k] = v;
            k += 1;
        }
        if let Flaw::WrongEntry(k) = self.flaw {
            j[k] *= 1.5;
        }
        Ok(())
    }
    fn hessian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        rows.copy_from_slice(&[0, 1, 1, 2, 2]);
        cols.copy_from_slice(&[0, 0, 1, 0, 2]);
    }
    fn eval_hessian(
        &self,
        x: &[f64],
        sigma: f64,
        lambda: &[f64],
        h: &mut [f64],
    ) -> Result<(), EvalError> {
        let e = (0.5 * x[0] * x[2]).exp();
        h[0] = sigma * (2.0 * x[1] + 0.25 * x[2] * x[2] * e);
        h[1] = sigma * 2.0 * x[0] + lambda[0];
        h[2] = lambda[1] * 6.0 * x[1];
        h[3] = sigma * (0.5 * e + 0.25 * x[0] * x[2] * e);
        h[4] = sigma * (-x[2].sin() + 0.25 * x[0] * x[0] * e) - 2.0 * lambda[0];
        if let Flaw::WrongHessian(k) = self.flaw {
            h[k] += 1.0;
        }
        Ok(())
    }
    fn constraint_name(&self, row: usize) -> String {
        ["product", "cubic"][row].to_string()
    }
}

/// A chain: c_i = x_i² − x_{i+1} + sin(x_{i+2})/2 for i < n − 2; f = (x0 − 1)² + x0·x_{n−1};
/// −2 ≤ x ≤ 2. Jacobian rows have three consecutive columns.
struct Chain {
    n: usize,
}

impl Nlp for Chain {
    fn dims(&self) -> Dims {
        Dims {
            n: self.n,
            m: self.n - 2,
            jac_nnz: 3 * (self.n - 2),
            hess_nnz: self.n + 1,
        }
    }
    fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
        xl.fill(-2.0);
        xu.fill(2.0);
        cl.fill(0.0);
        cu.fill(0.0);
    }
    fn start(&self, x: &mut [f64]) {
        for (j, v) in x.iter_mut().enumerate() {
            *v = (j as f64 * 0.7).sin();
        }
    }
    fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        for i in 0..self.n - 2 {
            for d in 0..3 {
                rows[3 * i + d] = i;
                cols[3 * i + d] = i + d;
            }
        }
    }
    fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
        let last = x[self.n - 1];
        *f = (x[0] - 1.0).powi(2) + x[0] * last;
        for (i, ci) in c.iter_mut().enumerate() {
            *ci = x[i] * x[i] - x[i + 1] + 0.5 * x[i + 2].sin();
        }
        Ok(())
    }
    fn eval_derivatives(&self, x: &[f64], g: &mut [f64], j: &mut [f64]) -> Result<(), EvalError> {
        g.fill(0.0);
        g[0] = 2.0 * (x[0] - 1.0) + x[self.n - 1];
        g[self.n - 1] += x[0];
        for i in 0..self.n - 2 {
            j[3 * i] = 2.0 * x[i];
            j[3 * i + 1] = -1.0;
            j[3 * i + 2] = 0.5 * x[i + 2].cos();
        }
        Ok(())
    }
    /// The diagonal, then (n − 1, 0).
    fn hessian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        for j in 0..self.n {
            rows[j] = j;
            cols[j] = j;
        }
        rows[self.n] = self.n - 1;
        cols[self.n] = 0;
    }
    fn eval_hessian(
        &self,
        x: &[f64],
        sigma: f64,
        lambda: &[f64],
        h: &mut [f64],
    ) -> Result<(), EvalError> {
        h.fill(0.0);
        h[0] = 2.0 * sigma;
        for (i, &l) in lambda.iter().enumerate() {
            h[i] += 2.0 * l;
            h[i + 2] -= 0.5 * l * x[i + 2].sin();
        }
        h[self.n] = sigma;
        Ok(())
    }
}

fn exact(nlp: &dyn Nlp, x: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let d = nlp.dims();
    let mut g = vec![0.0; d.n];
    let mut j = vec![0.0; d.jac_nnz];
    nlp.eval_derivatives(x, &mut g, &mut j).unwrap();
    (g, j)
}

fn max_error(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(&a, &b)| relative_error(a, b))
        .fold(0.0, f64::max)
}

fn differences(
    fd: &FiniteDifferences,
    nlp: &dyn Nlp,
    x: &[f64],
    scheme: DifferenceScheme,
) -> (Vec<f64>, Vec<f64>, usize) {
    let d = nlp.dims();
    let mut g = vec![0.0; d.n];
    let mut j = vec![0.0; d.jac_nnz];
    let count = fd.evaluate(nlp, x, scheme, &mut g, &mut j).unwrap();
    (g, j, count)
}

#[test]
fn default_intervals_reach_the_expected_accuracy() {
    let nlp = Small { flaw: Flaw::None };
    let x = [0.8, -0.3, 1.1];
    let fd = FiniteDifferences::new(&nlp, FiniteDifferenceOptions::default());
    let (g, j) = exact(&nlp, &x);
    let (gf, jf, nf) = differences(&fd, &nlp, &x, DifferenceScheme::Forward);
    let (gc, jc, nc) = differences(&fd, &nlp, &x, DifferenceScheme::Central);
    let forward = max_error(&g, &gf).max(max_error(&j, &jf));
    let central = max_error(&g, &gc).max(max_error(&j, &jc));
    // √ε_R ≈ 5e-7 and ε_R^(2/3) ≈ 5e-9 for ε_R = ε^0.8.
    assert!(forward < 5e-6, "forward error {forward:e}");
    assert!(central < 5e-8, "central error {central:e}");
    assert!(central < forward / 10.0);
    // Dense objective: one evaluation per column (two for central) plus the base point.
    assert_eq!((nf, nc), (4, 7));
}

#[test]
fn forward_is_first_order_and_central_second_order() {
    let nlp = Small { flaw: Flaw::None };
    let x = [0.8, -0.3, 1.1];
    let (g, _) = exact(&nlp, &x);
    // Halving the interval (through the characteristic scale) in the truncation-dominated range.
    let error_at = |scheme: DifferenceScheme, h: f64| {
        let unit = FiniteDifferenceOptions::default().interval(scheme, 0.0);
        let options = FiniteDifferenceOptions {
            characteristic_scale: Some(h / unit),
            ..Default::default()
        };
        let fd = FiniteDifferences::new(&nlp, options);
        let (gd, _, _) = differences(&fd, &nlp, &x, scheme);
        (gd[2] - g[2]).abs()
    };
    let forward =
        error_at(DifferenceScheme::Forward, 1e-2) / error_at(DifferenceScheme::Forward, 5e-3);
    let central =
        error_at(DifferenceScheme::Central, 1e-2) / error_at(DifferenceScheme::Central, 5e-3);
    assert!((forward - 2.0).abs() < 0.1, "forward ratio {forward}");
    assert!((central - 4.0).abs() < 0.2, "central ratio {central}");
}

#[test]
fn differences_at_active_bounds_step_inward() {
    let nlp = Small { flaw: Flaw::None };
    let (g, j) = exact(&nlp, &[2.0, -1.0, 0.4]);
    for x in [[2.0, -1.0, 0.4], [0.0, 1.0, -0.7]] {
        let (g, j) = exact(&nlp, &x);
        let fd = FiniteDifferences::new(&nlp, FiniteDifferenceOptions::default());
        let (gf, jf, _) = differences(&fd, &nlp, &x, DifferenceScheme::Forward);
        let (gc, jc, _) = differences(&fd, &nlp, &x, DifferenceScheme::Central);
        assert!(max_error(&g, &gf).max(max_error(&j, &jf)) < 5e-6);
        assert!(max_error(&g, &gc).max(max_error(&j, &jc)) < 5e-8);
    }
    // A model undefined outside the bounds still differentiates at the bounds.
    struct Guarded<'a>(&'a Small);
    impl Nlp for Guarded<'_> {
        crate::solver::forward_nlp!(0; dims, bounds, start, jacobian_structure);
        fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
            if !(0.0..=2.0).contains(&x[0]) || !(-1.0..=1.0).contains(&x[1]) {
                return Err(EvalError::Domain(format!("outside the box at {x:?}")));
            }
            self.0.eval(x, f, c)
        }
        fn eval_derivatives(
            &self,
            _: &[f64],
            _: &mut [f64],
            _: &mut [f64],
        ) -> Result<(), EvalError> {
            unreachable!("only differenced")
        }
    }
    let guarded = Guarded(&nlp);
    let fd = FiniteDifferences::new(&guarded, FiniteDifferenceOptions::default());
    let (gc, jc, _) = differences(&fd, &guarded, &[2.0, -1.0, 0.4], DifferenceScheme::Central);
    assert!(max_error(&g, &gc).max(max_error(&j, &jc)) < 5e-8);
}

#[test]
fn grouped_columns_give_the_sparse_jacobian() {
    let nlp = Chain { n: 30 };
    let mut x = vec![0.0; 30];
    nlp.start(&mut x);
    x[5] = 2.0;
    x[6] = -2.0;
    x[29] = 2.0;
    let fd = FiniteDifferences::with_objective_pattern(
        &nlp,
        FiniteDifferenceOptions::default(),
        &[0, 29],
    );
    // Rows span three consecutive columns and the objective couples x0 with x29.
    assert!(fd.groups().len() <= 4, "{} groups", fd.groups().len());
    let (g, j) = exact(&nlp, &x);
    let (gf, jf, nf) = differences(&fd, &nlp, &x, DifferenceScheme::Forward);
    let (gc, jc, nc) = differences(&fd, &nlp, &x, DifferenceScheme::Central);
    assert!(max_error(&g, &gf).max(max_error(&j, &jf)) < 5e-6);
    assert!(max_error(&g, &gc).max(max_error(&j, &jc)) < 5e-8);
    assert_eq!(nf, 1 + fd.groups().len());
    assert_eq!(nc, 1 + 2 * fd.groups().len());
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let nlp = Chain { n: 40 };
    let mut x = vec![0.0; 40];
    nlp.start(&mut x);
    let fd = FiniteDifferences::new(&nlp, FiniteDifferenceOptions::default());
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| differences(&fd, &nlp, &x, DifferenceScheme::Central))
    };
    let (g1, j1, _) = run(1);
    let (g4, j4, _) = run(4);
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&g1), bits(&g4));
    assert_eq!(bits(&j1), bits(&j4));
}

#[test]
fn wrapper_supplies_differenced_derivatives() {
    let nlp = Small { flaw: Flaw::None };
    let wrapped = FiniteDifferenceNlp::new(&nlp, FiniteDifferenceOptions::default());
    assert_eq!(wrapped.dims().hess_nnz, 0);
    assert_eq!(wrapped.constraint_name(1), "cubic");
    let x = [0.5, 0.2, -0.4];
    let (g, j) = exact(&nlp, &x);
    let (gf, jf) = exact(&wrapped, &x);
    wrapped.set_scheme(DifferenceScheme::Central);
    let (gc, jc) = exact(&wrapped, &x);
    let forward = max_error(&g, &gf).max(max_error(&j, &jf));
    let central = max_error(&g, &gc).max(max_error(&j, &jc));
    assert!(forward < 5e-6 && central < 5e-8 && central < forward);
    assert_eq!(wrapped.difference_evaluations(), 4 + 7);
}

#[test]
fn checker_passes_exact_derivatives() {
    let report = check_derivatives(
        &Small { flaw: Flaw::None },
        &[0.8, -0.3, 1.1],
        &CheckOptions::default(),
    )
    .unwrap();
    assert!(report.passed(), "{report}");
    assert_eq!(report.gradient.checked, 3);
    assert_eq!(report.jacobian.checked, 5);
    assert_eq!(report.hessian.as_ref().unwrap().checked, 5);
    assert!(report.max_error() < 1e-7, "{report}");
    // Also at a point on the bounds.
    let report = check_derivatives(
        &Small { flaw: Flaw::None },
        &[2.0, 1.0, 0.0],
        &CheckOptions::default(),
    )
    .unwrap();
    assert!(report.passed(), "{report}");
}

#[test]
fn checker_names_a_wrong_jacobian_entry() {
    // Position 3 is ∂cubic/∂x1 = 3·x1².
    let nlp = Small {
        flaw: Flaw::WrongEntry(3),
    };
    let report = check_derivatives(&nlp, &[0.8, -0.3, 1.1], &CheckOptions::default()).unwrap();
    assert!(!report.passed());
    assert_eq!((report.gradient.failed, report.jacobian.failed), (0, 1));
    // The Hessian check differences the (wrong) Jacobian, so it fails too.
    assert_eq!(report.hessian.as_ref().unwrap().failed, 1);
    let worst = report
        .worst_per_function
        .iter()
        .find(|e| e.block == Block::Jacobian)
        .unwrap();
    assert!(worst.error > report.tolerance);
    assert_eq!((worst.row, worst.col), (Some(1), 1));
    assert_eq!(worst.name, "cubic");
    // Central truncation error h²·|f'''|/6 with h = 1.3e-4: about 1.6e-8.
    assert!(
        (worst.estimate - 0.27).abs() < 1e-7 && (worst.analytic - 0.405).abs() < 1e-12,
        "{worst:?}"
    );
    let text = report.to_string();
    assert!(
        text.contains("cubic (row 1)") && text.contains("x[1]") && text.contains("FAILED"),
        "{text}"
    );
}

#[test]
fn checker_finds_an_entry_missing_from_the_pattern() {
    let nlp = Small {
        flaw: Flaw::MissingEntry,
    };
    let report = check_derivatives(&nlp, &[0.8, -0.3, 1.1], &CheckOptions::default()).unwrap();
    assert!(report.scanned_outside_pattern);
    let worst = &report.worst_per_function[0];
    assert_eq!(
        (worst.name.as_str(), worst.row, worst.col, worst.in_pattern),
        ("product", Some(0), 2, false)
    );
    assert!((worst.estimate + 2.2).abs() < 1e-8);
    assert!(report.to_string().contains("outside pattern"));
}

#[test]
fn checker_catches_a_wrong_hessian_entry() {
    let nlp = Small {
        flaw: Flaw::WrongHessian(3),
    };
    let report = check_derivatives(&nlp, &[0.8, -0.3, 1.1], &CheckOptions::default()).unwrap();
    let hessian = report.hessian.as_ref().unwrap();
    assert_eq!(
        (
            report.gradient.failed,
            report.jacobian.failed,
            hessian.failed
        ),
        (0, 0, 1)
    );
    let worst = &report.worst_per_function[0];
    assert_eq!(
        (worst.block, worst.row, worst.col),
        (Block::Hessian, Some(2), 0)
    );
}

#[test]
fn grouped_check_for_large_problems_agrees() {
    let nlp = Chain { n: 50 };
    let mut x = vec![0.0; 50];
    nlp.start(&mut x);
    let options = CheckOptions {
        scan_limit: 10,
        ..Default::default()
    };
    let report = check_derivatives(&nlp, &x, &options).unwrap();
    assert!(!report.scanned_outside_pattern);
    assert!(report.passed(), "{report}");
    assert_eq!(report.jacobian.checked, 3 * 48);
    assert_eq!(report.hessian.as_ref().unwrap().checked, 51);
    // The gradient check costs 1 + 2·50 evaluations (the objective is taken as dense) plus one
    // at x. The Hessian (diagonal plus one corner entry) needs two groups: 1 + 2·2 gradient
    // evaluations instead of 1 + 2·50 column by column.
    assert_eq!(report.evaluations, 102 + 5);
}

#[test]
fn forward_then_central_restarts_from_the_first_result() {
    use crate::solver::{Evaluations, IterationRecord, Solution, Status};
    use std::sync::Mutex;
    // A stand-in local solver: records the scheme's accuracy and the start it was given, and
    // "moves" the start by +0.1 in every coordinate.
    let nlp = Small { flaw: Flaw::None };
    let wrapped = FiniteDifferenceNlp::new(&nlp, FiniteDifferenceOptions::default());
    let seen = Mutex::new(Vec::new());
    let local = |p: &dyn Nlp| {
        let mut x = vec![0.0; 3];
        p.start(&mut x);
        let (g, _) = exact(p, &x);
        let (g_exact, _) = exact(&nlp, &x);
        seen.lock()
            .unwrap()
            .push((x.clone(), max_error(&g_exact, &g)));
        let x: Vec<f64> = x.iter().map(|v| v + 0.1).collect();
        Solution {
            status: Status::Optimal,
            x,
            lambda: vec![0.0; 2],
            z: vec![0.0; 3],
            objective: 0.0,
            constraints: vec![0.0; 2],
            max_violation: 0.0,
            optimality: 0.0,
            iterations: 2,
            evaluations: Evaluations {
                functions: 3,
                derivatives: 1,
                hessians: 0,
            },
            seconds: 0.5,
            log: vec![IterationRecord {
                iter: 0,
                objective: 0.0,
                infeasibility: 0.0,
                optimality: 0.0,
                step: 0.0,
                merit: 0.0,
                qp_iterations: 0,
                elapsed: 0.0,
                stage: String::new(),
            }],
        }
    };
    let s = solve_forward_then_central(&wrapped, local);
    let seen = seen.into_inner().unwrap();
    assert_eq!(seen[0].0, vec![1.0, 0.5, 0.3]);
    assert_eq!(seen[1].0, vec![1.1, 0.6, 0.4]);
    // Central differences are markedly more accurate in the second solve.
    assert!(seen[1].1 < seen[0].1 / 10.0, "{seen:?}");
    assert_eq!(wrapped.scheme(), DifferenceScheme::Central);
    assert_eq!(
        (s.iterations, s.evaluations.functions, s.log.len()),
        (4, 6, 2)
    );
    assert_eq!(s.seconds, 1.0);
}

#[test]
fn grouped_hessian_check_agrees_with_the_scan() {
    let grouped = CheckOptions {
        scan_limit: 0,
        ..Default::default()
    };
    let x = [0.8, -0.3, 1.1];
    let exact_report = check_derivatives(&Small { flaw: Flaw::None }, &x, &grouped).unwrap();
    assert!(exact_report.passed(), "{exact_report}");
    assert_eq!(exact_report.hessian.as_ref().unwrap().checked, 5);
    let flawed = Small {
        flaw: Flaw::WrongHessian(2),
    };
    let report = check_derivatives(&flawed, &x, &grouped).unwrap();
    assert_eq!(report.hessian.as_ref().unwrap().failed, 1);
    let worst = &report.worst_per_function[0];
    assert_eq!(
        (worst.block, worst.row, worst.col),
        (Block::Hessian, Some(1), 1)
    );
}

/// f = 0; c0 = |x0| + x1 ("kinked"), c1 = exp(k·x1) ("stiff"), with a slip factor on
/// ∂c0/∂x0 (1 when exact); x0 fixed at 0.5 by its bounds when `fixed`. No Hessian.
struct Kinked {
    k: f64,
    slip: f64,
    fixed: bool,
}

impl Nlp for Kinked {
    fn dims(&self) -> Dims {
        Dims {
            n: 2,
            m: 2,
            jac_nnz: 3,
            hess_nnz: 0,
        }
    }
    fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
        xl.fill(f64::NEG_INFINITY);
        xu.fill(f64::INFINITY);
        if self.fixed {
            (xl[0], xu[0]) = (0.5, 0.5);
        }
        cl.fill(0.0);
        cu.fill(0.0);
    }
    fn start(&self, x: &mut [f64]) {
        x.copy_from_slice(&[0.0, 0.0]);
    }
    fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        rows.copy_from_slice(&[0, 0, 1]);
        cols.copy_from_slice(&[0, 1, 1]);
    }
    fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
        *f = 0.0;
        c[0] = x[0].abs() + x[1];
        c[1] = (self.k * x[1]).exp();
        Ok(())
    }
    fn eval_derivatives(&self, x: &[f64], g: &mut [f64], j: &mut [f64]) -> Result<(), EvalError> {
        g.fill(0.0);
        j[0] = self.slip * x[0].signum();
        j[1] = 1.0;
        j[2] = self.k * (self.k * x[1]).exp();
        Ok(())
    }
}

#[test]
fn kink_handling_accepts_a_kink_inside_the_stencil_but_not_a_wrong_slope() {
    // x0 = 3e-6 lies inside the default central stencil (h ≈ 1e-4) of |x0|.
    let x = [3e-6, 0.1];
    let exact = Kinked {
        k: 1.0,
        slip: 1.0,
        fixed: false,
    };
    let plain = check_derivatives(&exact, &x, &CheckOptions::default()).unwrap();
    assert!(!plain.passed(), "{plain}");
    assert_eq!(plain.kinks, 0);
    let kinks = CheckOptions {
        kink_threshold: Some(1e-5),
        ..CheckOptions::default()
    };
    let report = check_derivatives(&exact, &x, &kinks).unwrap();
    assert!(report.passed(), "{report}");
    assert!(report.kinks >= 1);
    // A slope 1e-3 off is still caught, kink or not.
    let slipped = Kinked {
        k: 1.0,
        slip: 1.001,
        fixed: false,
    };
    let report = check_derivatives(&slipped, &x, &kinks).unwrap();
    assert!(!report.passed(), "{report}");
    let worst = &report.worst_per_function[0];
    assert_eq!((worst.row, worst.col), (Some(0), 0));
}

#[test]
fn richardson_extrapolation_removes_the_truncation_error() {
    // exp(100·x1): central truncation h²·k²/6 relative ≈ 1.2e-8·1e4/6 ≈ 2e-5 at h ≈ 1.1e-4.
    let x = [0.5, 0.1];
    let stiff = Kinked {
        k: 100.0,
        slip: 1.0,
        fixed: false,
    };
    let plain = check_derivatives(&stiff, &x, &CheckOptions::default()).unwrap();
    let extrapolated = CheckOptions {
        richardson: true,
        ..CheckOptions::default()
    };
    let report = check_derivatives(&stiff, &x, &extrapolated).unwrap();
    assert!(!plain.passed(), "{plain}");
    assert!(report.passed(), "{report}");
    assert!(report.max_error() < 1e-3 * plain.max_error());
}

#[test]
fn listed_columns_limit_the_check() {
    let nlp = Chain { n: 50 };
    let mut x = vec![0.0; 50];
    nlp.start(&mut x);
    let columns = spread_columns(50, 5);
    assert_eq!(columns, vec![0, 10, 20, 30, 40]);
    let options = CheckOptions {
        columns: Some(columns.clone()),
        ..Default::default()
    };
    let report = check_derivatives(&nlp, &x, &options).unwrap();
    assert!(report.passed(), "{report}");
    assert!(report.scanned_outside_pattern);
    assert_eq!((report.columns, report.gradient.checked), (5, 5));
    assert!(report.to_string().contains("5 of 50 variables checked"));
    // A listed column outside 0..n is an error, not a panic.
    let bad = CheckOptions {
        columns: Some(vec![50]),
        ..Default::default()
    };
    assert!(check_derivatives(&nlp, &x, &bad).is_err());
    // Jittered starts are reproducible and bounded.
    let a = jittered_start(&nlp, 1e-3, 9);
    assert_eq!(a, jittered_start(&nlp, 1e-3, 9));
    assert!(a.iter().zip(&x).all(|(p, q)| (p - q).abs() <= 1e-3));
    assert_ne!(a, jittered_start(&nlp, 1e-3, 10));
}

#[test]
fn fixed_variables_are_differenced_across_their_value() {
    let nlp = Kinked {
        k: 1.0,
        slip: 1.0,
        fixed: true,
    };
    let report = check_derivatives(&nlp, &[0.5, 0.1], &CheckOptions::default()).unwrap();
    assert!(report.passed(), "{report}");
    assert!(
        report.jacobian.checked == 3 && report.max_error() < 1e-7,
        "{report}"
    );
}
