//! Starting points: an [`Nlp`] seen from another start, and seeded random perturbations.
//!
//! A perturbed start is x0 + δ projected onto the bounds, with δ_j = p·s_j·u_j, u_j uniform in
//! [−1, 1] from a ChaCha8 stream, p the perturbation scale and s_j the variable's range
//! xu_j − xl_j when both bounds are finite, else max(1, |x0_j|).

use rand::RngExt;
use rand_chacha::ChaCha8Rng;

use crate::solver::{Nlp, forward_nlp};

/// `inner` with its starting point replaced; everything else is passed through.
pub struct WithStart<'a> {
    inner: &'a dyn Nlp,
    x0: Vec<f64>,
}

impl<'a> WithStart<'a> {
    /// `inner` started from `x0` (length n).
    pub fn new(inner: &'a dyn Nlp, x0: Vec<f64>) -> Self {
        assert_eq!(x0.len(), inner.dims().n, "start has the wrong length");
        WithStart { inner, x0 }
    }
}

impl Nlp for WithStart<'_> {
    forward_nlp!(inner; dims, bounds, jacobian_structure, eval, eval_derivatives,
        hessian_structure, eval_hessian, constraint_name);
    fn start(&self, x: &mut [f64]) {
        x.copy_from_slice(&self.x0);
    }
}

/// Variable and constraint bounds and the start of a problem, read once.
#[derive(Debug, Clone)]
pub(crate) struct Bounds {
    pub xl: Vec<f64>,
    pub xu: Vec<f64>,
    pub cl: Vec<f64>,
    pub cu: Vec<f64>,
    pub x0: Vec<f64>,
}

impl Bounds {
    pub(crate) fn of(nlp: &dyn Nlp) -> Self {
        let crate::solver::Bounds { xl, xu, cl, cu } = crate::solver::Bounds::of(nlp);
        let mut start = vec![0.0; xl.len()];
        nlp.start(&mut start);
        let mut b = Bounds {
            xl,
            xu,
            cl,
            cu,
            x0: Vec::new(),
        };
        b.x0 = b.project(&start);
        b
    }

    /// `x` clamped into the variable bounds.
    pub(crate) fn project(&self, x: &[f64]) -> Vec<f64> {
        x.iter()
            .zip(self.xl.iter().zip(&self.xu))
            .map(|(&v, (&l, &u))| v.max(l).min(u))
            .collect()
    }

    /// The range of variable j used to scale random moves: xu − xl when both are finite,
    /// else max(1, |x0_j|).
    pub(crate) fn range(&self, j: usize) -> f64 {
        let r = self.xu[j] - self.xl[j];
        if r.is_finite() {
            r
        } else {
            self.x0[j].abs().max(1.0)
        }
    }

    /// The largest violation of the general constraints by values `c`.
    pub(crate) fn violation(&self, c: &[f64]) -> f64 {
        c.iter()
            .zip(self.cl.iter().zip(&self.cu))
            .map(|(&v, (&l, &u))| (l - v).max(v - u).max(0.0))
            .fold(0.0, f64::max)
    }

    /// The ℓ1 sum of the general-constraint violations by values `c`.
    pub(crate) fn violation_sum(&self, c: &[f64]) -> f64 {
        c.iter()
            .zip(self.cl.iter().zip(&self.cu))
            .map(|(&v, (&l, &u))| (l - v).max(v - u).max(0.0))
            .sum()
    }
}

/// The start x0 + δ (see the module header), projected onto the bounds.
pub(crate) fn perturbed(bounds: &Bounds, scale: f64, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let x: Vec<f64> = (0..bounds.x0.len())
        .map(|j| {
            let u: f64 = rng.random_range(-1.0..=1.0);
            bounds.x0[j] + scale * bounds.range(j) * u
        })
        .collect();
    bounds.project(&x)
}
