//! Hock–Schittkowski test problems (W. Hock & K. Schittkowski, "Test Examples for Nonlinear
//! Programming Codes", LNEMS 187, Springer 1981), as `Nlp`s with exact derivatives.
//!
//! Each problem is written once, generically over a dual-number type, and evaluated with
//! `f64` (values), `Dual64` (one directional derivative per variable: gradient and Jacobian
//! columns) and `HyperDual64` (one second derivative per pair i ≥ j: the Lagrangian Hessian).
//! Derivatives obtained this way are exact to rounding; tests also compare them with central
//! differences. Optimal values are from the book, with the corrections listed in the notes
//! (HS14 = 9 − 23√7/8, HS81 = 0.0539498478, HS106 = 7049.2480205, HS116 = 97.5875096).
//! Constraints are written as `cl ≤ c(x) ≤ cu`; the book's `g(x) ≥ 0` becomes `cl = 0`.

#![allow(dead_code)]

use num_dual::{Dual64, DualNum, HyperDual64};
use optimize::solver::{Dims, EvalError, Nlp};

/// A problem function: returns f(x) and writes c(x).
pub type Fun<T> = fn(&[T], &mut [T]) -> T;

/// One test problem.
#[derive(Clone)]
pub struct Hs {
    /// "HS71" etc.
    pub name: &'static str,
    /// Standard start.
    pub x0: Vec<f64>,
    /// Variable bounds.
    pub xl: Vec<f64>,
    /// Variable bounds.
    pub xu: Vec<f64>,
    /// Constraint bounds.
    pub cl: Vec<f64>,
    /// Constraint bounds.
    pub cu: Vec<f64>,
    /// Optimal objective value.
    pub fstar: f64,
    f: Fun<f64>,
    f1: Fun<Dual64>,
    f2: Fun<HyperDual64>,
}

const INF: f64 = f64::INFINITY;

macro_rules! funs {
    ($g:ident) => {
        (
            $g::<f64> as Fun<f64>,
            $g::<Dual64> as Fun<Dual64>,
            $g::<HyperDual64> as Fun<HyperDual64>,
        )
    };
}

impl Hs {
    #[allow(clippy::too_many_arguments)]
    fn new(
        name: &'static str,
        x0: &[f64],
        xl: &[f64],
        xu: &[f64],
        cl: &[f64],
        cu: &[f64],
        fstar: f64,
        (f, f1, f2): (Fun<f64>, Fun<Dual64>, Fun<HyperDual64>),
    ) -> Hs {
        let n = x0.len();
        let fill = |v: &[f64], d: f64| if v.is_empty() { vec![d; n] } else { v.to_vec() };
        Hs {
            name,
            x0: x0.to_vec(),
            xl: fill(xl, -INF),
            xu: fill(xu, INF),
            cl: cl.to_vec(),
            cu: cu.to_vec(),
            fstar,
            f,
            f1,
            f2,
        }
    }

    /// The same problem from another start.
    pub fn with_start(&self, x0: Vec<f64>) -> Hs {
        Hs { x0, ..self.clone() }
    }

    /// Number of variables.
    pub fn n(&self) -> usize {
        self.x0.len()
    }

    /// Number of general constraints.
    pub fn m(&self) -> usize {
        self.cl.len()
    }

    /// f and c at x.
    pub fn values(&self, x: &[f64]) -> (f64, Vec<f64>) {
        let mut c = vec![0.0; self.m()];
        let f = (self.f)(x, &mut c);
        (f, c)
    }

    /// Largest violation of bounds and constraints at x.
    pub fn violation(&self, x: &[f64]) -> f64 {
        let (_, c) = self.values(x);
        let mut v = 0.0_f64;
        for ((&x, &l), &u) in x.iter().zip(&self.xl).zip(&self.xu) {
            v = v.max(l - x).max(x - u);
        }
        for ((&c, &l), &u) in c.iter().zip(&self.cl).zip(&self.cu) {
            v = v.max(l - c).max(c - u);
        }
        v
    }

    /// The problem as an `Nlp`; `exact` decides whether it offers its Hessian.
    pub fn nlp(&self, exact: bool) -> HsNlp<'_> {
        HsNlp { p: self, exact }
    }
}

/// An HS problem seen through the solver's interface (dense Jacobian pattern, row-major;
/// dense lower-triangle Hessian pattern, row-major).
pub struct HsNlp<'a> {
    /// The problem.
    pub p: &'a Hs,
    /// Whether the exact Hessian is offered.
    pub exact: bool,
}

impl Nlp for HsNlp<'_> {
    fn dims(&self) -> Dims {
        let (n, m) = (self.p.n(), self.p.m());
        Dims {
            n,
            m,
            jac_nnz: n * m,
            hess_nnz: if self.exact { n * (n + 1) / 2 } else { 0 },
        }
    }

    fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
        xl.copy_from_slice(&self.p.xl);
        xu.copy_from_slice(&self.p.xu);
        cl.copy_from_slice(&self.p.cl);
        cu.copy_from_slice(&self.p.cu);
    }

    fn start(&self, x: &mut [f64]) {
        x.copy_from_slice(&self.p.x0);
    }

    fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        let n = self.p.n();
        for k in 0..rows.len() {
            rows[k] = k / n;
            cols[k] = k % n;
        }
    }

    fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
        *f = (self.p.f)(x, c);
        Ok(())
    }

    fn eval_derivatives(
        &self,
        x: &[f64],
        grad: &mut [f64],
        jac: &mut [f64],
    ) -> Result<(), EvalError> {
        let (n, m) = (self.p.n(), self.p.m());
        let mut c = vec![Dual64::from(0.0); m];
        for j in 0..n {
            let xd: Vec<Dual64> = (0..n)
                .map(|k| Dual64::new(x[k], if k == j { 1.0 } else { 0.0 }))
                .collect();
            let f = (self.p.f1)(&xd, &mut c);
            grad[j] = f.eps;
            for i in 0..m {
                jac[i * n + j] = c[i].eps;
            }
        }
        Ok(())
    }

    fn hessian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        let mut k = 0;
        for i in 0..self.p.n() {
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
        let (n, m) = (self.p.n(), self.p.m());
        let mut c = vec![HyperDual64::from(0.0); m];
        let mut k = 0;
        for i in 0..n {
            for j in 0..=i {
                let xd: Vec<HyperDual64> = (0..n)
                    .map(|l| {
                        let e1 = if l == i { 1.0 } else { 0.0 };
                        let e2 = if l == j { 1.0 } else { 0.0 };
                        HyperDual64::new(x[l], e1, e2, 0.0)
                    })
                    .collect();
                let f = (self.p.f2)(&xd, &mut c);
                let mut v = sigma * f.eps1eps2;
                for r in 0..m {
                    v += lambda[r] * c[r].eps1eps2;
                }
                values[k] = v;
                k += 1;
            }
        }
        Ok(())
    }
}

fn sq<T: DualNum<Primitive = f64> + Copy>(t: T) -> T {
    t * t
}

// ---------------------------------------------------------------------------------------
// The problems. Notation: x[0] is the book's x1.

fn hs001<T: DualNum<Primitive = f64> + Copy>(x: &[T], _c: &mut [T]) -> T {
    sq(x[1] - x[0] * x[0]) * 100.0 + sq(-x[0] + 1.0)
}

fn hs003<T: DualNum<Primitive = f64> + Copy>(x: &[T], _c: &mut [T]) -> T {
    x[1] + sq(x[1] - x[0]) * 1e-5
}

fn hs004<T: DualNum<Primitive = f64> + Copy>(x: &[T], _c: &mut [T]) -> T {
    (x[0] + 1.0).powi(3) / 3.0 + x[1]
}

fn hs005<T: DualNum<Primitive = f64> + Copy>(x: &[T], _c: &mut [T]) -> T {
    (x[0] + x[1]).sin() + sq(x[0] - x[1]) - x[0] * 1.5 + x[1] * 2.5 + 1.0
}

fn hs006<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = (x[1] - x[0] * x[0]) * 10.0;
    sq(-x[0] + 1.0)
}

fn hs007<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = sq(x[0] * x[0] + 1.0) + x[1] * x[1] - 4.0;
    (x[0] * x[0] + 1.0).ln() - x[1]
}

fn hs008<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] * x[0] + x[1] * x[1] - 25.0;
    c[1] = x[0] * x[1] - 9.0;
    T::from(-1.0) + x[0] * 0.0
}

fn hs009<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    use std::f64::consts::PI;
    c[0] = x[0] * 4.0 - x[1] * 3.0;
    (x[0] * (PI / 12.0)).sin() * (x[1] * (PI / 16.0)).cos()
}

fn hs010<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = -(x[0] * x[0]) * 3.0 + x[0] * x[1] * 2.0 - x[1] * x[1] + 1.0;
    x[0] - x[1]
}

fn hs011<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = -(x[0] * x[0]) + x[1];
    sq(x[0] - 5.0) + x[1] * x[1] - 25.0
}

fn hs012<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = -(x[0] * x[0]) * 4.0 - x[1] * x[1] + 25.0;
    x[0] * x[0] * 0.5 + x[1] * x[1] - x[0] * x[1] - x[0] * 7.0 - x[1] * 7.0
}

fn hs014<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] - x[1] * 2.0 + 1.0;
    c[1] = -(x[0] * x[0]) / 4.0 - x[1] * x[1] + 1.0;
    sq(x[0] - 2.0) + sq(x[1] - 1.0)
}

fn hs015<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] * x[1] - 1.0;
    c[1] = x[0] + x[1] * x[1];
    sq(x[1] - x[0] * x[0]) * 100.0 + sq(-x[0] + 1.0)
}

fn hs021<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] * 10.0 - x[1] - 10.0;
    x[0] * x[0] * 0.01 + x[1] * x[1] - 100.0
}

fn hs024<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    let r3 = 3.0_f64.sqrt();
    c[0] = x[0] / r3 - x[1];
    c[1] = x[0] + x[1] * r3;
    c[2] = -x[0] - x[1] * r3 + 6.0;
    (sq(x[0] - 3.0) - 9.0) * x[1].powi(3) / (27.0 * r3)
}

fn hs026<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = (x[1] * x[1] + 1.0) * x[0] + x[2].powi(4) - 3.0;
    sq(x[0] - x[1]) + (x[1] - x[2]).powi(4)
}

fn hs027<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] + x[2] * x[2] + 1.0;
    sq(x[0] - 1.0) * 0.01 + sq(x[1] - x[0] * x[0])
}

fn hs028<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] + x[1] * 2.0 + x[2] * 3.0 - 1.0;
    sq(x[0] + x[1]) + sq(x[1] + x[2])
}

fn hs035<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = -x[0] - x[1] - x[2] * 2.0 + 3.0;
    -x[0] * 8.0 - x[1] * 6.0 - x[2] * 4.0
        + 9.0
        + x[0] * x[0] * 2.0
        + x[1] * x[1] * 2.0
        + x[2] * x[2]
        + x[0] * x[1] * 2.0
        + x[0] * x[2] * 2.0
}

fn hs039<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[1] - x[0].powi(3) - x[2] * x[2];
    c[1] = x[0] * x[0] - x[1] - x[3] * x[3];
    -x[0]
}

fn hs040<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0].powi(3) + x[1] * x[1] - 1.0;
    c[1] = x[0] * x[0] * x[3] - x[2];
    c[2] = x[3] * x[3] - x[1];
    -(x[0] * x[1] * x[2] * x[3])
}

fn hs043<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    let s = |k: usize| x[k] * x[k];
    c[0] = -s(0) - s(1) - s(2) - s(3) - x[0] + x[1] - x[2] + x[3] + 8.0;
    c[1] = -s(0) - s(1) * 2.0 - s(2) - s(3) * 2.0 + x[0] + x[3] + 10.0;
    c[2] = -s(0) * 2.0 - s(1) - s(2) - x[0] * 2.0 + x[1] + x[3] + 5.0;
    s(0) + s(1) + s(2) * 2.0 + s(3) - x[0] * 5.0 - x[1] * 5.0 - x[2] * 21.0 + x[3] * 7.0
}

fn hs046<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] * x[0] * x[3] + (x[3] - x[4]).sin() - 1.0;
    c[1] = x[1] + x[2].powi(4) * x[3] * x[3] - 2.0;
    sq(x[0] - x[1]) + sq(x[2] - 1.0) + (x[3] - 1.0).powi(4) + (x[4] - 1.0).powi(6)
}

fn hs048<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] + x[1] + x[2] + x[3] + x[4] - 5.0;
    c[1] = x[2] - (x[3] + x[4]) * 2.0 + 3.0;
    sq(x[0] - 1.0) + sq(x[1] - x[2]) + sq(x[3] - x[4])
}

fn hs049<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] + x[1] + x[2] + x[3] * 4.0 - 7.0;
    c[1] = x[2] + x[4] * 5.0 - 6.0;
    sq(x[0] - x[1]) + sq(x[2] - 1.0) + (x[3] - 1.0).powi(4) + (x[4] - 1.0).powi(6)
}

fn hs050<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] + x[1] * 2.0 + x[2] * 3.0 - 6.0;
    c[1] = x[1] + x[2] * 2.0 + x[3] * 3.0 - 6.0;
    c[2] = x[2] + x[3] * 2.0 + x[4] * 3.0 - 6.0;
    sq(x[0] - x[1]) + sq(x[1] - x[2]) + (x[2] - x[3]).powi(4) + sq(x[3] - x[4])
}

fn hs051<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] + x[1] * 3.0 - 4.0;
    c[1] = x[2] + x[3] - x[4] * 2.0;
    c[2] = x[1] - x[4];
    sq(x[0] - x[1]) + sq(x[1] + x[2] - 2.0) + sq(x[3] - 1.0) + sq(x[4] - 1.0)
}

fn hs052<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] + x[1] * 3.0;
    c[1] = x[2] + x[3] - x[4] * 2.0;
    c[2] = x[1] - x[4];
    sq(x[0] * 4.0 - x[1]) + sq(x[1] + x[2] - 2.0) + sq(x[3] - 1.0) + sq(x[4] - 1.0)
}

fn hs053<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] + x[1] * 3.0;
    c[1] = x[2] + x[3] - x[4] * 2.0;
    c[2] = x[1] - x[4];
    sq(x[0] - x[1]) + sq(x[1] + x[2] - 2.0) + sq(x[3] - 1.0) + sq(x[4] - 1.0)
}

fn hs065<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = -(x[0] * x[0]) - x[1] * x[1] - x[2] * x[2] + 48.0;
    sq(x[0] - x[1]) + sq(x[0] + x[1] - 10.0) / 9.0 + sq(x[2] - 5.0)
}

fn hs071<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] * x[1] * x[2] * x[3] - 25.0;
    c[1] = x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3] - 40.0;
    x[0] * x[3] * (x[0] + x[1] + x[2]) + x[2]
}

fn hs073<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] * 2.3 + x[1] * 5.6 + x[2] * 11.1 + x[3] * 1.3 - 5.0;
    let q = x[0] * x[0] * 0.28 + x[1] * x[1] * 0.19 + x[2] * x[2] * 20.5 + x[3] * x[3] * 0.62;
    c[1] = x[0] * 12.0 + x[1] * 11.9 + x[2] * 41.8 + x[3] * 52.1 - 21.0 - q.sqrt() * 1.645;
    c[2] = x[0] + x[1] + x[2] + x[3] - 1.0;
    x[0] * 24.55 + x[1] * 26.75 + x[2] * 39.0 + x[3] * 40.5
}

fn hs076<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = -x[0] - x[1] * 2.0 - x[2] - x[3] + 5.0;
    c[1] = -x[0] * 3.0 - x[1] - x[2] * 2.0 + x[3] + 4.0;
    c[2] = x[1] + x[2] * 4.0 - 1.5;
    x[0] * x[0] + x[1] * x[1] * 0.5 + x[2] * x[2] + x[3] * x[3] * 0.5 - x[0] * x[2] + x[2] * x[3]
        - x[0]
        - x[1] * 3.0
        + x[2]
        - x[3]
}

fn hs077<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    let r2 = 2.0_f64.sqrt();
    c[0] = x[0] * x[0] * x[3] + (x[3] - x[4]).sin() - 2.0 * r2;
    c[1] = x[1] + x[2].powi(4) * x[3] * x[3] - 8.0 - r2;
    sq(x[0] - 1.0) + sq(x[0] - x[1]) + sq(x[2] - 1.0) + (x[3] - 1.0).powi(4) + (x[4] - 1.0).powi(6)
}

fn hs078<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3] + x[4] * x[4] - 10.0;
    c[1] = x[1] * x[2] - x[3] * x[4] * 5.0;
    c[2] = x[0].powi(3) + x[1].powi(3) + 1.0;
    x[0] * x[1] * x[2] * x[3] * x[4]
}

fn hs079<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    let r2 = 2.0_f64.sqrt();
    c[0] = x[0] + x[1] * x[1] + x[2].powi(3) - 2.0 - 3.0 * r2;
    c[1] = x[1] - x[2] * x[2] + x[3] + 2.0 - 2.0 * r2;
    c[2] = x[0] * x[4] - 2.0;
    sq(x[0] - 1.0)
        + sq(x[0] - x[1])
        + sq(x[1] - x[2])
        + (x[2] - x[3]).powi(4)
        + (x[3] - x[4]).powi(4)
}

fn hs080<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3] + x[4] * x[4] - 10.0;
    c[1] = x[1] * x[2] - x[3] * x[4] * 5.0;
    c[2] = x[0].powi(3) + x[1].powi(3) + 1.0;
    (x[0] * x[1] * x[2] * x[3] * x[4]).exp()
}

fn hs081<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3] + x[4] * x[4] - 10.0;
    c[1] = x[1] * x[2] - x[3] * x[4] * 5.0;
    c[2] = x[0].powi(3) + x[1].powi(3) + 1.0;
    (x[0] * x[1] * x[2] * x[3] * x[4]).exp() - sq(x[0].powi(3) + x[1].powi(3) + 1.0) * 0.5
}

fn hs100<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] =
        -(x[0] * x[0]) * 2.0 - x[1].powi(4) * 3.0 - x[2] - x[3] * x[3] * 4.0 - x[4] * 5.0 + 127.0;
    c[1] = -x[0] * 7.0 - x[1] * 3.0 - x[2] * x[2] * 10.0 - x[3] + x[4] + 282.0;
    c[2] = -x[0] * 23.0 - x[1] * x[1] - x[5] * x[5] * 6.0 + x[6] * 8.0 + 196.0;
    c[3] = -(x[0] * x[0]) * 4.0 - x[1] * x[1] + x[0] * x[1] * 3.0 - x[2] * x[2] * 2.0 - x[5] * 5.0
        + x[6] * 11.0;
    sq(x[0] - 10.0)
        + sq(x[1] - 12.0) * 5.0
        + x[2].powi(4)
        + sq(x[3] - 11.0) * 3.0
        + x[4].powi(6) * 10.0
        + x[5] * x[5] * 7.0
        + x[6].powi(4)
        - x[5] * x[6] * 4.0
        - x[5] * 10.0
        - x[6] * 8.0
}

fn hs104<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    let f = x[0].powf(0.67) * x[6].powf(-0.67) * 0.4 + x[1].powf(0.67) * x[7].powf(-0.67) * 0.4
        - x[0]
        - x[1]
        + 10.0;
    c[0] = -x[4] * x[6] * 0.0588 - x[0] * 0.1 + 1.0;
    c[1] = -x[5] * x[7] * 0.0588 - x[0] * 0.1 - x[1] * 0.1 + 1.0;
    c[2] =
        -x[2] * 4.0 / x[4] - x[2].powf(-0.71) * 2.0 / x[4] - x[2].powf(-1.3) * x[6] * 0.0588 + 1.0;
    c[3] =
        -x[3] * 4.0 / x[5] - x[3].powf(-0.71) * 2.0 / x[5] - x[3].powf(-1.3) * x[7] * 0.0588 + 1.0;
    c[4] = f;
    f
}

fn hs106<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = -(x[3] + x[5]) * 0.0025 + 1.0;
    c[1] = -(x[4] + x[6] - x[3]) * 0.0025 + 1.0;
    c[2] = -(x[7] - x[4]) * 0.01 + 1.0;
    c[3] = x[0] * x[5] - x[3] * 833.33252 - x[0] * 100.0 + 83333.333;
    c[4] = x[1] * x[6] - x[4] * 1250.0 - x[1] * x[3] + x[3] * 1250.0;
    c[5] = x[2] * x[7] - 1250000.0 - x[2] * x[4] + x[4] * 2500.0;
    x[0] + x[1] + x[2]
}

fn hs108<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = -(x[2] * x[2]) - x[3] * x[3] + 1.0;
    c[1] = -(x[8] * x[8]) + 1.0;
    c[2] = -(x[4] * x[4]) - x[5] * x[5] + 1.0;
    c[3] = -(x[0] * x[0]) - sq(x[1] - x[8]) + 1.0;
    c[4] = -sq(x[0] - x[4]) - sq(x[1] - x[5]) + 1.0;
    c[5] = -sq(x[0] - x[6]) - sq(x[1] - x[7]) + 1.0;
    c[6] = -sq(x[2] - x[4]) - sq(x[3] - x[5]) + 1.0;
    c[7] = -sq(x[2] - x[6]) - sq(x[3] - x[7]) + 1.0;
    c[8] = -(x[6] * x[6]) - sq(x[7] - x[8]) + 1.0;
    c[9] = x[0] * x[3] - x[1] * x[2];
    c[10] = x[2] * x[8];
    c[11] = -(x[4] * x[8]);
    c[12] = x[4] * x[7] - x[5] * x[6];
    (x[0] * x[3] - x[1] * x[2] + x[2] * x[8] - x[4] * x[8] + x[4] * x[7] - x[5] * x[6]) * -0.5
}

fn hs113<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = -x[0] * 4.0 - x[1] * 5.0 + x[6] * 3.0 - x[7] * 9.0 + 105.0;
    c[1] = -x[0] * 10.0 + x[1] * 8.0 + x[6] * 17.0 - x[7] * 2.0;
    c[2] = x[0] * 8.0 - x[1] * 2.0 - x[8] * 5.0 + x[9] * 2.0 + 12.0;
    c[3] = -sq(x[0] - 2.0) * 3.0 - sq(x[1] - 3.0) * 4.0 - x[2] * x[2] * 2.0 + x[3] * 7.0 + 120.0;
    c[4] = -(x[0] * x[0]) * 5.0 - x[1] * 8.0 - sq(x[2] - 6.0) + x[3] * 2.0 + 40.0;
    c[5] = -sq(x[0] - 8.0) * 0.5 - sq(x[1] - 4.0) * 2.0 - x[4] * x[4] * 3.0 + x[5] + 30.0;
    c[6] = -(x[0] * x[0]) - sq(x[1] - 2.0) * 2.0 + x[0] * x[1] * 2.0 - x[4] * 14.0 + x[5] * 6.0;
    c[7] = x[0] * 3.0 - x[1] * 6.0 - sq(x[8] - 8.0) * 12.0 + x[9] * 7.0;
    x[0] * x[0] + x[1] * x[1] + x[0] * x[1] - x[0] * 14.0 - x[1] * 16.0
        + sq(x[2] - 10.0)
        + sq(x[3] - 5.0) * 4.0
        + sq(x[4] - 3.0)
        + sq(x[5] - 1.0) * 2.0
        + x[6] * x[6] * 5.0
        + sq(x[7] - 11.0) * 7.0
        + sq(x[8] - 10.0) * 2.0
        + sq(x[9] - 7.0)
        + 45.0
}

fn hs118<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    let mut f = T::from(0.0);
    for k in 0..5 {
        let (a, b, d) = (x[3 * k], x[3 * k + 1], x[3 * k + 2]);
        f += a * 2.3 + a * a * 0.0001 + b * 1.7 + b * b * 0.0001 + d * 2.2 + d * d * 0.00015;
    }
    for k in 1..5 {
        for j in 0..3 {
            c[3 * (k - 1) + j] = x[3 * k + j] - x[3 * k + j - 3] + 7.0;
        }
    }
    c[12] = x[0] + x[1] + x[2];
    c[13] = x[3] + x[4] + x[5];
    c[14] = x[6] + x[7] + x[8];
    c[15] = x[9] + x[10] + x[11];
    c[16] = x[12] + x[13] + x[14];
    f
}

fn hs013<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = (-x[0] + 1.0).powi(3) - x[1];
    sq(x[0] - 2.0) + x[1] * x[1]
}

fn hs016<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] + x[1] * x[1];
    c[1] = x[0] * x[0] + x[1];
    sq(x[1] - x[0] * x[0]) * 100.0 + sq(-x[0] + 1.0)
}

fn hs017<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[1] * x[1] - x[0];
    c[1] = x[0] * x[0] - x[1];
    sq(x[1] - x[0] * x[0]) * 100.0 + sq(-x[0] + 1.0)
}

fn hs018<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] * x[1] - 25.0;
    c[1] = x[0] * x[0] + x[1] * x[1] - 25.0;
    x[0] * x[0] * 0.01 + x[1] * x[1]
}

fn hs019<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = sq(x[0] - 5.0) + sq(x[1] - 5.0) - 100.0;
    c[1] = -sq(x[1] - 5.0) - sq(x[0] - 6.0) + 82.81;
    (x[0] - 10.0).powi(3) + (x[1] - 20.0).powi(3)
}

fn hs020<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] + x[1] * x[1];
    c[1] = x[0] * x[0] + x[1];
    c[2] = x[0] * x[0] + x[1] * x[1] - 1.0;
    sq(x[1] - x[0] * x[0]) * 100.0 + sq(-x[0] + 1.0)
}

fn hs022<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = -x[0] - x[1] + 2.0;
    c[1] = -(x[0] * x[0]) + x[1];
    sq(x[0] - 2.0) + sq(x[1] - 1.0)
}

fn hs023<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] + x[1] - 1.0;
    c[1] = x[0] * x[0] + x[1] * x[1] - 1.0;
    c[2] = x[0] * x[0] * 9.0 + x[1] * x[1] - 9.0;
    c[3] = x[0] * x[0] - x[1];
    c[4] = x[1] * x[1] - x[0];
    x[0] * x[0] + x[1] * x[1]
}

fn hs029<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = -(x[0] * x[0]) - x[1] * x[1] * 2.0 - x[2] * x[2] * 4.0 + 48.0;
    -(x[0] * x[1] * x[2])
}

fn hs030<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] * x[0] + x[1] * x[1] - 1.0;
    x[0] * x[0] + x[1] * x[1] + x[2] * x[2]
}

fn hs031<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] * x[1] - 1.0;
    x[0] * x[0] * 9.0 + x[1] * x[1] + x[2] * x[2] * 9.0
}

fn hs032<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[1] * 6.0 + x[2] * 4.0 - x[0].powi(3) - 3.0;
    c[1] = -x[0] - x[1] - x[2] + 1.0;
    sq(x[0] + x[1] * 3.0 + x[2]) + sq(x[0] - x[1]) * 4.0
}

fn hs033<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[2] * x[2] - x[1] * x[1] - x[0] * x[0];
    c[1] = x[0] * x[0] + x[1] * x[1] + x[2] * x[2] - 4.0;
    (x[0] - 1.0) * (x[0] - 2.0) * (x[0] - 3.0) + x[2]
}

fn hs034<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[1] - x[0].exp();
    c[1] = x[2] - x[1].exp();
    -x[0]
}

fn hs036<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = -x[0] - x[1] * 2.0 - x[2] * 2.0 + 72.0;
    -(x[0] * x[1] * x[2])
}

fn hs037<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = -x[0] - x[1] * 2.0 - x[2] * 2.0 + 72.0;
    c[1] = x[0] + x[1] * 2.0 + x[2] * 2.0;
    -(x[0] * x[1] * x[2])
}

fn hs038<T: DualNum<Primitive = f64> + Copy>(x: &[T], _c: &mut [T]) -> T {
    sq(x[1] - x[0] * x[0]) * 100.0
        + sq(-x[0] + 1.0)
        + sq(x[3] - x[2] * x[2]) * 90.0
        + sq(-x[2] + 1.0)
        + (sq(x[1] - 1.0) + sq(x[3] - 1.0)) * 10.1
        + (x[1] - 1.0) * (x[3] - 1.0) * 19.8
}

fn hs041<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] + x[1] * 2.0 + x[2] * 2.0 - x[3];
    -(x[0] * x[1] * x[2]) + 2.0
}

fn hs042<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] - 2.0;
    c[1] = x[2] * x[2] + x[3] * x[3] - 2.0;
    sq(x[0] - 1.0) + sq(x[1] - 2.0) + sq(x[2] - 3.0) + sq(x[3] - 4.0)
}

fn hs044<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = -x[0] - x[1] * 2.0 + 8.0;
    c[1] = -x[0] * 4.0 - x[1] + 12.0;
    c[2] = -x[0] * 3.0 - x[1] * 4.0 + 12.0;
    c[3] = -x[2] * 2.0 - x[3] + 8.0;
    c[4] = -x[2] - x[3] * 2.0 + 8.0;
    c[5] = -x[2] - x[3] + 5.0;
    x[0] - x[1] - x[2] - x[0] * x[2] + x[0] * x[3] + x[1] * x[2] - x[1] * x[3]
}

fn hs045<T: DualNum<Primitive = f64> + Copy>(x: &[T], _c: &mut [T]) -> T {
    -(x[0] * x[1] * x[2] * x[3] * x[4]) / 120.0 + 2.0
}

fn hs055<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] + x[1] * 2.0 + x[4] * 5.0 - 6.0;
    c[1] = x[0] + x[1] + x[2] - 3.0;
    c[2] = x[3] + x[4] + x[5] - 2.0;
    c[3] = x[0] + x[3] - 1.0;
    c[4] = x[1] + x[4] - 2.0;
    c[5] = x[2] + x[5] - 2.0;
    x[0] + x[1] * 2.0 + x[4] * 4.0 + (x[0] * x[3]).exp()
}

fn hs056<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] - sq(x[3].sin()) * 4.2;
    c[1] = x[1] - sq(x[4].sin()) * 4.2;
    c[2] = x[2] - sq(x[5].sin()) * 4.2;
    c[3] = x[0] + x[1] * 2.0 + x[2] * 2.0 - sq(x[6].sin()) * 7.2;
    -(x[0] * x[1] * x[2])
}

fn hs060<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] * (x[1] * x[1] + 1.0) + x[2].powi(4) - 4.0 - 3.0 * 2.0_f64.sqrt();
    sq(x[0] - 1.0) + sq(x[0] - x[1]) + (x[1] - x[2]).powi(4)
}

fn hs061<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] * 3.0 - x[1] * x[1] * 2.0 - 7.0;
    c[1] = x[0] * 4.0 - x[2] * x[2] - 11.0;
    x[0] * x[0] * 4.0 + x[1] * x[1] * 2.0 + x[2] * x[2] * 2.0 - x[0] * 33.0 + x[1] * 16.0
        - x[2] * 24.0
}

fn hs063<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] * 8.0 + x[1] * 14.0 + x[2] * 7.0 - 56.0;
    c[1] = x[0] * x[0] + x[1] * x[1] + x[2] * x[2] - 25.0;
    -(x[0] * x[0]) - x[1] * x[1] * 2.0 - x[2] * x[2] - x[0] * x[1] - x[0] * x[2] + 1000.0
}

fn hs064<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = -(x[0].recip() * 4.0) - x[1].recip() * 32.0 - x[2].recip() * 120.0 + 1.0;
    x[0] * 5.0
        + x[0].recip() * 50000.0
        + x[1] * 20.0
        + x[1].recip() * 72000.0
        + x[2] * 10.0
        + x[2].recip() * 144000.0
}

fn hs066<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[1] - x[0].exp();
    c[1] = x[2] - x[1].exp();
    x[2] * 0.2 - x[0] * 0.8
}

fn hs072<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    let r = |k: usize| x[k].recip();
    c[0] = -(r(0) * 4.0) - r(1) * 2.25 - r(2) - r(3) * 0.25 + 0.0401;
    c[1] = -(r(0) * 0.16) - r(1) * 0.36 - r(2) * 0.64 - r(3) * 0.64 + 0.010085;
    x[0] + x[1] + x[2] + x[3] + 1.0
}

fn hs083<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[1] * x[4] * 0.0056858 + x[0] * x[3] * 0.0006262 - x[2] * x[4] * 0.0022053 + 85.334407;
    c[1] = x[1] * x[4] * 0.0071317 + x[0] * x[1] * 0.0029955 + x[2] * x[2] * 0.0021813 + 80.51249;
    c[2] = x[2] * x[4] * 0.0047026 + x[0] * x[2] * 0.0012547 + x[2] * x[3] * 0.0019085 + 9.300961;
    x[2] * x[2] * 5.3578547 + x[0] * x[4] * 0.8356891 + x[0] * 37.293239 - 40792.141
}

fn hs110<T: DualNum<Primitive = f64> + Copy>(x: &[T], _c: &mut [T]) -> T {
    let mut f = T::from(0.0);
    let mut prod = T::from(1.0);
    for &xi in x {
        f += sq((xi - 2.0).ln()) + sq((-xi + 10.0).ln());
        prod *= xi;
    }
    f - prod.powf(0.2)
}

fn hs112<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    const G: [f64; 10] = [
        -6.089, -17.164, -34.054, -5.914, -24.721, -14.986, -24.1, -10.708, -26.662, -22.179,
    ];
    let total = x.iter().fold(T::from(0.0), |a, &v| a + v);
    let mut f = T::from(0.0);
    for j in 0..10 {
        f += x[j] * ((x[j] / total).ln() + G[j]);
    }
    c[0] = x[0] + x[1] * 2.0 + x[2] * 2.0 + x[5] + x[9] - 2.0;
    c[1] = x[3] + x[4] * 2.0 + x[5] + x[6] - 1.0;
    c[2] = x[2] + x[6] + x[7] + x[8] * 2.0 + x[9] - 1.0;
    f
}

fn hs025<T: DualNum<Primitive = f64> + Copy>(x: &[T], _c: &mut [T]) -> T {
    let mut f = T::from(0.0);
    for i in 1..=99 {
        let t = 0.01 * i as f64;
        let u = 25.0 + (-50.0 * t.ln()).powf(2.0 / 3.0);
        // a^b = exp(b·ln a), with a > 0 on the whole box.
        let power = ((-x[1] + u).ln() * x[2]).exp();
        let r = (-(power / x[0])).exp() - t;
        f += r * r;
    }
    f
}

fn hs062<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[0] + x[1] + x[2] - 1.0;
    let a = ((x[0] + x[1] + x[2] + 0.03) / (x[0] * 0.09 + x[1] + x[2] + 0.03)).ln() * 255.0;
    let b = ((x[1] + x[2] + 0.03) / (x[1] * 0.07 + x[2] + 0.03)).ln() * 280.0;
    let d = ((x[2] + 0.03) / (x[2] * 0.13 + 0.03)).ln() * 290.0;
    (a + b + d) * -32.174
}

fn hs074_75<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    c[0] = x[3] - x[2];
    c[1] = ((-x[2] - 0.25).sin() + (-x[3] - 0.25).sin()) * 1000.0 + 894.8 - x[0];
    c[2] = ((x[2] - 0.25).sin() + (x[2] - x[3] - 0.25).sin()) * 1000.0 + 894.8 - x[1];
    c[3] = ((x[3] - 0.25).sin() + (x[3] - x[2] - 0.25).sin()) * 1000.0 + 1294.8;
    x[0] * 3.0 + x[0].powi(3) * 1e-6 + x[1] * 2.0 + x[1].powi(3) * (2e-6 / 3.0)
}

fn hs093<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    let s1 = x[0] + x[1] + x[2];
    let s2 = x[0] + x[1] * 1.57 + x[3];
    c[0] = x[0] * x[1] * x[2] * x[3] * x[4] * x[5] * 0.001 - 2.07;
    c[1] = -(x[0] * x[3] * x[4] * x[4] * s1 * 0.00062) - x[1] * x[2] * x[5] * x[5] * s2 * 0.00058
        + 1.0;
    x[0] * x[3] * s1 * 0.0204
        + x[1] * x[2] * s2 * 0.0187
        + x[0] * x[3] * x[4] * x[4] * s1 * 0.0607
        + x[1] * x[2] * x[5] * x[5] * s2 * 0.0437
}

fn hs111<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    const G: [f64; 10] = [
        -6.089, -17.164, -34.054, -5.914, -24.721, -14.986, -24.1, -10.708, -26.662, -22.179,
    ];
    let e: Vec<T> = x.iter().map(|v| v.exp()).collect();
    let total = e.iter().fold(T::from(0.0), |a, &v| a + v);
    let mut f = T::from(0.0);
    for j in 0..10 {
        f += e[j] * (x[j] - total.ln() + G[j]);
    }
    c[0] = e[0] + e[1] * 2.0 + e[2] * 2.0 + e[5] + e[9] - 2.0;
    c[1] = e[3] + e[4] * 2.0 + e[5] + e[6] - 1.0;
    c[2] = e[2] + e[6] + e[7] + e[8] * 2.0 + e[9] - 1.0;
    f
}

fn hs116<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    let v = |k: usize| x[k - 1];
    c[0] = v(3) - v(2);
    c[1] = v(2) - v(1);
    c[2] = -v(7) * 0.002 + v(8) * 0.002 + 1.0;
    c[3] = v(11) + v(12) + v(13) - 50.0;
    c[4] = -v(11) - v(12) - v(13) + 250.0;
    c[5] = v(13) - v(10) * 1.262626 + v(3) * v(10) * 1.231059;
    c[6] = v(5) - v(2) * 0.03475 - v(2) * v(5) * 0.975 + v(2) * v(2) * 0.00975;
    c[7] = v(6) - v(3) * 0.03475 - v(3) * v(6) * 0.975 + v(3) * v(3) * 0.00975;
    c[8] = v(5) * v(7) - v(1) * v(8) - v(4) * v(7) + v(4) * v(8);
    c[9] = -(v(2) * v(9) + v(5) * v(8) - v(1) * v(8) - v(6) * v(9)) * 0.002 - v(5) - v(6) + 1.0;
    c[10] = v(2) * v(9) - v(3) * v(10) - v(6) * v(9) - v(2) * 500.0 + v(6) * 500.0 + v(2) * v(10);
    c[11] = v(2) - 0.9 - (v(2) * v(10) - v(3) * v(10)) * 0.002;
    c[12] = v(4) - v(1) * 0.03475 - v(1) * v(4) * 0.975 + v(1) * v(1) * 0.00975;
    c[13] = v(11) - v(8) * 1.262626 + v(1) * v(8) * 1.231059;
    c[14] = v(12) - v(9) * 1.262626 + v(2) * v(9) * 1.231059;
    v(11) + v(12) + v(13)
}

/// HS114 (Bracken & McCormick's alkylation process): variables from 1.5 to 16,000.
fn hs114<T: DualNum<Primitive = f64> + Copy>(x: &[T], c: &mut [T]) -> T {
    let v = |k: usize| x[k - 1];
    let (a, b) = (0.99, 0.9);
    let g5 = v(1) * 1.12 + v(1) * v(8) * 0.13167 - v(1) * v(8) * v(8) * 0.00667 - v(4) * a;
    let g6 = v(8) * 1.098 - v(8) * v(8) * 0.038 + v(6) * 0.325 - v(7) * a + 57.425;
    c[0] = -v(10) * 0.222 - v(9) * b + 35.82;
    c[1] = v(7) * 3.0 - v(10) * a - 133.0;
    c[2] = v(10) * 0.222 + v(9) * (1.0 / b) - 35.82;
    c[3] = -v(7) * 3.0 + v(10) * (1.0 / a) + 133.0;
    c[4] = g5;
    c[5] = g6;
    c[6] = -g5 + v(4) * (1.0 / a - a);
    c[7] = -g6 + v(7) * (1.0 / a - a);
    c[8] = v(4) * 1.22 - v(1) - v(5);
    c[9] = v(3) * 98000.0 / (v(4) * v(9) + v(3) * 1000.0) - v(6);
    c[10] = (v(2) + v(5)) / v(1) - v(8);
    v(1) * 5.04 + v(2) * 0.035 + v(3) * 10.0 + v(5) * 3.36 - v(4) * v(7) * 0.063
}

/// All problems of the set.
pub fn all() -> Vec<Hs> {
    let r2 = 2.0_f64.sqrt();
    let r3 = 3.0_f64.sqrt();
    let e = [0.0];
    let pos = |k: usize| vec![0.0; k];
    let a56 = (1.0_f64 / 4.2).sqrt().asin();
    let b56 = (5.0_f64 / 7.2).sqrt().asin();
    let mut v = vec![
        Hs::new(
            "HS1",
            &[-2.0, 1.0],
            &[-INF, -1.5],
            &[],
            &[],
            &[],
            0.0,
            funs!(hs001),
        ),
        Hs::new(
            "HS2",
            &[-2.0, 1.0],
            &[-INF, 1.5],
            &[],
            &[],
            &[],
            0.0504261879,
            funs!(hs001),
        ),
        Hs::new(
            "HS3",
            &[10.0, 1.0],
            &[-INF, 0.0],
            &[],
            &[],
            &[],
            0.0,
            funs!(hs003),
        ),
        Hs::new(
            "HS4",
            &[1.125, 0.125],
            &[1.0, 0.0],
            &[],
            &[],
            &[],
            8.0 / 3.0,
            funs!(hs004),
        ),
        Hs::new(
            "HS5",
            &[0.0, 0.0],
            &[-1.5, -3.0],
            &[4.0, 3.0],
            &[],
            &[],
            -r3 / 2.0 - std::f64::consts::PI / 3.0,
            funs!(hs005),
        ),
        Hs::new("HS6", &[-1.2, 1.0], &[], &[], &e, &e, 0.0, funs!(hs006)),
        Hs::new("HS7", &[2.0, 2.0], &[], &[], &e, &e, -r3, funs!(hs007)),
        Hs::new(
            "HS8",
            &[2.0, 1.0],
            &[],
            &[],
            &[0.0; 2],
            &[0.0; 2],
            -1.0,
            funs!(hs008),
        ),
        Hs::new("HS9", &[0.0, 0.0], &[], &[], &e, &e, -0.5, funs!(hs009)),
        Hs::new(
            "HS10",
            &[-10.0, 10.0],
            &[],
            &[],
            &e,
            &[INF],
            -1.0,
            funs!(hs010),
        ),
        Hs::new(
            "HS11",
            &[4.9, 0.1],
            &[],
            &[],
            &e,
            &[INF],
            -8.498464223,
            funs!(hs011),
        ),
        Hs::new(
            "HS12",
            &[0.0, 0.0],
            &[],
            &[],
            &e,
            &[INF],
            -30.0,
            funs!(hs012),
        ),
        Hs::new(
            "HS14",
            &[2.0, 2.0],
            &[],
            &[],
            &[0.0, 0.0],
            &[0.0, INF],
            9.0 - 23.0 * 7.0_f64.sqrt() / 8.0,
            funs!(hs014),
        ),
        Hs::new(
            "HS15",
            &[-2.0, 1.0],
            &[],
            &[0.5, INF],
            &[0.0; 2],
            &[INF; 2],
            306.5,
            funs!(hs015),
        ),
        Hs::new(
            "HS21",
            &[-1.0, -1.0],
            &[2.0, -50.0],
            &[50.0, 50.0],
            &e,
            &[INF],
            -99.96,
            funs!(hs021),
        ),
        Hs::new(
            "HS24",
            &[1.0, 0.5],
            &pos(2),
            &[],
            &[0.0; 3],
            &[INF; 3],
            -1.0,
            funs!(hs024),
        ),
        Hs::new(
            "HS26",
            &[-2.6, 2.0, 2.0],
            &[],
            &[],
            &e,
            &e,
            0.0,
            funs!(hs026),
        ),
        Hs::new(
            "HS27",
            &[2.0, 2.0, 2.0],
            &[],
            &[],
            &e,
            &e,
            0.04,
            funs!(hs027),
        ),
        Hs::new(
            "HS28",
            &[-4.0, 1.0, 1.0],
            &[],
            &[],
            &e,
            &e,
            0.0,
            funs!(hs028),
        ),
        Hs::new(
            "HS35",
            &[0.5, 0.5, 0.5],
            &pos(3),
            &[],
            &e,
            &[INF],
            1.0 / 9.0,
            funs!(hs035),
        ),
        Hs::new(
            "HS39",
            &[2.0; 4],
            &[],
            &[],
            &[0.0; 2],
            &[0.0; 2],
            -1.0,
            funs!(hs039),
        ),
        Hs::new(
            "HS40",
            &[0.8; 4],
            &[],
            &[],
            &[0.0; 3],
            &[0.0; 3],
            -0.25,
            funs!(hs040),
        ),
        Hs::new(
            "HS43",
            &[0.0; 4],
            &[],
            &[],
            &[0.0; 3],
            &[INF; 3],
            -44.0,
            funs!(hs043),
        ),
        Hs::new(
            "HS46",
            &[r2 / 2.0, 1.75, 0.5, 2.0, 2.0],
            &[],
            &[],
            &[0.0; 2],
            &[0.0; 2],
            0.0,
            funs!(hs046),
        ),
        Hs::new(
            "HS48",
            &[3.0, 5.0, -3.0, 2.0, -2.0],
            &[],
            &[],
            &[0.0; 2],
            &[0.0; 2],
            0.0,
            funs!(hs048),
        ),
        Hs::new(
            "HS49",
            &[10.0, 7.0, 2.0, -3.0, 0.8],
            &[],
            &[],
            &[0.0; 2],
            &[0.0; 2],
            0.0,
            funs!(hs049),
        ),
        Hs::new(
            "HS50",
            &[35.0, -31.0, 11.0, 5.0, -5.0],
            &[],
            &[],
            &[0.0; 3],
            &[0.0; 3],
            0.0,
            funs!(hs050),
        ),
        Hs::new(
            "HS51",
            &[2.5, 0.5, 2.0, -1.0, 0.5],
            &[],
            &[],
            &[0.0; 3],
            &[0.0; 3],
            0.0,
            funs!(hs051),
        ),
        Hs::new(
            "HS52",
            &[2.0; 5],
            &[],
            &[],
            &[0.0; 3],
            &[0.0; 3],
            1859.0 / 349.0,
            funs!(hs052),
        ),
        Hs::new(
            "HS53",
            &[2.0; 5],
            &[-10.0; 5],
            &[10.0; 5],
            &[0.0; 3],
            &[0.0; 3],
            176.0 / 43.0,
            funs!(hs053),
        ),
        Hs::new(
            "HS65",
            &[-5.0, 5.0, 0.0],
            &[-4.5, -4.5, -5.0],
            &[4.5, 4.5, 5.0],
            &e,
            &[INF],
            0.9535288567,
            funs!(hs065),
        ),
        Hs::new(
            "HS71",
            &[1.0, 5.0, 5.0, 1.0],
            &[1.0; 4],
            &[5.0; 4],
            &[0.0; 2],
            &[INF, 0.0],
            17.0140173,
            funs!(hs071),
        ),
        Hs::new(
            "HS73",
            &[1.0; 4],
            &pos(4),
            &[],
            &[0.0; 3],
            &[INF, INF, 0.0],
            29.894378,
            funs!(hs073),
        ),
        Hs::new(
            "HS76",
            &[0.5; 4],
            &pos(4),
            &[],
            &[0.0; 3],
            &[INF; 3],
            -4.681818181,
            funs!(hs076),
        ),
        Hs::new(
            "HS77",
            &[2.0; 5],
            &[],
            &[],
            &[0.0; 2],
            &[0.0; 2],
            0.24150513,
            funs!(hs077),
        ),
        Hs::new(
            "HS78",
            &[-2.0, 1.5, 2.0, -1.0, -1.0],
            &[],
            &[],
            &[0.0; 3],
            &[0.0; 3],
            -2.91970041,
            funs!(hs078),
        ),
        Hs::new(
            "HS79",
            &[2.0; 5],
            &[],
            &[],
            &[0.0; 3],
            &[0.0; 3],
            0.0787768209,
            funs!(hs079),
        ),
        Hs::new(
            "HS80",
            &[-2.0, 2.0, 2.0, -1.0, -1.0],
            &[-2.3, -2.3, -3.2, -3.2, -3.2],
            &[2.3, 2.3, 3.2, 3.2, 3.2],
            &[0.0; 3],
            &[0.0; 3],
            0.0539498478,
            funs!(hs080),
        ),
        Hs::new(
            "HS81",
            &[-2.0, 2.0, 2.0, -1.0, -1.0],
            &[-2.3, -2.3, -3.2, -3.2, -3.2],
            &[2.3, 2.3, 3.2, 3.2, 3.2],
            &[0.0; 3],
            &[0.0; 3],
            0.0539498478,
            funs!(hs081),
        ),
        Hs::new(
            "HS100",
            &[1.0, 2.0, 0.0, 4.0, 0.0, 1.0, 1.0],
            &[],
            &[],
            &[0.0; 4],
            &[INF; 4],
            680.6300573,
            funs!(hs100),
        ),
        Hs::new(
            "HS104",
            &[6.0, 3.0, 0.4, 0.2, 6.0, 6.0, 1.0, 0.5],
            &[0.1; 8],
            &[10.0; 8],
            &[0.0, 0.0, 0.0, 0.0, 0.1],
            &[INF, INF, INF, INF, 4.2],
            3.9511634396,
            funs!(hs104),
        ),
        Hs::new(
            "HS106",
            &[5000.0, 5000.0, 5000.0, 200.0, 350.0, 150.0, 225.0, 425.0],
            &[100.0, 1000.0, 1000.0, 10.0, 10.0, 10.0, 10.0, 10.0],
            &[
                10000.0, 10000.0, 10000.0, 1000.0, 1000.0, 1000.0, 1000.0, 1000.0,
            ],
            &[0.0; 6],
            &[INF; 6],
            7049.2480205,
            funs!(hs106),
        ),
        Hs::new(
            "HS108",
            &[1.0; 9],
            &[-INF, -INF, -INF, -INF, -INF, -INF, -INF, -INF, 0.0],
            &[],
            &[0.0; 13],
            &[INF; 13],
            -0.8660254038,
            funs!(hs108),
        ),
        Hs::new(
            "HS113",
            &[2.0, 3.0, 5.0, 5.0, 1.0, 2.0, 7.0, 3.0, 6.0, 10.0],
            &[],
            &[],
            &[0.0; 8],
            &[INF; 8],
            24.3062091,
            funs!(hs113),
        ),
        Hs::new(
            "HS13",
            &[-2.0, -2.0],
            &pos(2),
            &[],
            &e,
            &[INF],
            1.0,
            funs!(hs013),
        ),
        Hs::new(
            "HS16",
            &[-2.0, 1.0],
            &[-2.0, -INF],
            &[0.5, 1.0],
            &[0.0; 2],
            &[INF; 2],
            0.25,
            funs!(hs016),
        ),
        Hs::new(
            "HS17",
            &[-2.0, 1.0],
            &[-2.0, -INF],
            &[0.5, 1.0],
            &[0.0; 2],
            &[INF; 2],
            1.0,
            funs!(hs017),
        ),
        Hs::new(
            "HS18",
            &[2.0, 2.0],
            &[2.0, 0.0],
            &[50.0, 50.0],
            &[0.0; 2],
            &[INF; 2],
            5.0,
            funs!(hs018),
        ),
        Hs::new(
            "HS19",
            &[20.1, 5.84],
            &[13.0, 0.0],
            &[100.0, 100.0],
            &[0.0; 2],
            &[INF; 2],
            -6961.81381,
            funs!(hs019),
        ),
        Hs::new(
            "HS20",
            &[-2.0, 1.0],
            &[-0.5, -INF],
            &[0.5, INF],
            &[0.0; 3],
            &[INF; 3],
            81.5 - 25.0 * r3,
            funs!(hs020),
        ),
        Hs::new(
            "HS22",
            &[2.0, 2.0],
            &[],
            &[],
            &[0.0; 2],
            &[INF; 2],
            1.0,
            funs!(hs022),
        ),
        Hs::new(
            "HS23",
            &[3.0, 1.0],
            &[-50.0; 2],
            &[50.0; 2],
            &[0.0; 5],
            &[INF; 5],
            2.0,
            funs!(hs023),
        ),
        Hs::new(
            "HS29",
            &[1.0; 3],
            &[],
            &[],
            &e,
            &[INF],
            -16.0 * r2,
            funs!(hs029),
        ),
        Hs::new(
            "HS30",
            &[1.0; 3],
            &[1.0, -10.0, -10.0],
            &[10.0; 3],
            &e,
            &[INF],
            1.0,
            funs!(hs030),
        ),
        Hs::new(
            "HS31",
            &[1.0; 3],
            &[-10.0, 1.0, -10.0],
            &[10.0, 10.0, 1.0],
            &e,
            &[INF],
            6.0,
            funs!(hs031),
        ),
        Hs::new(
            "HS32",
            &[0.1, 0.7, 0.2],
            &pos(3),
            &[],
            &[0.0; 2],
            &[INF, 0.0],
            1.0,
            funs!(hs032),
        ),
        Hs::new(
            "HS33",
            &[0.0, 0.0, 3.0],
            &pos(3),
            &[INF, INF, 5.0],
            &[0.0; 2],
            &[INF; 2],
            r2 - 6.0,
            funs!(hs033),
        ),
        Hs::new(
            "HS34",
            &[0.0, 1.05, 2.9],
            &pos(3),
            &[100.0, 100.0, 10.0],
            &[0.0; 2],
            &[INF; 2],
            -(10.0_f64.ln().ln()),
            funs!(hs034),
        ),
        Hs::new(
            "HS36",
            &[10.0; 3],
            &pos(3),
            &[20.0, 11.0, 42.0],
            &e,
            &[INF],
            -3300.0,
            funs!(hs036),
        ),
        Hs::new(
            "HS37",
            &[10.0; 3],
            &pos(3),
            &[42.0; 3],
            &[0.0; 2],
            &[INF; 2],
            -3456.0,
            funs!(hs037),
        ),
        Hs::new(
            "HS38",
            &[-3.0, -1.0, -3.0, -1.0],
            &[-10.0; 4],
            &[10.0; 4],
            &[],
            &[],
            0.0,
            funs!(hs038),
        ),
        Hs::new(
            "HS41",
            &[2.0; 4],
            &pos(4),
            &[1.0, 1.0, 1.0, 2.0],
            &e,
            &e,
            52.0 / 27.0,
            funs!(hs041),
        ),
        Hs::new(
            "HS42",
            &[1.0; 4],
            &[],
            &[],
            &[0.0; 2],
            &[0.0; 2],
            28.0 - 10.0 * r2,
            funs!(hs042),
        ),
        Hs::new(
            "HS44",
            &[0.0; 4],
            &pos(4),
            &[],
            &[0.0; 6],
            &[INF; 6],
            -15.0,
            funs!(hs044),
        ),
        Hs::new(
            "HS45",
            &[2.0; 5],
            &pos(5),
            &[1.0, 2.0, 3.0, 4.0, 5.0],
            &[],
            &[],
            1.0,
            funs!(hs045),
        ),
        Hs::new(
            "HS55",
            &[1.0, 2.0, 0.0, 0.0, 0.0, 2.0],
            &pos(6),
            &[1.0, INF, INF, 1.0, INF, INF],
            &[0.0; 6],
            &[0.0; 6],
            19.0 / 3.0,
            funs!(hs055),
        ),
        Hs::new(
            "HS56",
            &[1.0, 1.0, 1.0, a56, a56, a56, b56],
            &[],
            &[],
            &[0.0; 4],
            &[0.0; 4],
            -3.456,
            funs!(hs056),
        ),
        Hs::new(
            "HS60",
            &[2.0; 3],
            &[-10.0; 3],
            &[10.0; 3],
            &e,
            &e,
            0.0325682003,
            funs!(hs060),
        ),
        Hs::new(
            "HS61",
            &[0.0; 3],
            &[],
            &[],
            &[0.0; 2],
            &[0.0; 2],
            -143.6461422,
            funs!(hs061),
        ),
        Hs::new(
            "HS63",
            &[2.0; 3],
            &pos(3),
            &[],
            &[0.0; 2],
            &[0.0; 2],
            961.7151721,
            funs!(hs063),
        ),
        Hs::new(
            "HS64",
            &[1.0; 3],
            &[1e-5; 3],
            &[],
            &e,
            &[INF],
            6299.842428,
            funs!(hs064),
        ),
        Hs::new(
            "HS66",
            &[0.0, 1.05, 2.9],
            &pos(3),
            &[100.0, 100.0, 10.0],
            &[0.0; 2],
            &[INF; 2],
            0.5181632741,
            funs!(hs066),
        ),
        Hs::new(
            "HS72",
            &[1.0; 4],
            &[0.001; 4],
            &[4e5, 3e5, 2e5, 1e5],
            &[0.0; 2],
            &[INF; 2],
            727.67937,
            funs!(hs072),
        ),
        Hs::new(
            "HS83",
            &[78.0, 33.0, 27.0, 27.0, 27.0],
            &[78.0, 33.0, 27.0, 27.0, 27.0],
            &[102.0, 45.0, 45.0, 45.0, 45.0],
            &[0.0, 90.0, 20.0],
            &[92.0, 110.0, 25.0],
            -30665.53867,
            funs!(hs083),
        ),
        Hs::new(
            "HS110",
            &[9.0; 10],
            &[2.001; 10],
            &[9.999; 10],
            &[],
            &[],
            -45.77846971,
            funs!(hs110),
        ),
        Hs::new(
            "HS112",
            &[0.1; 10],
            &[1e-6; 10],
            &[],
            &[0.0; 3],
            &[0.0; 3],
            -47.76109026,
            funs!(hs112),
        ),
        Hs::new(
            "HS25",
            &[100.0, 12.5, 3.0],
            &[0.1, 0.0, 0.0],
            &[100.0, 25.6, 5.0],
            &[],
            &[],
            0.0,
            funs!(hs025),
        ),
        Hs::new(
            "HS62",
            &[0.7, 0.2, 0.1],
            &pos(3),
            &[1.0; 3],
            &e,
            &e,
            -26272.51448,
            funs!(hs062),
        ),
        Hs::new(
            "HS74",
            &[0.0; 4],
            &[0.0, 0.0, -0.55, -0.55],
            &[1200.0, 1200.0, 0.55, 0.55],
            &[-0.55, 0.0, 0.0, 0.0],
            &[0.55, 0.0, 0.0, 0.0],
            5126.4981,
            funs!(hs074_75),
        ),
        Hs::new(
            "HS75",
            &[0.0; 4],
            &[0.0, 0.0, -0.48, -0.48],
            &[1200.0, 1200.0, 0.48, 0.48],
            &[-0.48, 0.0, 0.0, 0.0],
            &[0.48, 0.0, 0.0, 0.0],
            5174.4129,
            funs!(hs074_75),
        ),
        Hs::new(
            "HS93",
            &[5.54, 4.4, 12.02, 11.82, 0.702, 0.852],
            &pos(6),
            &[],
            &[0.0; 2],
            &[INF; 2],
            135.075961,
            funs!(hs093),
        ),
        Hs::new(
            "HS111",
            &[-2.3; 10],
            &[-100.0; 10],
            &[100.0; 10],
            &[0.0; 3],
            &[0.0; 3],
            -47.76109026,
            funs!(hs111),
        ),
        Hs::new(
            "HS114",
            &[
                1745.0, 12000.0, 110.0, 3048.0, 1974.0, 89.2, 92.8, 8.0, 3.6, 145.0,
            ],
            &[1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 85.0, 90.0, 3.0, 1.2, 145.0],
            &[
                2000.0, 16000.0, 120.0, 5000.0, 2000.0, 93.0, 95.0, 12.0, 4.0, 162.0,
            ],
            &[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            &[INF, INF, INF, INF, INF, INF, INF, INF, 0.0, 0.0, 0.0],
            -1768.80696,
            funs!(hs114),
        ),
        Hs::new(
            "HS116",
            &[
                0.5, 0.8, 0.9, 0.1, 0.14, 0.5, 489.0, 80.0, 650.0, 450.0, 150.0, 150.0, 150.0,
            ],
            &[
                0.1, 0.1, 0.1, 1e-4, 0.1, 0.1, 0.1, 0.1, 500.0, 0.1, 1.0, 1e-4, 1e-4,
            ],
            &[
                1.0, 1.0, 1.0, 0.1, 0.9, 0.9, 1000.0, 1000.0, 1000.0, 500.0, 150.0, 150.0, 150.0,
            ],
            &[0.0; 15],
            &[INF; 15],
            97.5875096,
            funs!(hs116),
        ),
    ];
    let mut cl118 = vec![0.0; 12];
    let mut cu118 = vec![
        13.0, 14.0, 13.0, 13.0, 14.0, 13.0, 13.0, 14.0, 13.0, 13.0, 14.0, 13.0,
    ];
    cl118.extend_from_slice(&[60.0, 50.0, 70.0, 85.0, 100.0]);
    cu118.extend_from_slice(&[INF; 5]);
    let mut xl118 = vec![8.0, 43.0, 3.0];
    let mut xu118 = vec![21.0, 57.0, 16.0];
    for _ in 0..4 {
        xl118.extend_from_slice(&[0.0, 0.0, 0.0]);
        xu118.extend_from_slice(&[90.0, 120.0, 60.0]);
    }
    v.push(Hs::new(
        "HS118",
        &[
            20.0, 55.0, 15.0, 20.0, 60.0, 20.0, 20.0, 60.0, 20.0, 20.0, 60.0, 20.0, 20.0, 60.0,
            20.0,
        ],
        &xl118,
        &xu118,
        &cl118,
        &cu118,
        664.8204500,
        funs!(hs118),
    ));
    v
}
