//! CMC evaluation cost: objective + constraints, and gradient + Jacobian, of the double bubble
//! NLP at about 3,000 and 11,000 vertices (the scale target is a ≥ 10,000-vertex double bubble).

use criterion::{Criterion, criterion_group, criterion_main};
use optimize::cmc::generators::double_bubble;
use optimize::cmc::nlp::{CmcNlp, VolumeConstraint};
use optimize::solver::Nlp;

fn double_bubble_nlp(levels: usize) -> CmcNlp {
    let shape = double_bubble([1e-6, 2e-6], levels).expect("valid start");
    let volumes = shape
        .volumes
        .into_iter()
        .map(|(name, region, target)| VolumeConstraint {
            name,
            region,
            target,
        })
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
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = evaluation
}
criterion_main!(benches);
