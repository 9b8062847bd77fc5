//! Finite-difference Jacobians of a sparse chain: column grouping against one column per
//! evaluation, and annealing throughput on a two-variable function.
//!
//! Run: `cargo bench --bench finite_differences`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use optimize::solver::derivatives::{DifferenceScheme, FiniteDifferenceOptions, FiniteDifferences};
use optimize::solver::global::{AnnealOptions, anneal};
use optimize::solver::{Dims, EvalError, Nlp};

/// c_i = x_i² − x_{i+1} + sin(x_{i+2})/2 (i < n − 2); f = (x0 − 1)² + x0·x_{n−1}.
struct Chain {
    n: usize,
}

impl Nlp for Chain {
    fn dims(&self) -> Dims {
        Dims {
            n: self.n,
            m: self.n - 2,
            jac_nnz: 3 * (self.n - 2),
            hess_nnz: 0,
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
        *f = (x[0] - 1.0).powi(2) + x[0] * x[self.n - 1];
        for (i, ci) in c.iter_mut().enumerate() {
            *ci = x[i] * x[i] - x[i + 1] + 0.5 * x[i + 2].sin();
        }
        Ok(())
    }
    fn eval_derivatives(&self, _: &[f64], _: &mut [f64], _: &mut [f64]) -> Result<(), EvalError> {
        Err(EvalError::Fatal("differenced only".into()))
    }
}

fn jacobian(c: &mut Criterion, name: &str, n: usize, grouped: bool, scheme: DifferenceScheme) {
    let nlp = Chain { n };
    let fd = if grouped {
        FiniteDifferences::with_objective_pattern(
            &nlp,
            FiniteDifferenceOptions::default(),
            &[0, n - 1],
        )
    } else {
        FiniteDifferences::new(&nlp, FiniteDifferenceOptions::default())
    };
    let mut x = vec![0.0; n];
    nlp.start(&mut x);
    let mut g = vec![0.0; n];
    let mut j = vec![0.0; 3 * (n - 2)];
    c.bench_function(name, |b| {
        b.iter(|| {
            fd.evaluate(&nlp, black_box(&x), scheme, &mut g, &mut j)
                .unwrap()
        })
    });
}

fn benches(c: &mut Criterion) {
    jacobian(
        c,
        "chain 100000 grouped forward",
        100_000,
        true,
        DifferenceScheme::Forward,
    );
    jacobian(
        c,
        "chain 100000 grouped central",
        100_000,
        true,
        DifferenceScheme::Central,
    );
    jacobian(
        c,
        "chain 2000 grouped forward",
        2000,
        true,
        DifferenceScheme::Forward,
    );
    jacobian(
        c,
        "chain 2000 one column per evaluation",
        2000,
        false,
        DifferenceScheme::Forward,
    );
    c.bench_function("chain 100000 column grouping", |b| {
        let nlp = Chain { n: 100_000 };
        b.iter(|| {
            FiniteDifferences::with_objective_pattern(
                &nlp,
                FiniteDifferenceOptions::default(),
                &[0, 99_999],
            )
        })
    });
    c.bench_function("anneal camel 10000 evaluations", |b| {
        let camel = Camel;
        let options = AnnealOptions {
            max_evaluations: 10_000,
            maximum_cost_repeat: usize::MAX,
            ..Default::default()
        };
        b.iter(|| anneal(&camel, &options))
    });
}

/// Six-hump camel on [−3, 3] × [−2, 2].
struct Camel;

impl Nlp for Camel {
    fn dims(&self) -> Dims {
        Dims {
            n: 2,
            m: 0,
            jac_nnz: 0,
            hess_nnz: 0,
        }
    }
    fn bounds(&self, xl: &mut [f64], xu: &mut [f64], _: &mut [f64], _: &mut [f64]) {
        xl.copy_from_slice(&[-3.0, -2.0]);
        xu.copy_from_slice(&[3.0, 2.0]);
    }
    fn start(&self, x: &mut [f64]) {
        x.copy_from_slice(&[-1.6071, -0.5687]);
    }
    fn jacobian_structure(&self, _: &mut [usize], _: &mut [usize]) {}
    fn eval(&self, x: &[f64], f: &mut f64, _: &mut [f64]) -> Result<(), EvalError> {
        let (a, b) = (x[0], x[1]);
        *f = (4.0 - 2.1 * a * a + a.powi(4) / 3.0) * a * a + a * b + (-4.0 + 4.0 * b * b) * b * b;
        Ok(())
    }
    fn eval_derivatives(&self, _: &[f64], _: &mut [f64], _: &mut [f64]) -> Result<(), EvalError> {
        Err(EvalError::Fatal("not needed".into()))
    }
}

criterion_group!(group, benches);
criterion_main!(group);
