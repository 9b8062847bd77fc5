//! The symbolic analysis of a KKT pattern, shared by every solver of the same pattern.
//!
//! The analysis (AMD ordering, elimination tree, fill pattern of L, and for a simplicial
//! factorization the permuted entries and row reaches of `uplooking`) is a function of the
//! lower-triangle pattern alone, so a solver built for a pattern analysed before on the same
//! thread takes that analysis instead of repeating it: the result is the same bit for bit, only
//! the work is saved. Problems solved in rounds that rebuild the NLP with the same sparsity
//! (cmc normal coordinates, a refinement level solved again) then analyse their KKT patterns
//! once. Each thread keeps the [`REMEMBERED`] most recently used patterns (least recently used
//! forgotten first), so nothing crosses threads and the results do not depend on `--threads`.

use std::cell::RefCell;
use std::sync::Arc;

use faer::sparse::SymbolicSparseColMatRef;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};

use super::KktError;
use super::uplooking::UpLooking;
use crate::solver::remembered::Remembered;

/// Patterns remembered per thread: an SQP solve analyses up to three (least-squares
/// multipliers, the QP's Newton system, the elastic or feasibility subproblem), and the cmc
/// stability analysis one more.
pub const REMEMBERED: usize = 4;

/// An analysed pattern's key: the lower triangle in compressed sparse columns.
type Pattern = (Vec<usize>, Vec<usize>);

/// What a pattern's analysis yields.
pub struct Analysis {
    /// faer's symbolic factorization (ordering, elimination tree, pattern of L).
    pub symbolic: SymbolicCholesky<usize>,
    /// The numeric factorization's pattern work, when it is simplicial (`uplooking`).
    pub up_looking: Option<UpLooking>,
}

thread_local! {
    /// This thread's analysed patterns.
    static ANALYSED: RefCell<Remembered<Pattern, Analysis>> =
        const { RefCell::new(Remembered::new(REMEMBERED)) };
}

/// The symbolic LDLᵀ analysis of the `dim`-square lower-triangle pattern `(col_ptr, row_idx)`
/// (checked by the caller), from this thread's remembered patterns when it is one of them.
pub fn analyse(
    dim: usize,
    col_ptr: &[usize],
    row_idx: &[usize],
) -> Result<Arc<Analysis>, KktError> {
    ANALYSED.with_borrow_mut(|analysed| {
        analysed.get_or_make(
            |(c, r)| c == col_ptr && r == row_idx,
            || {
                let pattern =
                    SymbolicSparseColMatRef::new_checked(dim, dim, col_ptr, None, row_idx);
                let symbolic = factorize_symbolic_cholesky(
                    pattern,
                    faer::Side::Lower,
                    SymmetricOrdering::Amd,
                    CholeskySymbolicParams::default(),
                )
                .map_err(|e| KktError::Symbolic(format!("{e:?}")))?;
                let up_looking = UpLooking::new(&symbolic, col_ptr, row_idx);
                let analysis = Analysis {
                    symbolic,
                    up_looking,
                };
                Ok(((col_ptr.to_vec(), row_idx.to_vec()), analysis))
            },
        )
    })
}
