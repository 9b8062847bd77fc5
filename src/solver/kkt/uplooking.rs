//! The numeric simplicial LDLᵀ factorization with its pattern work done once.
//!
//! ```text
//!     for k = 0 … n−1 (row k of L, up-looking):
//!         x = Ã_{0:k, k}                                  (Ã = P K̃ Pᵀ, upper triangle)
//!         for j in reach(k):                              (the pattern of row k of L, topological)
//!             L_kj = x_j / d_j;   x_i −= L_ij x_j for i < k in column j;   d_k −= L_kj x_j
//!         d_k += x_k … (Ã_kk first);   |d_k| ≤ ε → ±δ (dynamic regularization)
//! ```
//! This is faer's simplicial LDLᵀ (`factorize_simplicial_numeric_ldlt`, the up-looking
//! algorithm of Davis, *Direct Methods for Sparse Linear Systems*, SIAM 2006, §4.8) with the
//! work that depends on the pattern alone moved to the symbolic analysis: faer permutes K
//! into a new upper-triangle matrix and walks the elimination tree for every row's reach at
//! every factorization; here the permuted matrix is a list of source positions and each row's
//! reach is a stored list (memory: one index per entry of L and two per entry of K). The arithmetic is faer's, in the
//! same order (the permuted columns' entries in faer's order, each reach in the order of
//! faer's walk), so the factors are the same bit for bit (`kkt::tests`); the factor solves
//! stay faer's. Used when faer's analysis chooses the simplicial factorization (small or very
//! sparse factors); the supernodal one is left to faer.

use faer::sparse::linalg::cholesky::{SymbolicCholesky, SymbolicCholeskyRaw};

/// Marks an unvisited node in the reach walk, and a root's parent.
const NONE: usize = usize::MAX;

/// The pattern work of one simplicial factorization (see the module header).
pub struct UpLooking {
    /// Column k of the permuted upper triangle: entries `entry_ptr[k]..entry_ptr[k+1]` of
    /// `entry_row` (its permuted row) and `entry_source` (its position in K's values).
    entry_ptr: Vec<usize>,
    entry_row: Vec<usize>,
    entry_source: Vec<usize>,
    /// Row k's reach: the columns j of `L_kj ≠ 0`, entries `reach_ptr[k]..reach_ptr[k+1]` of
    /// `reach` (as many as L has entries below its diagonal: the plan's largest part).
    reach_ptr: Vec<usize>,
    reach: Vec<usize>,
}

/// A pivot that is zero or not finite after regularization: faer's `ZeroPivot` index (the
/// 1-based row of the pivot).
pub struct ZeroPivot(pub usize);

impl UpLooking {
    /// The plan for the `dim`-square lower-triangle pattern `(col_ptr, row_idx)` analysed as
    /// `symbolic`; `None` unless faer chose a simplicial factorization under a permutation.
    pub fn new(
        symbolic: &SymbolicCholesky<usize>,
        col_ptr: &[usize],
        row_idx: &[usize],
    ) -> Option<Self> {
        let SymbolicCholeskyRaw::Simplicial(factor) = symbolic.raw() else {
            return None;
        };
        let n = col_ptr.len() - 1;
        let (_, inverse) = symbolic.perm()?.arrays();
        // P K Pᵀ into the upper triangle, entries in the order faer's
        // `permute_self_adjoint_to_unsorted` writes them: source columns ascending, each
        // column's stored order.
        let target = |old_row: usize, old_col: usize| {
            let (r, c) = (inverse[old_row], inverse[old_col]);
            if r <= c { (c, r) } else { (r, c) }
        };
        let mut entry_ptr = vec![0usize; n + 1];
        for old_col in 0..n {
            for &old_row in &row_idx[col_ptr[old_col]..col_ptr[old_col + 1]] {
                entry_ptr[target(old_row, old_col).0 + 1] += 1;
            }
        }
        for k in 0..n {
            entry_ptr[k + 1] += entry_ptr[k];
        }
        let mut next = entry_ptr.clone();
        let mut entry_row = vec![0usize; row_idx.len()];
        let mut entry_source = vec![0usize; row_idx.len()];
        for old_col in 0..n {
            let entries = col_ptr[old_col]..col_ptr[old_col + 1];
            for (p, &old_row) in entries.clone().zip(&row_idx[entries]) {
                let (col, row) = target(old_row, old_col);
                entry_row[next[col]] = row;
                entry_source[next[col]] = p;
                next[col] += 1;
            }
        }
        // The elimination tree from L's pattern (rows sorted, diagonal first).
        let (l_ptr, l_row) = (factor.col_ptr(), factor.row_idx());
        let parent: Vec<usize> = (0..n)
            .map(|j| {
                if l_ptr[j] + 1 < l_ptr[j + 1] {
                    l_row[l_ptr[j] + 1]
                } else {
                    NONE
                }
            })
            .collect();
        // Each row's reach in the order of faer's `ereach`: the paths from the column's
        // entries up the tree, each later path stacked before the earlier ones.
        let mut reach_ptr = Vec::with_capacity(n + 1);
        reach_ptr.push(0);
        let mut reach = Vec::with_capacity(l_row.len().saturating_sub(n));
        let mut visited = vec![NONE; n];
        let mut stack = vec![0usize; n];
        for k in 0..n {
            visited[k] = k;
            let mut top = n;
            for &start in &entry_row[entry_ptr[k]..entry_ptr[k + 1]] {
                let (mut i, mut len) = (start, 0);
                if i >= k {
                    continue;
                }
                while visited[i] != k {
                    stack[len] = i;
                    len += 1;
                    visited[i] = k;
                    i = parent[i];
                }
                stack.copy_within(..len, top - len);
                top -= len;
            }
            reach.extend_from_slice(&stack[top..]);
            reach_ptr.push(reach.len());
        }
        Some(UpLooking {
            entry_ptr,
            entry_row,
            entry_source,
            reach_ptr,
            reach,
        })
    }

    /// Factors the matrix whose lower-triangle values (in the analysed pattern's order) are
    /// `values` into `l_values` (faer's simplicial layout for `symbolic`), replacing a pivot
    /// with `|d| ≤ epsilon` by `±delta` (its sign; none when `delta` is 0). `x` is a work
    /// vector of length n, zero on entry and on a successful return; `filled` one of length n
    /// (each column's last position written).
    #[allow(clippy::too_many_arguments)]
    pub fn factor(
        &self,
        symbolic: &SymbolicCholesky<usize>,
        values: &[f64],
        l_values: &mut [f64],
        x: &mut [f64],
        filled: &mut [usize],
        epsilon: f64,
        delta: f64,
    ) -> Result<(), ZeroPivot> {
        let SymbolicCholeskyRaw::Simplicial(factor) = symbolic.raw() else {
            unreachable!("an up-looking plan is made for simplicial analyses only")
        };
        let (l_ptr, l_row) = (factor.col_ptr(), factor.row_idx());
        let (epsilon, delta) = (epsilon.abs(), delta.abs());
        filled.copy_from_slice(&l_ptr[..x.len()]);
        for k in 0..x.len() {
            let entries = self.entry_ptr[k]..self.entry_ptr[k + 1];
            for (&i, &p) in self.entry_row[entries.clone()]
                .iter()
                .zip(&self.entry_source[entries])
            {
                x[i] += values[p];
            }
            let mut d = x[k];
            x[k] = 0.0;
            for &j in &self.reach[self.reach_ptr[k]..self.reach_ptr[k + 1]] {
                let start = l_ptr[j];
                filled[j] += 1;
                let position = filled[j];
                let xj = x[j];
                x[j] = 0.0;
                let lkj = xj * (1.0 / l_values[start]);
                let (done, rest) = l_values.split_at_mut(position);
                for (&i, &lij) in l_row[start + 1..position].iter().zip(&done[start + 1..]) {
                    x[i] -= lij * xj;
                }
                d -= lkj * xj;
                rest[0] = lkj;
            }
            if delta > 0.0 && d.abs() <= epsilon {
                d = if d < 0.0 { -delta } else { delta };
            }
            if d == 0.0 || !d.is_finite() {
                x.fill(0.0);
                return Err(ZeroPivot(k + 1));
            }
            l_values[l_ptr[k]] = d;
        }
        Ok(())
    }
}
