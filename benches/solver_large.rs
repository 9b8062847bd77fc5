//! Large-scale linear algebra on the generated chained problem (tests/common/large.rs) at
//! n = 50,000 variables and m = 20,000 nonlinear equality constraints:
//! - `kkt_symbolic`: AMD ordering + symbolic LDLᵀ of the QP's KKT pattern [H, Aᵀ; A, −D];
//! - `kkt_numeric`: one numeric factorization (values updated in place);
//! - `kkt_solve`: one solve with iterative refinement;
//! - `qp_first_subproblem`: one full interior-point solve of the first SQP subproblem
//!   (fresh solver, symbolic analysis included), and `..._reused_symbolic` with a solver that
//!   already analysed the pattern (the situation of SQP iterations after the first);
//! - `qp_first_subproblem_lowrank p=20`: the same QP with the compact limited-memory Hessian
//!   `H = δI − W M Wᵀ` (p = 20 columns, as L-BFGS with 10 pairs) instead of the exact one;
//! - `solve_exact` / `solve_lbfgs`: the whole SQP solve from the standard start with the
//!   exact Hessian and with L-BFGS (sparse QP path), 10 samples each. Status, iterations and
//!   final accuracy are printed once before timing; peak memory of one solve is printed by
//!   `cargo run --release --example large_solve -- 50000 exact|lbfgs`.
//!
//! Run: `cargo bench --bench solver_large` (size via `LARGE_N`, default 50000).

#[path = "../tests/common/large.rs"]
#[allow(dead_code)]
mod large;

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use large::{ChainedRosenbrock, FirstQp};
use nalgebra::DMatrix;
use optimize::solver::kkt::{KktSolver, Regularization};
use optimize::solver::qp::sparse::SparseQp;
use optimize::solver::qp::{QpHessian, QpProblem, QpStatus};
use optimize::solver::{HessianMode, Options, solve};

fn size() -> usize {
    std::env::var("LARGE_N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(50_000)
}

fn problem(qp: &FirstQp) -> QpProblem<'_> {
    QpProblem {
        h: QpHessian::SparseLower(&qp.h),
        g: &qp.g,
        a: &qp.a,
        dl: &qp.dl,
        du: &qp.du,
        bl: &qp.bl,
        bu: &qp.bu,
    }
}

/// Shift making the start Hessian positive definite (tridiagonal with diagonal ≈ 302 and
/// off-diagonal ≈ −200: smallest eigenvalue ≈ −98), so the benchmarked matrix is
/// quasi-definite like the interior-point Newton matrices.
const SHIFT: f64 = 200.0;

/// The KKT pattern of the QP's Newton system, as lower-triangle triplets with values
/// [H + SHIFT·I, Aᵀ; A, −I].
fn kkt_triplets(qp: &FirstQp) -> (usize, usize, Vec<usize>, Vec<usize>, Vec<f64>) {
    let (n, m) = (qp.g.len(), qp.a.nrows());
    let (mut rows, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
    for (r, c, v) in qp.h.triplet_iter() {
        rows.push(r.max(c));
        cols.push(r.min(c));
        vals.push(*v + if r == c { SHIFT } else { 0.0 });
    }
    for (r, c, v) in qp.a.triplet_iter() {
        rows.push(n + r);
        cols.push(c);
        vals.push(*v);
    }
    for i in 0..m {
        rows.push(n + i);
        cols.push(n + i);
        vals.push(-1.0);
    }
    (n, m, rows, cols, vals)
}

fn bench_large(c: &mut Criterion) {
    let n = size();
    let nlp = ChainedRosenbrock::new(n);
    let qp = nlp.first_qp();
    let (n, m, rows, cols, vals) = kkt_triplets(&qp);

    c.bench_function(&format!("kkt_symbolic n={n} m={m}"), |b| {
        b.iter(|| black_box(KktSolver::from_lower_triplets(n, m, &rows, &cols).unwrap()))
    });

    let (mut kkt, positions) = KktSolver::from_lower_triplets(n, m, &rows, &cols).unwrap();
    let write_values = |kkt: &mut KktSolver| {
        let values = kkt.values_mut();
        values.fill(0.0);
        for (&p, &v) in positions.iter().zip(&vals) {
            values[p] += v;
        }
    };
    write_values(&mut kkt);
    let inertia = kkt.factor(Regularization::default()).unwrap();
    assert!(inertia.is_quasi_definite_like(n, m));
    eprintln!(
        "KKT dim {}, nnz(L) {}, inertia {inertia:?}",
        n + m,
        kkt.factor_nnz()
    );
    c.bench_function(&format!("kkt_numeric n={n} m={m}"), |b| {
        b.iter(|| {
            write_values(&mut kkt);
            black_box(kkt.factor(Regularization::default()).unwrap())
        })
    });
    let rhs: Vec<f64> = (0..n + m).map(|i| (i as f64).sin()).collect();
    let mut x = rhs.clone();
    c.bench_function(&format!("kkt_solve n={n} m={m}"), |b| {
        b.iter(|| {
            x.copy_from_slice(&rhs);
            black_box(kkt.solve_refined(&mut x, 3, 1e-14).unwrap())
        })
    });

    let (sol, info) = SparseQp::new().solve(&problem(&qp), 1e-8);
    assert_eq!(sol.status, QpStatus::Optimal);
    eprintln!("first QP: {} iterations, {info:?}", sol.iterations);
    c.bench_function(&format!("qp_first_subproblem n={n} m={m}"), |b| {
        b.iter(|| black_box(SparseQp::new().solve(&problem(&qp), 1e-8)))
    });
    let mut solver = SparseQp::new();
    solver.solve(&problem(&qp), 1e-8);
    c.bench_function(
        &format!("qp_first_subproblem_reused_symbolic n={n} m={m}"),
        |b| b.iter(|| black_box(solver.solve(&problem(&qp), 1e-8))),
    );
}

/// A deterministic compact limited-memory Hessian: unit-scale columns of W, M with both signs,
/// δ large enough that H = δI − W M Wᵀ is positive definite (‖W M Wᵀ‖ ≤ 0.3·δ·‖W‖²).
fn low_rank(n: usize, p: usize) -> (f64, DMatrix<f64>, DMatrix<f64>) {
    let scale = (2.0 / n as f64).sqrt();
    let w = DMatrix::from_fn(n, p, |j, k| {
        scale * (0.37 * (j * (k + 1)) as f64 + k as f64).sin()
    });
    let delta = 300.0;
    let m = DMatrix::from_fn(p, p, |a, b| {
        if a == b {
            if a % 2 == 0 { -delta } else { 0.3 * delta }
        } else {
            0.0
        }
    });
    (delta, w, m)
}

fn bench_low_rank(c: &mut Criterion) {
    let n = size();
    let nlp = ChainedRosenbrock::new(n);
    let qp = nlp.first_qp();
    let m_rows = qp.a.nrows();
    let (delta, w, m) = low_rank(n, 20);
    let problem = QpProblem {
        h: QpHessian::LowRank {
            delta,
            w: &w,
            m: &m,
        },
        ..problem(&qp)
    };
    let (sol, info) = SparseQp::new().solve(&problem, 1e-8);
    assert_eq!(sol.status, QpStatus::Optimal);
    eprintln!("low-rank QP: {} iterations, {info:?}", sol.iterations);
    let mut solver = SparseQp::new();
    c.bench_function(
        &format!("qp_first_subproblem_lowrank p=20 n={n} m={m_rows}"),
        |b| b.iter(|| black_box(solver.solve(&problem, 1e-8))),
    );
}

fn bench_solve(c: &mut Criterion) {
    let n = size();
    let nlp = ChainedRosenbrock::new(n);
    for (name, hessian) in [("exact", HessianMode::Exact), ("lbfgs", HessianMode::Lbfgs)] {
        let options = Options {
            hessian,
            verbosity: 0,
            ..Options::default()
        };
        let s = solve(&nlp, &options);
        assert!(s.status.is_success(), "{name}: {:?}", s.status);
        eprintln!(
            "solve {name} n={n}: {:?}, {} iterations, {:.2} s, f = {:.10e} (f* = {:.10e}), violation {:.1e}",
            s.status,
            s.iterations,
            s.seconds,
            s.objective,
            nlp.optimal_objective(),
            s.max_violation
        );
        c.bench_function(&format!("solve_{name} n={n}"), |b| {
            b.iter(|| black_box(solve(&nlp, &options)))
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10).measurement_time(Duration::from_secs(10));
    targets = bench_large, bench_low_rank
}

criterion_group! {
    name = solves;
    config = Criterion::default().sample_size(10).measurement_time(Duration::from_secs(60));
    targets = bench_solve
}
criterion_main!(benches, solves);
