//! CMC cost: objective + constraints, gradient + Jacobian, and the Lagrangian Hessian of the double bubble NLP at about
//! 3,000 and 11,000 vertices; and a whole solve of the ≥ 10,000-vertex double bubble (the scale
//! target: under 20 s on one core) with the sparse QP path and the exact Hessian.
//!
//! `cargo bench --bench cmc -- eval` runs the evaluations only; `-- solve` the solve (ten
//! samples of a full solve: long until the sparse path is fast). Run with
//! `RAYON_NUM_THREADS=1` for one-core figures.

use criterion::{Criterion, criterion_group, criterion_main};
use optimize::cmc::generators::double_bubble;
use optimize::cmc::nlp::{CmcNlp, VolumeConstraint};
use optimize::solver::qp::QpMethod;
use optimize::solver::{HessianMode, Nlp, Options};

fn double_bubble_nlp(levels: usize) -> CmcNlp {
    let shape = double_bubble([1e-6, 2e-6], levels).expect("valid start");
    let volumes = shape
        .volumes
        .into_iter()
        .map(|(name, region, target)| VolumeConstraint::with_target(name, region, target))
        .collect();
    CmcNlp::new(shape.mesh, volumes, Vec::new(), 0.01).expect("valid problem")
}

fn evaluation(c: &mut Criterion) {
    for levels in [18, 34] {
        let nlp = double_bubble_nlp(levels);
        let d = nlp.dims();
        let mut x = vec![0.0; d.n];
        nlp.start(&mut x);
        let vertices = nlp.mesh().vertex_count();
        let (mut f, mut cons) = (0.0, vec![0.0; d.m]);
        c.bench_function(
            &format!("cmc double bubble eval, {vertices} vertices"),
            |b| b.iter(|| nlp.eval(&x, &mut f, &mut cons).expect("evaluates")),
        );
        let (mut g, mut jac) = (vec![0.0; d.n], vec![0.0; d.jac_nnz]);
        c.bench_function(
            &format!("cmc double bubble derivatives, {vertices} vertices"),
            |b| {
                b.iter(|| {
                    nlp.eval_derivatives(&x, &mut g, &mut jac)
                        .expect("evaluates")
                })
            },
        );
        // The Lagrangian Hessian with every multiplier nonzero (all curvature stars).
        let lambda: Vec<f64> = (0..d.m).map(|i| 1.0 + (i % 7) as f64).collect();
        let mut hess = vec![0.0; d.hess_nnz];
        c.bench_function(
            &format!("cmc double bubble Hessian, {vertices} vertices"),
            |b| {
                b.iter(|| {
                    nlp.eval_hessian(&x, 1.0, &lambda, &mut hess)
                        .expect("evaluates")
                })
            },
        );
    }
}

fn solve(c: &mut Criterion) {
    let nlp = double_bubble_nlp(34);
    let vertices = nlp.mesh().vertex_count();
    assert!(vertices >= 10_000, "{vertices} vertices");
    let options = Options {
        verbosity: 0,
        hessian: HessianMode::Exact,
        qp_method: QpMethod::Sparse,
        ..Default::default()
    };
    c.bench_function(
        &format!("cmc double bubble solve, {vertices} vertices"),
        |b| {
            b.iter(|| {
                let solution = optimize::solver::solve(&nlp, &options);
                assert!(solution.status.is_success(), "{:?}", solution.status);
                solution.iterations
            })
        },
    );
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = evaluation, solve
}
criterion_main!(benches);
