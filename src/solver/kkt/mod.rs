//! Sparse symmetric KKT systems and their LDLᵀ factorization.
//!
//! ```text
//!     K = [ H + D_p   Aᵀ        ]      n_p primal rows first,
//!         [ A        −D_d       ]      then n_d dual rows
//! ```
//! K is given by its lower triangle (row ≥ col) in compressed sparse columns, with every
//! diagonal entry present in the pattern. Factorization adds a static regularization
//! `+δ_p` on the primal diagonal and `−δ_d` on the dual diagonal, then computes `LDLᵀ` without
//! pivoting under an approximate-minimum-degree ordering (faer's sparse LDLᵀ; when faer's
//! analysis chooses its simplicial factorization, the same arithmetic by `uplooking`, with the
//! permutation and the elimination-tree walks done once per pattern). When
//! `H + D_p + δ_p I ≻ 0` and `D_d + δ_d I ≻ 0` the matrix is quasi-definite, so this
//! factorization exists and is stable for every symmetric ordering (Vanderbei 1995,
//! "Symmetric quasi-definite matrices", SIAM J. Optim. 5(1)).
//!
//! Before factoring, K is equilibrated symmetrically (Ruiz 2001, "A scaling algorithm to
//! equilibrate both rows and columns norms in matrices", RAL-TR-2001-034): a positive diagonal
//! S with every row of `K̃ = S K S` of ∞-norm ≈ 1, and K̃ plus the static regularization is
//! factored, the regularization being the smaller of δ relative to K̃ and δ absolute in K. Without it an
//! absolute δ_d can exceed the Schur complement `A (H + D_p)⁻¹ Aᵀ` of a KKT matrix whose
//! primal block is large (a big convexification shift), and refinement then cannot restore
//! the equality rows. S is a congruence, so the inertia is unchanged.
//!
//! The symbolic analysis (ordering, elimination tree, fill pattern) runs once in
//! [`KktSolver::new`], or not at all when the thread analysed the same pattern recently
//! (`analysis`); each [`KktSolver::factor`] works in buffers allocated there. Solves refine
//! iteratively against the *unregularized* matrix, so the static regularization only affects
//! the convergence of refinement, not the answer. The inertia (signs of the pivots of D, equal
//! to the signs of K's eigenvalues by Sylvester's law) is reported for IPOPT-style inertia
//! correction (Wächter & Biegler 2006, §3.1).
//!
//! Split by verb: construction and symbolic analysis here, `factor.rs` the numeric
//! factorization and inertia (`uplooking.rs` its simplicial kernel), `solve.rs` the refined
//! solves and the product with K.

mod analysis;
mod factor;
mod solve;
mod uplooking;

use std::sync::Arc;

use faer::Par;
use faer::dyn_stack::{MemBuffer, StackReq};

pub use factor::{Equilibration, Inertia, Regularization};
pub use solve::SolveReport;

/// Why a KKT operation failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum KktError {
    /// The pattern is malformed (out-of-range index, upper-triangle entry, missing diagonal).
    #[error("invalid KKT pattern: {0}")]
    Pattern(String),
    /// The symbolic analysis failed (out of memory or index overflow).
    #[error("symbolic analysis failed: {0}")]
    Symbolic(String),
    /// A pivot was exactly zero or not finite.
    #[error("factorization broke down at pivot {0}")]
    Breakdown(usize),
    /// `solve` was called before a successful `factor`.
    #[error("no valid factorization")]
    NotFactored,
}

/// A symmetric KKT matrix with fixed pattern, its symbolic analysis, and its latest numeric
/// LDLᵀ factorization. All buffers are allocated in [`KktSolver::new`].
pub struct KktSolver {
    n_primal: usize,
    dim: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// The unregularized matrix values (lower triangle), owned by the caller through
    /// [`KktSolver::values_mut`].
    values: Vec<f64>,
    /// Position of each diagonal entry in `values`.
    diag_pos: Vec<usize>,
    /// `S values S` plus the static regularization, handed to the numeric factorization.
    shifted: Vec<f64>,
    /// The equilibrating diagonal S of the last factorization.
    scale: Vec<f64>,
    /// Shared with the other solvers of the same pattern (`analysis`).
    analysis: Arc<analysis::Analysis>,
    l_values: Vec<f64>,
    /// The up-looking factorization's work vectors (`x` zero between factorizations).
    up_looking_work: Vec<f64>,
    up_looking_filled: Vec<usize>,
    factor_mem: MemBuffer,
    solve_mem: MemBuffer,
    /// Right-hand-side columns `solve_mem` is sized for.
    solve_columns: usize,
    /// Residual and correction buffers of iterative refinement.
    residual: Vec<f64>,
    rhs_copy: Vec<f64>,
    factored: bool,
    inertia: Inertia,
    /// What the factors in `l_values` are the factorization of (None before the first
    /// successful [`KktSolver::factor`] and after a failed one).
    last: Option<factor::FactoredValues>,
    /// Successful numeric factorizations (kept factors not counted).
    numeric_factorizations: usize,
}

impl KktSolver {
    /// Analyses the pattern of a `(n_primal + n_dual)`-square symmetric matrix given by its
    /// lower triangle in CSC form (`col_ptr` of length dim + 1, `row_idx` sorted within each
    /// column, no duplicates, every diagonal present). Values start at zero.
    pub fn new(
        n_primal: usize,
        n_dual: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
    ) -> Result<Self, KktError> {
        let dim = n_primal + n_dual;
        let diag_pos = check_pattern(dim, &col_ptr, &row_idx)?;
        let nnz = row_idx.len();
        let analysis = analysis::analyse(dim, &col_ptr, &row_idx)?;
        let symbolic = &analysis.symbolic;
        let factor_req =
            symbolic.factorize_numeric_ldlt_scratch::<f64>(Par::Seq, Default::default());
        let solve_req = symbolic.solve_in_place_scratch::<f64>(1, Par::Seq);
        let l_len = symbolic.len_val();
        Ok(KktSolver {
            n_primal,
            dim,
            col_ptr,
            row_idx,
            values: vec![0.0; nnz],
            diag_pos,
            shifted: vec![0.0; nnz],
            scale: vec![1.0; dim],
            l_values: vec![0.0; l_len],
            up_looking_work: vec![0.0; dim],
            up_looking_filled: vec![0; dim],
            analysis,
            factor_mem: MemBuffer::new(factor_req),
            solve_mem: MemBuffer::new(StackReq::any_of(&[solve_req])),
            solve_columns: 1,
            residual: vec![0.0; dim],
            rhs_copy: vec![0.0; dim],
            factored: false,
            inertia: Inertia::default(),
            last: None,
            numeric_factorizations: 0,
        })
    }

    /// Builds the pattern from lower-triangle `(row, col)` pairs (row ≥ col; duplicates allowed;
    /// diagonals added if missing) and returns the solver with, for each input pair, its
    /// position in [`KktSolver::values_mut`] (duplicates share a position: add into it).
    pub fn from_lower_triplets(
        n_primal: usize,
        n_dual: usize,
        rows: &[usize],
        cols: &[usize],
    ) -> Result<(Self, Vec<usize>), KktError> {
        let dim = n_primal + n_dual;
        if rows.len() != cols.len() {
            return Err(KktError::Pattern("rows and cols differ in length".into()));
        }
        if let Some((&r, &c)) = rows.iter().zip(cols).find(|&(&r, &c)| r >= dim || c > r) {
            return Err(KktError::Pattern(format!(
                "entry ({r}, {c}) is outside the lower triangle of a {dim}×{dim} matrix"
            )));
        }
        // Bucketed by column (each diagonal first), then each column sorted and deduplicated.
        let mut start = vec![1usize; dim + 1];
        start[0] = 0;
        for &c in cols {
            start[c + 1] += 1;
        }
        for c in 0..dim {
            start[c + 1] += start[c];
        }
        let mut bucketed = vec![0usize; start[dim]];
        let mut next = start.clone();
        for k in 0..dim {
            bucketed[next[k]] = k;
            next[k] += 1;
        }
        for (&r, &c) in rows.iter().zip(cols) {
            bucketed[next[c]] = r;
            next[c] += 1;
        }
        let mut col_ptr = vec![0usize; dim + 1];
        let mut row_idx = Vec::with_capacity(bucketed.len());
        for c in 0..dim {
            let column = &mut bucketed[start[c]..start[c + 1]];
            column.sort_unstable();
            let first = row_idx.len();
            for &r in column.iter() {
                if row_idx.len() == first || row_idx.last() != Some(&r) {
                    row_idx.push(r);
                }
            }
            col_ptr[c + 1] = row_idx.len();
        }
        let positions = rows
            .iter()
            .zip(cols)
            .map(|(&r, &c)| {
                let column = &row_idx[col_ptr[c]..col_ptr[c + 1]];
                col_ptr[c] + column.binary_search(&r).unwrap_or_else(|_| unreachable!())
            })
            .collect();
        Ok((Self::new(n_primal, n_dual, col_ptr, row_idx)?, positions))
    }

    /// Matrix dimension `n_primal + n_dual`.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Number of primal rows (the leading block).
    pub fn n_primal(&self) -> usize {
        self.n_primal
    }

    /// Position of the diagonal entry `(k, k)` in the values array.
    pub fn diagonal_position(&self, k: usize) -> usize {
        self.diag_pos[k]
    }

    /// The matrix values (lower triangle, pattern order), to overwrite in place before
    /// [`KktSolver::factor`]. Writing invalidates the current factorization.
    pub fn values_mut(&mut self) -> &mut [f64] {
        self.factored = false;
        &mut self.values
    }

    /// The matrix values (lower triangle, pattern order).
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Successful numeric factorizations so far; a [`KktSolver::factor`] of the values and
    /// regularization already factored keeps the factors and does not count.
    pub fn numeric_factorizations(&self) -> usize {
        self.numeric_factorizations
    }

    /// Returns the solver to the state [`KktSolver::new`] left it in, pattern and analysis kept:
    /// no factorization held (none kept for [`KktSolver::factor`] to reuse, none counted), S = I
    /// as the start of [`Equilibration::RuizFromLast`]. The values are left to be overwritten.
    pub fn forget_factorizations(&mut self) {
        self.factored = false;
        self.last = None;
        self.inertia = Inertia::default();
        self.scale.fill(1.0);
        self.numeric_factorizations = 0;
    }

    /// Number of nonzeros in the factor L (a measure of fill-in).
    pub fn factor_nnz(&self) -> usize {
        self.l_values.len()
    }
}

/// Checks a lower-triangle CSC pattern and returns the diagonal positions.
fn check_pattern(dim: usize, col_ptr: &[usize], row_idx: &[usize]) -> Result<Vec<usize>, KktError> {
    if col_ptr.len() != dim + 1 || col_ptr[0] != 0 || col_ptr[dim] != row_idx.len() {
        return Err(KktError::Pattern(
            "col_ptr does not match the dimension".into(),
        ));
    }
    let mut diag_pos = vec![usize::MAX; dim];
    for c in 0..dim {
        if col_ptr[c] > col_ptr[c + 1] {
            return Err(KktError::Pattern(format!(
                "col_ptr decreases at column {c}"
            )));
        }
        let column = &row_idx[col_ptr[c]..col_ptr[c + 1]];
        for (k, &r) in column.iter().enumerate() {
            if r < c || r >= dim || (k > 0 && column[k - 1] >= r) {
                return Err(KktError::Pattern(format!(
                    "column {c}: rows must be sorted, unique, ≥ {c} and < {dim}"
                )));
            }
            if r == c {
                diag_pos[c] = col_ptr[c] + k;
            }
        }
        if diag_pos[c] == usize::MAX {
            return Err(KktError::Pattern(format!("diagonal ({c}, {c}) missing")));
        }
    }
    Ok(diag_pos)
}

#[cfg(test)]
mod tests;
