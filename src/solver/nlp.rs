//! The problem side of the solver: a smooth nonlinear program with a sparse Jacobian.
//!
//! ```text
//!     min f(x)   s.t.   xl ≤ x ≤ xu,   cl ≤ c(x) ≤ cu
//! ```
//! Equality rows have `cl == cu`; infinite bounds are `f64::INFINITY` / `f64::NEG_INFINITY`.
//! The Jacobian pattern is fixed for the whole solve and given as (row, col) triplets; duplicate
//! entries are summed. The optional exact Hessian is of the Lagrangian
//! `L(x, λ) = σ·f(x) + Σᵢ λᵢ·cᵢ(x)` (IPOPT's convention), lower triangle only (row ≥ col).

/// Problem sizes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Dims {
    /// Number of variables.
    pub n: usize,
    /// Number of general constraints (rows of c).
    pub m: usize,
    /// Number of structural nonzeros in the constraint Jacobian.
    pub jac_nnz: usize,
    /// Number of structural nonzeros in the lower triangle of the Lagrangian Hessian;
    /// 0 when the problem provides no exact Hessian.
    pub hess_nnz: usize,
}

/// Why an evaluation could not produce finite values.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EvalError {
    /// The point is outside the domain where the functions are defined (the solver backs off).
    #[error("evaluation undefined at this point: {0}")]
    Domain(String),
    /// The model failed in a way that backing off cannot cure.
    #[error("evaluation failed: {0}")]
    Fatal(String),
}

/// The bounds of an [`Nlp`] as owned vectors: `xl ≤ x ≤ xu` (length n), `cl ≤ c(x) ≤ cu`
/// (length m), ±∞ where a side is absent, in the problem's own units.
pub struct Bounds {
    /// Lower variable bounds.
    pub xl: Vec<f64>,
    /// Upper variable bounds.
    pub xu: Vec<f64>,
    /// Lower constraint bounds.
    pub cl: Vec<f64>,
    /// Upper constraint bounds.
    pub cu: Vec<f64>,
}

impl Bounds {
    /// Reads the bounds of `nlp`.
    pub fn of<N: Nlp + ?Sized>(nlp: &N) -> Bounds {
        let d = nlp.dims();
        let mut b = Bounds {
            xl: vec![0.0; d.n],
            xu: vec![0.0; d.n],
            cl: vec![0.0; d.m],
            cu: vec![0.0; d.m],
        };
        nlp.bounds(&mut b.xl, &mut b.xu, &mut b.cl, &mut b.cu);
        b
    }
}

/// A smooth nonlinear program. Implementations must be deterministic: the same `x` gives the same
/// bits. `Sync` lets the global methods evaluate starts in parallel.
pub trait Nlp: Sync {
    /// Sizes of the problem.
    fn dims(&self) -> Dims;

    /// Variable bounds `xl, xu` (length n) and constraint bounds `cl, cu` (length m).
    fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]);

    /// The starting point (length n).
    fn start(&self, x: &mut [f64]);

    /// Jacobian sparsity pattern, `jac_nnz` (row, col) pairs in the order of `eval_derivatives`.
    fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]);

    /// Objective and constraints at `x` together (one simulation yields both).
    fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError>;

    /// Objective gradient (length n) and Jacobian values (length `jac_nnz`, pattern order) at `x`.
    fn eval_derivatives(
        &self,
        x: &[f64],
        grad: &mut [f64],
        jac: &mut [f64],
    ) -> Result<(), EvalError>;

    /// Lower-triangle pattern of the Lagrangian Hessian (`hess_nnz` pairs, row ≥ col).
    /// Only called when `dims().hess_nnz > 0`.
    fn hessian_structure(&self, _rows: &mut [usize], _cols: &mut [usize]) {}

    /// Values of `σ·∇²f + Σ λᵢ ∇²cᵢ` in `hessian_structure` order.
    /// Only called when `dims().hess_nnz > 0`.
    fn eval_hessian(
        &self,
        _x: &[f64],
        _sigma: f64,
        _lambda: &[f64],
        _values: &mut [f64],
    ) -> Result<(), EvalError> {
        Err(EvalError::Fatal(
            "this problem provides no exact Hessian".into(),
        ))
    }

    /// Names for variables and constraints, used in logs and infeasibility reports.
    fn constraint_name(&self, row: usize) -> String {
        format!("c[{row}]")
    }
}

/// Passes the listed [`Nlp`] methods of a wrapper through to its field `$field` (a name or a
/// tuple index), so a wrapper writes out only the methods it changes:
/// `impl Nlp for Logged<'_> { forward_nlp!(inner; dims, bounds, start); fn eval(..) {..} }`.
/// Methods neither listed nor written keep the trait's defaults.
macro_rules! forward_nlp {
    ($field:tt; $($method:ident),+ $(,)?) => {
        $( $crate::solver::forward_nlp!(@ $field $method); )+
    };
    (@ $f:tt dims) => {
        fn dims(&self) -> $crate::solver::Dims {
            self.$f.dims()
        }
    };
    (@ $f:tt bounds) => {
        fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
            self.$f.bounds(xl, xu, cl, cu)
        }
    };
    (@ $f:tt start) => {
        fn start(&self, x: &mut [f64]) {
            self.$f.start(x)
        }
    };
    (@ $f:tt jacobian_structure) => {
        fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
            self.$f.jacobian_structure(rows, cols)
        }
    };
    (@ $f:tt eval) => {
        fn eval(
            &self,
            x: &[f64],
            f: &mut f64,
            c: &mut [f64],
        ) -> Result<(), $crate::solver::EvalError> {
            self.$f.eval(x, f, c)
        }
    };
    (@ $f:tt eval_derivatives) => {
        fn eval_derivatives(
            &self,
            x: &[f64],
            grad: &mut [f64],
            jac: &mut [f64],
        ) -> Result<(), $crate::solver::EvalError> {
            self.$f.eval_derivatives(x, grad, jac)
        }
    };
    (@ $f:tt hessian_structure) => {
        fn hessian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
            self.$f.hessian_structure(rows, cols)
        }
    };
    (@ $f:tt eval_hessian) => {
        fn eval_hessian(
            &self,
            x: &[f64],
            sigma: f64,
            lambda: &[f64],
            values: &mut [f64],
        ) -> Result<(), $crate::solver::EvalError> {
            self.$f.eval_hessian(x, sigma, lambda, values)
        }
    };
    (@ $f:tt constraint_name) => {
        fn constraint_name(&self, row: usize) -> String {
            self.$f.constraint_name(row)
        }
    };
}
pub(crate) use forward_nlp;
