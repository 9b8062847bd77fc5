//! Interior-point QP: KKT conditions on random QPs, Hessian forms, infeasible / unbounded /
//! indefinite cases.

use nalgebra::DMatrix;
use nalgebra_sparse::{CooMatrix, CscMatrix, CsrMatrix};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::convexification::Convexification;
use super::{SparseQp, operators};
use crate::solver::qp::{self, QpHessian, QpMethod, QpProblem, QpSolution, QpStatus, WarmStart};

const INF: f64 = f64::INFINITY;

/// Owned data of one QP.
struct Data {
    h: CscMatrix<f64>,
    g: Vec<f64>,
    a: CsrMatrix<f64>,
    dl: Vec<f64>,
    du: Vec<f64>,
    bl: Vec<f64>,
    bu: Vec<f64>,
}

impl Data {
    fn problem(&self) -> QpProblem<'_> {
        QpProblem {
            h: QpHessian::SparseLower(&self.h),
            g: &self.g,
            a: &self.a,
            dl: &self.dl,
            du: &self.du,
            bl: &self.bl,
            bu: &self.bu,
        }
    }
}

fn lower_csc(dense: &DMatrix<f64>) -> CscMatrix<f64> {
    let n = dense.nrows();
    let mut coo = CooMatrix::new(n, n);
    for c in 0..n {
        for r in c..n {
            if dense[(r, c)] != 0.0 {
                coo.push(r, c, dense[(r, c)]);
            }
        }
    }
    CscMatrix::from(&coo)
}

/// A random feasible sparse convex QP with every kind of bound and row.
fn random_qp(rng: &mut ChaCha8Rng, n: usize, m: usize) -> Data {
    let x0: Vec<f64> = (0..n).map(|_| rng.random_range(-2.0..2.0)).collect();
    let mut h = DMatrix::<f64>::zeros(n, n);
    let mut curved = vec![false; n];
    for (j, c) in curved.iter_mut().enumerate() {
        if rng.random::<f64>() < 0.8 {
            h[(j, j)] = rng.random_range(0.1..3.0);
            *c = true;
        }
    }
    for _ in 0..n / 2 {
        // PSD rank-one terms v vᵀ with two nonzeros.
        let (i, j) = (rng.random_range(0..n), rng.random_range(0..n));
        let (a, b) = (rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
        h[(i, i)] += a * a;
        h[(j, j)] += b * b;
        h[(i, j)] += a * b;
        h[(j, i)] += a * b;
    }
    let mut dl = vec![-INF; n];
    let mut du = vec![INF; n];
    for j in 0..n {
        let kind = rng.random_range(0..5);
        let must_bound = !curved[j];
        match kind {
            0 if !must_bound => {}
            1 => dl[j] = x0[j] - rng.random_range(0.0..1.0),
            2 => du[j] = x0[j] + rng.random_range(0.0..1.0),
            3 => dl[j] = x0[j],
            _ => {
                dl[j] = x0[j] - rng.random_range(0.0..1.0);
                du[j] = x0[j] + rng.random_range(0.0..1.0);
            }
        }
        if must_bound && !(dl[j].is_finite() && du[j].is_finite()) {
            dl[j] = x0[j] - 1.0;
            du[j] = x0[j] + 1.0;
        }
    }
    // A few fixed variables.
    for _ in 0..n / 20 {
        let j = rng.random_range(0..n);
        dl[j] = x0[j];
        du[j] = x0[j];
    }
    let mut coo = CooMatrix::new(m, n);
    for i in 0..m {
        for _ in 0..3 {
            coo.push(i, rng.random_range(0..n), rng.random_range(-2.0..2.0));
        }
    }
    let a = CsrMatrix::from(&coo);
    let mut ax0 = vec![0.0; m];
    operators::a_times(&a, &x0, &mut ax0);
    let (mut bl, mut bu) = (vec![-INF; m], vec![INF; m]);
    let equalities = (m / 4).min(n / 3);
    for i in 0..m {
        if i < equalities {
            bl[i] = ax0[i];
            bu[i] = ax0[i];
            continue;
        }
        match rng.random_range(0..4) {
            0 => bl[i] = ax0[i] - rng.random_range(0.0..0.5),
            1 => bu[i] = ax0[i] + rng.random_range(0.0..0.5),
            2 => {
                bl[i] = ax0[i] - rng.random_range(0.0..0.5);
                bu[i] = ax0[i] + rng.random_range(0.0..0.5);
            }
            _ => {}
        }
    }
    let g = (0..n).map(|_| rng.random_range(-5.0..5.0)).collect();
    Data {
        h: lower_csc(&h),
        g,
        a,
        dl,
        du,
        bl,
        bu,
    }
}

/// Checks the KKT conditions with the shared sign convention to `tol` (absolute).
fn assert_kkt(qp: &QpProblem<'_>, added: &Convexification, sol: &QpSolution, tol: f64) {
    let (n, m) = (qp.g.len(), qp.a.nrows());
    let mut hd = vec![0.0; n];
    let mut tmp = vec![0.0; 64];
    operators::hessian_times(&qp.h, &sol.d, &mut hd, &mut tmp);
    let mut aty = vec![0.0; n];
    operators::a_transpose_times(qp.a, &sol.lambda, &mut aty);
    let mut ad = vec![0.0; m];
    operators::a_times(qp.a, &sol.d, &mut ad);
    for j in 0..n {
        let stat = hd[j] + added.added(j) * sol.d[j] + qp.g[j] + aty[j] + sol.z[j];
        assert!(stat.abs() <= tol, "stationarity {j}: {stat:e}");
        let (d, z) = (sol.d[j], sol.z[j]);
        assert!(d >= qp.dl[j] - tol && d <= qp.du[j] + tol, "bound {j}");
        if qp.dl[j] == qp.du[j] {
            continue;
        }
        if z < 0.0 {
            assert!(
                (-z) * (d - qp.dl[j]) <= tol,
                "complementarity lower {j}: z={z:e}"
            );
        } else if z > 0.0 {
            assert!(
                z * (qp.du[j] - d) <= tol,
                "complementarity upper {j}: z={z:e}"
            );
        }
    }
    for (i, &v) in ad.iter().enumerate() {
        let l = sol.lambda[i];
        assert!(
            v >= qp.bl[i] - tol && v <= qp.bu[i] + tol,
            "row {i}: {v} ∉ [{}, {}]",
            qp.bl[i],
            qp.bu[i]
        );
        if qp.bl[i] == qp.bu[i] {
            continue;
        }
        if l < 0.0 {
            assert!(
                (-l) * (v - qp.bl[i]) <= tol,
                "row complementarity lower {i}: λ={l:e}"
            );
        } else if l > 0.0 {
            assert!(
                l * (qp.bu[i] - v) <= tol,
                "row complementarity upper {i}: λ={l:e}"
            );
        }
    }
}

#[test]
fn random_sparse_convex_qps_satisfy_kkt() {
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let mut solver = SparseQp::new();
    for &(n, m) in &[
        (1, 0),
        (5, 2),
        (12, 20),
        (40, 15),
        (100, 60),
        (250, 100),
        (300, 0),
        (60, 150),
    ] {
        for _ in 0..3 {
            let data = random_qp(&mut rng, n, m);
            let (sol, info) = solver.solve(&data.problem(), 1e-11);
            assert_eq!(sol.status, QpStatus::Optimal, "n={n} m={m} {info:?}");
            assert!(info.convexification.is_zero(), "{info:?}");
            assert!(
                sol.iterations < 60,
                "n={n} m={m}: {} iterations",
                sol.iterations
            );
            assert_kkt(&data.problem(), &Convexification::default(), &sol, 1e-8);
        }
    }
}

#[test]
fn symbolic_analysis_is_reused_for_the_same_pattern() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut data = random_qp(&mut rng, 50, 20);
    let mut solver = SparseQp::new();
    let (_, first) = solver.solve(&data.problem(), 1e-10);
    assert!(!first.reused_symbolic);
    for g in &mut data.g {
        *g *= -0.5;
    }
    let (sol, second) = solver.solve(&data.problem(), 1e-10);
    assert!(second.reused_symbolic);
    assert_eq!(sol.status, QpStatus::Optimal);
    assert_kkt(&data.problem(), &Convexification::default(), &sol, 1e-8);
}

#[test]
fn an_equality_qp_steps_with_the_factors_of_its_inertia_test() {
    // H = diag(1, −1, ½) is convex on the null space of d₁ + d₂ = 1 only after a shift
    // (δ > ¼); no bounds, so the Newton matrix of the step is the one whose inertia was
    // tested last.
    let h = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1.0, -1.0, 0.5]));
    let data = small_qp(
        h,
        vec![-1.0, 0.5, 0.0],
        &[(vec![0.0, 1.0, 1.0], 1.0, 1.0)],
        vec![-INF; 3],
        vec![INF; 3],
    );
    let mut solver = SparseQp::new();
    solver.first_shift = 1.0;
    let (sol, info) = solver.solve(&data.problem(), 1e-10);
    assert_eq!(sol.status, QpStatus::Optimal);
    // H's negative diagonal entry flipped (no uniform shift needed).
    assert_eq!(info.convexification.flip, vec![0.0, 2.0, 0.0], "{info:?}");
    assert_eq!(info.convexification.shift, 0.0, "{info:?}");
    // Trials 0 and 1: nothing more for the step.
    assert_eq!(info.factorizations, 2, "{info:?}");
    assert_kkt(&data.problem(), &info.convexification, &sol, 1e-8);
    // The same QP again with a shift known to suffice (no inertia test): one factorization.
    solver.fixed_convexification = Some(info.convexification.clone());
    let (again, info) = solver.solve(&data.problem(), 1e-10);
    assert_eq!(info.factorizations, 1, "{info:?}");
    for (a, b) in again.d.iter().zip(&sol.d) {
        assert!((a - b).abs() < 1e-9, "{a} vs {b}");
    }
}

#[test]
fn dense_sparse_and_low_rank_hessians_agree() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let (n, p) = (30, 4);
    let w = DMatrix::from_fn(n, p, |_, _| rng.random_range(-1.0..1.0));
    // Mixed-sign M, with δ large enough that H = δI − W M Wᵀ stays positive definite.
    let m_small = DMatrix::from_fn(p, p, |i, j| {
        if i == j {
            [-1.0, 0.4, -0.3, 0.2][i]
        } else {
            0.0
        }
    });
    let delta = 8.0;
    let dense = DMatrix::identity(n, n) * delta - &w * &m_small * w.transpose();
    assert!(dense.clone().symmetric_eigenvalues().min() > 0.1);
    let mut data = random_qp(&mut rng, n, 12);
    data.h = lower_csc(&dense);
    let sparse_sol = super::solve(&data.problem(), 1e-11);
    let dense_problem = QpProblem {
        h: QpHessian::Dense(&dense),
        ..data.problem()
    };
    let dense_sol = super::solve(&dense_problem, 1e-11);
    let low_rank_problem = QpProblem {
        h: QpHessian::LowRank {
            delta,
            w: &w,
            m: &m_small,
        },
        ..data.problem()
    };
    let (low_rank_sol, info) = SparseQp::new().solve(&low_rank_problem, 1e-11);
    assert!(info.convexification.is_zero(), "{info:?}");
    for sol in [&sparse_sol, &dense_sol, &low_rank_sol] {
        assert_eq!(sol.status, QpStatus::Optimal);
        assert_kkt(&data.problem(), &Convexification::default(), sol, 1e-8);
    }
    for j in 0..n {
        assert!((sparse_sol.d[j] - dense_sol.d[j]).abs() < 1e-8);
        assert!((sparse_sol.d[j] - low_rank_sol.d[j]).abs() < 1e-8);
    }
}

fn small_qp(
    h: DMatrix<f64>,
    g: Vec<f64>,
    rows: &[(Vec<f64>, f64, f64)],
    dl: Vec<f64>,
    du: Vec<f64>,
) -> Data {
    let n = g.len();
    let mut coo = CooMatrix::new(rows.len(), n);
    for (i, (coefficients, _, _)) in rows.iter().enumerate() {
        for (j, &c) in coefficients.iter().enumerate() {
            if c != 0.0 {
                coo.push(i, j, c);
            }
        }
    }
    Data {
        h: lower_csc(&h),
        g,
        a: CsrMatrix::from(&coo),
        dl,
        du,
        bl: rows.iter().map(|r| r.1).collect(),
        bu: rows.iter().map(|r| r.2).collect(),
    }
}

#[test]
fn infeasible_qps_are_detected() {
    let identity = DMatrix::<f64>::identity(2, 2);
    let cases = [
        // Bounds 0 ≤ d ≤ 1 cannot reach d₁ + d₂ ≥ 3.
        small_qp(
            identity.clone(),
            vec![1.0, -1.0],
            &[(vec![1.0, 1.0], 3.0, INF)],
            vec![0.0; 2],
            vec![1.0; 2],
        ),
        // Inconsistent equalities on dependent rows.
        small_qp(
            identity.clone(),
            vec![0.0, 0.0],
            &[(vec![1.0, 1.0], 1.0, 1.0), (vec![2.0, 2.0], 4.0, 4.0)],
            vec![-INF; 2],
            vec![INF; 2],
        ),
        // Contradictory inequalities, free variables.
        small_qp(
            DMatrix::zeros(2, 2),
            vec![1.0, 1.0],
            &[(vec![1.0, -1.0], 2.0, INF), (vec![-1.0, 1.0], -1.0, INF)],
            vec![-INF; 2],
            vec![INF; 2],
        ),
        // A fixed variable against a row.
        small_qp(
            identity,
            vec![0.0, 0.0],
            &[(vec![1.0, 0.0], -INF, -1.0)],
            vec![0.0, -INF],
            vec![0.0, INF],
        ),
    ];
    for (k, data) in cases.iter().enumerate() {
        let sol = super::solve(&data.problem(), 1e-9);
        assert_eq!(
            sol.status,
            QpStatus::Infeasible,
            "case {k}: after {} iterations",
            sol.iterations
        );
    }
    // A large random QP made infeasible by one row bound beyond what the variable bounds allow.
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let mut data = random_qp(&mut rng, 200, 80);
    for j in 0..200 {
        if !data.dl[j].is_finite() {
            data.dl[j] = -1.0;
        }
        if !data.du[j].is_finite() {
            data.du[j] = 1.0;
        }
        data.dl[j] = data.dl[j].min(data.du[j]);
    }
    let last = 79;
    let (offsets, cols, values) = data.a.csr_data();
    let reach: f64 = (offsets[last]..offsets[last + 1])
        .map(|k| values[k].abs() * data.dl[cols[k]].abs().max(data.du[cols[k]].abs()))
        .sum();
    data.bl[last] = reach + 1.0;
    data.bu[last] = INF;
    let sol = super::solve(&data.problem(), 1e-9);
    assert_eq!(
        sol.status,
        QpStatus::Infeasible,
        "after {} iterations",
        sol.iterations
    );
}

#[test]
fn a_feasible_qp_with_a_huge_multiplier_is_not_called_infeasible() {
    // min d₁ + 1e3 d₂ s.t. d₁ ≥ 1e-3 d₂, d₂ ≥ 1: optimum d = (1e-3, 1), bound multiplier
    // ≈ −1e3. The objective is ≈ 1e3, so the relative tolerance must be 1e-12 for products
    // t·z ≤ 1e-8.
    let data = small_qp(
        DMatrix::from_diagonal_element(2, 2, 1e-6),
        vec![1.0, 1e3],
        &[(vec![1.0, -1e-3], 0.0, INF)],
        vec![-INF, 1.0],
        vec![INF, INF],
    );
    let sol = super::solve(&data.problem(), 1e-12);
    assert_eq!(sol.status, QpStatus::Optimal);
    assert_kkt(&data.problem(), &Convexification::default(), &sol, 1e-8);
}

#[test]
fn unbounded_qp_is_detected() {
    // min −d₁ + d₂², d₁ ≥ 0, d₁ − d₂ ≥ −1.
    let data = small_qp(
        DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![0.0, 2.0])),
        vec![-1.0, 0.0],
        &[(vec![1.0, -1.0], -1.0, INF)],
        vec![0.0, -INF],
        vec![INF, INF],
    );
    let sol = super::solve(&data.problem(), 1e-9);
    assert_eq!(sol.status, QpStatus::Unbounded);
}

#[test]
fn indefinite_hessian_is_convexified_only_when_needed() {
    // H = diag(1, −1) is convex on the null space of the equality d₂ = 0.5: no shift.
    let h = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1.0, -1.0]));
    let data = small_qp(
        h.clone(),
        vec![-1.0, 0.0],
        &[(vec![0.0, 1.0], 0.5, 0.5)],
        vec![-INF; 2],
        vec![INF; 2],
    );
    let (sol, info) = SparseQp::new().solve(&data.problem(), 1e-10);
    assert_eq!(sol.status, QpStatus::Optimal);
    assert!(info.convexification.is_zero(), "{info:?}");
    assert!((sol.d[0] - 1.0).abs() < 1e-8 && (sol.d[1] - 0.5).abs() < 1e-8);
    assert_kkt(&data.problem(), &Convexification::default(), &sol, 1e-8);

    // Without the equality (only bounds), H must be convex: its negative diagonal entry is
    // flipped, H + diag(0, 2) = I, and no uniform shift is needed.
    let data = small_qp(h, vec![-1.0, 0.1], &[], vec![-1.0; 2], vec![1.0; 2]);
    let (sol, info) = SparseQp::new().solve(&data.problem(), 1e-10);
    assert_eq!(sol.status, QpStatus::Optimal);
    assert_eq!(info.convexification.flip, vec![0.0, 2.0], "{info:?}");
    assert_eq!(info.convexification.shift, 0.0, "{info:?}");
    assert!((sol.d[1] + 0.1).abs() < 1e-8, "{sol:?}");
    assert_kkt(&data.problem(), &info.convexification, &sol, 1e-8);

    // Negative curvature off the diagonal (H = [0 1; 1 0], eigenvalues ±1) has nothing to
    // flip: H + δI must be positive semidefinite, δ ≥ 1 (the shifts tried are 0, 1e-4, 1e-3,
    // …, so the first acceptable one is exactly 1).
    let h = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 1.0, 0.0]);
    let data = small_qp(h, vec![-1.0, 0.1], &[], vec![-1.0; 2], vec![1.0; 2]);
    let (sol, info) = SparseQp::new().solve(&data.problem(), 1e-10);
    assert_eq!(sol.status, QpStatus::Optimal);
    assert!(info.convexification.flip.is_empty(), "{info:?}");
    assert!(
        info.convexification.shift >= 1.0 && info.convexification.shift < 20.0,
        "{info:?}"
    );
    assert_kkt(&data.problem(), &info.convexification, &sol, 1e-8);

    // A low-rank H = δI − W M Wᵀ with a negative eigenvalue gets the closed-form shift.
    let w = DMatrix::from_column_slice(3, 1, &[1.0, 1.0, 0.0]);
    let m = DMatrix::from_element(1, 1, 1.0);
    let data = small_qp(
        DMatrix::zeros(3, 3),
        vec![1.0, -1.0, 0.5],
        &[],
        vec![-2.0; 3],
        vec![2.0; 3],
    );
    let qp = QpProblem {
        h: QpHessian::LowRank {
            delta: 0.5,
            w: &w,
            m: &m,
        },
        ..data.problem()
    };
    let (sol, info) = SparseQp::new().solve(&qp, 1e-10);
    // Eigenvalues of 0.5 I − w wᵀ: 0.5 − 2 = −1.5 → shift just above 1.5.
    assert!((info.convexification.shift - 1.5).abs() < 1e-6, "{info:?}");
    assert_eq!(sol.status, QpStatus::Optimal);
    assert_kkt(&qp, &info.convexification, &sol, 1e-8);
}

#[test]
fn inconsistent_bounds_are_infeasible_and_bad_dimensions_numerical() {
    let data = small_qp(
        DMatrix::identity(1, 1),
        vec![0.0],
        &[],
        vec![1.0],
        vec![0.0],
    );
    assert_eq!(
        super::solve(&data.problem(), 1e-8).status,
        QpStatus::Infeasible
    );
    let data = small_qp(
        DMatrix::identity(1, 1),
        vec![0.0, 1.0],
        &[],
        vec![1.0],
        vec![0.0],
    );
    assert_eq!(
        super::solve(&data.problem(), 1e-8).status,
        QpStatus::Numerical
    );
}

/// The ways `feasibility_classification_is_reliable` perturbs a random feasible QP.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Perturbation {
    None,
    RowBeyondReach,
    OverdeterminedEqualities,
    ContradictoryRowPair,
    RowNearReach,
    RowExactlyAtReach,
}

fn perturb(rng: &mut ChaCha8Rng, data: &mut Data, kind: Perturbation) {
    let (n, m) = (data.g.len(), data.a.nrows());
    match kind {
        Perturbation::None => {}
        Perturbation::RowBeyondReach
        | Perturbation::RowNearReach
        | Perturbation::RowExactlyAtReach => {
            for j in 0..n {
                if !data.dl[j].is_finite() {
                    data.dl[j] = -1.0 - rng.random::<f64>();
                }
                if !data.du[j].is_finite() {
                    data.du[j] = 1.0 + rng.random::<f64>();
                }
                data.dl[j] = data.dl[j].min(data.du[j]);
            }
            let i = rng.random_range(0..m);
            let (offsets, cols, values) = data.a.csr_data();
            let reach: f64 = (offsets[i]..offsets[i + 1])
                .map(|k| (values[k] * data.dl[cols[k]]).max(values[k] * data.du[cols[k]]))
                .sum();
            if kind != Perturbation::RowBeyondReach {
                // Only row i and the box remain, so these stay feasible.
                for r in (0..m).filter(|&r| r != i) {
                    data.bl[r] = -INF;
                    data.bu[r] = INF;
                }
            }
            data.bl[i] = match kind {
                Perturbation::RowBeyondReach => reach + 1e-5 * reach.abs() + 1e-6,
                Perturbation::RowNearReach => reach - 1e-5 * reach.abs() - 1e-6,
                _ => reach,
            };
            data.bu[i] = INF;
        }
        Perturbation::OverdeterminedEqualities => {
            let mut coo = CooMatrix::new(n + 2, n);
            for i in 0..n + 2 {
                for j in 0..n {
                    if i == j || rng.random::<f64>() < 0.5 {
                        coo.push(i, j, rng.random_range(-1.0..1.0));
                    }
                }
            }
            data.a = CsrMatrix::from(&coo);
            data.bl = (0..n + 2).map(|_| rng.random_range(-1.0..1.0)).collect();
            data.bu = data.bl.clone();
        }
        Perturbation::ContradictoryRowPair => {
            // Row i ≥ 0.5 and its negation ≥ −0.5 + 1e-4, i.e. row i ≤ 0.5 − 1e-4.
            let i = rng.random_range(0..m);
            let (offsets, cols, values) = data.a.csr_data();
            let mut coo = CooMatrix::new(m + 1, n);
            for r in 0..m {
                for k in offsets[r]..offsets[r + 1] {
                    coo.push(r, cols[k], values[k]);
                }
            }
            for k in offsets[i]..offsets[i + 1] {
                coo.push(m, cols[k], -values[k]);
            }
            data.a = CsrMatrix::from(&coo);
            data.bl[i] = 0.5;
            data.bu[i] = INF;
            data.bl.push(-0.5 + 1e-4);
            data.bu.push(INF);
        }
    }
}

#[test]
fn feasibility_classification_is_reliable() {
    use Perturbation::*;
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let kinds = [
        None,
        RowBeyondReach,
        OverdeterminedEqualities,
        ContradictoryRowPair,
        RowNearReach,
        RowExactlyAtReach,
    ];
    let mut wrong = Vec::new();
    for trial in 0..600 {
        let (n, m) = (rng.random_range(2..60), rng.random_range(1..40));
        let mut data = random_qp(&mut rng, n, m);
        let kind = kinds[trial % kinds.len()];
        perturb(&mut rng, &mut data, kind);
        let tolerance = [1e-6, 1e-9][trial % 2];
        let sol = super::solve(&data.problem(), tolerance);
        let feasible = matches!(kind, None | RowNearReach | RowExactlyAtReach);
        let expected = if feasible {
            QpStatus::Optimal
        } else {
            QpStatus::Infeasible
        };
        if sol.status != expected {
            wrong.push((trial, kind, sol.status));
        }
    }
    assert!(wrong.is_empty(), "misclassified: {wrong:?}");
}

#[test]
fn empty_problems_are_handled() {
    let none = small_qp(DMatrix::zeros(0, 0), vec![], &[], vec![], vec![]);
    assert_eq!(
        super::solve(&none.problem(), 1e-8).status,
        QpStatus::Optimal
    );
    let rows = small_qp(
        DMatrix::zeros(0, 0),
        vec![],
        &[(vec![], 1.0, 2.0)],
        vec![],
        vec![],
    );
    assert_eq!(
        super::solve(&rows.problem(), 1e-8).status,
        QpStatus::Infeasible
    );
    // Variables but no rows, and an all-fixed problem.
    let box_only = small_qp(
        DMatrix::identity(2, 2),
        vec![1.0, -1.0],
        &[],
        vec![0.0; 2],
        vec![0.5; 2],
    );
    let sol = super::solve(&box_only.problem(), 1e-10);
    assert_eq!(sol.status, QpStatus::Optimal);
    assert!(sol.d[0].abs() < 1e-9 && (sol.d[1] - 0.5).abs() < 1e-9);
    let fixed = small_qp(
        DMatrix::identity(2, 2),
        vec![1.0, -1.0],
        &[(vec![1.0, 1.0], 0.0, 1.0)],
        vec![0.25; 2],
        vec![0.25; 2],
    );
    let sol = super::solve(&fixed.problem(), 1e-10);
    assert_eq!(sol.status, QpStatus::Optimal);
    assert_kkt(&fixed.problem(), &Convexification::default(), &sol, 1e-9);
}

#[test]
fn bounds_beyond_1e20_count_as_infinite() {
    // min ½d² − d with "bounds" ±1e30 and a row bound 1e25: the optimum d = 1 is unaffected.
    let data = small_qp(
        DMatrix::identity(1, 1),
        vec![-1.0],
        &[(vec![1.0], -1e25, 1e25)],
        vec![-1e30],
        vec![1e30],
    );
    let sol = super::solve(&data.problem(), 1e-10);
    assert_eq!(sol.status, QpStatus::Optimal);
    assert!((sol.d[0] - 1.0).abs() < 1e-9);
    assert!(sol.z[0].abs() < 1e-12 && sol.lambda[0].abs() < 1e-12);
}

#[test]
fn a_raised_interrupt_ends_the_solve_before_any_iteration() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let data = random_qp(&mut rng, 100, 60);
    let mut solver = SparseQp::new();
    solver.interrupt.raise();
    let (sol, info) = solver.solve(&data.problem(), 1e-10);
    assert_eq!(sol.status, QpStatus::Interrupted);
    assert_eq!((sol.iterations, info.factorizations), (0, 0));
    // The same solver, flag lowered (a fresh one), solves it.
    solver.interrupt = crate::solver::Interrupt::new();
    let (sol, _) = solver.solve(&data.problem(), 1e-10);
    assert_eq!(sol.status, QpStatus::Optimal);
    // Through the SQP's entry point, on both paths.
    for method in [QpMethod::Dense, QpMethod::Sparse] {
        let interrupt = crate::solver::Interrupt::new();
        let mut warm = WarmStart::new(method).interruptible(interrupt.clone());
        assert_eq!(
            qp::solve(&data.problem(), &mut warm, 1e-10).status,
            QpStatus::Optimal
        );
        interrupt.raise();
        let sol = qp::solve(&data.problem(), &mut warm, 1e-10);
        assert_eq!((sol.status, sol.iterations), (QpStatus::Interrupted, 0));
    }
}
