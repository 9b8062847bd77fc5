//! Dense strictly convex QP by the Goldfarb–Idnani dual active-set method.
//!
//! ```text
//!     min ½ dᵀH d + gᵀd   s.t.   dl ≤ d ≤ du,   bl ≤ A d ≤ bu        (H ≻ 0)
//! ```
//! Every finite bound becomes one constraint `nₖᵀd ≥ bₖ` (upper bounds are negated); rows with
//! `bl == bu` and variables with `dl == du` are equalities. The method (Goldfarb & Idnani,
//! Math. Programming 27, 1983) starts from the unconstrained minimizer `−H⁻¹g`, keeps the dual
//! iterate feasible (multipliers uₖ ≥ 0 on active inequalities) and adds the most violated
//! constraint at a time, dropping active ones whose multiplier would turn negative. It keeps
//! `J` with `J Jᵀ = H⁻¹` and an upper-triangular `R` with `Jᵀ N = [R; 0]` for the active normals
//! `N`. The equalities come first, without steps and as one block: with `J₀ = L⁻ᵀ`
//! (`H = L Lᵀ`) and the equality normals `N_E`, a Householder QR of `M = J₀ᵀ N_E` column by
//! column (a column whose part outside the earlier ones' span is negligible is a dependent
//! row, skipped) gives R, and J is turned by the same reflections, `J = J₀ Q`, a panel of
//! them at a time in compact WY form (the private module `qp::reflectors`): the factorization
//! of adding the equalities one by one by a reflection of J's inactive columns each, with
//! matrix products instead of one rank-one update of J per equality. The minimizer on their manifold is then formed at once from J and
//! R (`x = J y`, `Rᵀy₁ = b`, `y₂ = −J₂ᵀg`). Inequalities are added by Givens rotations of J's
//! inactive columns. When a violated constraint can be neither reached by a primal step nor
//! made reachable by dropping another, the constraints are inconsistent and the QP is reported
//! `Infeasible` (a certificate of the dual method, not a heuristic).
//!
//! Warm start: constraints of the previous working set are preferred when choosing which
//! violated constraint to add next, which reproduces an unchanged active set in as many steps
//! as it has members and never changes the solution. A solve of the same H, A, g and
//! equality rows as the last one (the SQP's second-order correction moves only the
//! right-hand sides) starts from the last equality phase, `J` and `R` as they were after the
//! equalities were factored ([`EqualityPhase`]): only `x = J y` and the multipliers are formed
//! again.
//!
//! Multipliers are returned in the convention of [`super::QpSolution`]:
//! `H d + g + Aᵀλ + z = 0`, λ ≤ 0 at an active lower bound, ≥ 0 at an active upper one.

use nalgebra::{DMatrix, DVector};

use super::reflectors::Reflectors;
use super::{QpProblem, QpSolution, QpStatus};

/// Identifier of one constraint side (`n` variables, `m` rows): `0..n` lower variable bounds,
/// `n..2n` upper ones, `2n..2n+m` lower row bounds, `2n+m..2n+2m` upper row bounds.
pub type ConstraintId = usize;

/// Which side of which bound a constraint id stands for (`n` variables, `m` rows):
/// `0..n` lower variable bounds, `n..2n` upper ones, `2n..2n+m` lower row bounds,
/// `2n+m..2n+2m` upper row bounds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ConstraintSide {
    VarLower(usize),
    VarUpper(usize),
    RowLower(usize),
    RowUpper(usize),
}

fn side_of(id: ConstraintId, n: usize, m: usize) -> ConstraintSide {
    debug_assert!(id < 2 * (n + m));
    if id < n {
        ConstraintSide::VarLower(id)
    } else if id < 2 * n {
        ConstraintSide::VarUpper(id - n)
    } else if id < 2 * n + m {
        ConstraintSide::RowLower(id - 2 * n)
    } else {
        ConstraintSide::RowUpper(id - 2 * n - m)
    }
}

/// The constraints of a QP in `nₖᵀd ≥ bₖ` form. Products with a row normal use the sparse
/// rows of A (a truss balance row has a handful of nonzeros among a hundred variables).
struct Constraints<'a> {
    n: usize,
    m: usize,
    /// Euclidean norm of each row of A.
    row_norms: Vec<f64>,
    /// The inequality sides with a finite right-hand side, in id order, each with its bₖ and
    /// ‖nₖ‖: the constraints the dual iteration's scan for a violated one looks at.
    inequalities: Vec<Inequality>,
    problem: &'a QpProblem<'a>,
}

/// An inequality side `nₖᵀd ≥ bₖ` with a finite bₖ (see [`Constraints::inequalities`]).
struct Inequality {
    id: ConstraintId,
    rhs: f64,
    normal_norm: f64,
}

impl<'a> Constraints<'a> {
    fn new(problem: &'a QpProblem<'a>) -> Self {
        let row_norms = (problem.a.row_iter())
            .map(|row| row.values().iter().map(|v| v * v).sum::<f64>().sqrt())
            .collect();
        let mut cons = Constraints {
            n: problem.g.len(),
            m: problem.a.nrows(),
            row_norms,
            inequalities: Vec::new(),
            problem,
        };
        cons.inequalities = (0..cons.count())
            .filter(|&id| !cons.is_equality_lower(id) && !cons.is_equality_upper(id))
            .filter_map(|id| {
                cons.rhs(id).map(|rhs| Inequality {
                    id,
                    rhs,
                    normal_norm: cons.normal_norm(id),
                })
            })
            .collect();
        cons
    }

    /// Row `i` of A: its column indices and values.
    fn row(&self, i: usize) -> (&'a [usize], &'a [f64]) {
        let a = self.problem.a;
        let span = a.row_offsets()[i]..a.row_offsets()[i + 1];
        (&a.col_indices()[span.clone()], &a.values()[span])
    }

    /// aᵢᵀv for row `i` of A (the dense product's number, [`dense_dot_tail`]).
    fn row_dot(&self, i: usize, v: &DVector<f64>) -> f64 {
        let (cols, vals) = self.row(i);
        let tail = dense_dot_tail(cols, self.n);
        let mut partial = [0.0; 8];
        for (&c, &a) in cols[..tail].iter().zip(vals) {
            partial[c % 8] += a * v[c];
        }
        let mut sum = 0.0;
        for p in 0..4 {
            sum += partial[p] + partial[p + 4];
        }
        for (&c, &a) in cols[tail..].iter().zip(&vals[tail..]) {
            sum += a * v[c];
        }
        sum
    }

    /// Jᵀaᵢ for row `i` of A: the sum of aᵢⱼ times row j of J (the dense product's numbers,
    /// [`dense_dot_tail`]). Column by column of J, with the eight partial sums on the stack.
    fn jt_times_row(&self, i: usize, j: &DMatrix<f64>) -> DVector<f64> {
        let (cols, vals) = self.row(i);
        let tail = dense_dot_tail(cols, self.n);
        let n = j.nrows().max(1);
        let mut out = DVector::<f64>::zeros(j.ncols());
        let columns = j.as_slice().chunks_exact(n).zip(out.iter_mut());
        for (column, o) in columns {
            let mut partial = [0.0; 8];
            for (&c, &a) in cols[..tail].iter().zip(vals) {
                partial[c % 8] += column[c] * a;
            }
            for p in 0..4 {
                *o += partial[p] + partial[p + 4];
            }
            for (&c, &a) in cols[tail..].iter().zip(&vals[tail..]) {
                *o += column[c] * a;
            }
        }
        out
    }

    /// [`Constraints::jt_times_row`] from `jt = Jᵀ` (so that row k of J is column k of `jt`,
    /// contiguous), the same numbers to the bit: each nonzero `aᵢₖ` scales a whole row of J
    /// into the partial-sum column `k mod 8` of `scratch` (the first to reach a column writes
    /// `0 + x·a`, as the sum starting at +0 would), and the columns are combined as
    /// `jt_times_row` combines its eight partial sums, one output entry at a time in the same
    /// order, a column no nonzero reached reading as +0 (`scratch`'s ninth column, never
    /// written). One pass over each touched row of J instead of one short gather per column of
    /// J. J's columns `..skip` are not read: their entries of the product are left at +0, which
    /// is the dense product's number when those columns are zero on the row's nonzeros (every
    /// term a zero product, ±0, which changes no sum that starts at +0).
    fn jt_times_row_from_transpose(
        &self,
        i: usize,
        jt: &DMatrix<f64>,
        skip: usize,
        scratch: &mut Vec<f64>,
    ) -> DVector<f64> {
        let (cols, vals) = self.row(i);
        let tail = dense_dot_tail(cols, self.n);
        let width = jt.nrows();
        if scratch.len() != 9 * width {
            scratch.clear();
            scratch.resize(9 * width, 0.0);
        }
        let entries = jt.as_slice();
        let row_of_j = |k: usize| &entries[k * width + skip..(k + 1) * width];
        let mut reached = [false; 8];
        for (&k, &a) in cols[..tail].iter().zip(vals) {
            let p = k % 8;
            let partial = &mut scratch[p * width + skip..(p + 1) * width];
            if std::mem::replace(&mut reached[p], true) {
                for (s, &x) in partial.iter_mut().zip(row_of_j(k)) {
                    *s += x * a;
                }
            } else {
                for (s, &x) in partial.iter_mut().zip(row_of_j(k)) {
                    *s = 0.0 + x * a;
                }
            }
        }
        let column = |p: usize| {
            let c = if reached[p] { p } else { 8 };
            &scratch[c * width + skip..(c + 1) * width]
        };
        let mut out = DVector::<f64>::zeros(width);
        let o = &mut out.as_mut_slice()[skip..];
        for p in 0..4 {
            for ((oi, &x), &y) in o.iter_mut().zip(column(p)).zip(column(p + 4)) {
                *oi += x + y;
            }
        }
        for (&k, &a) in cols[tail..].iter().zip(&vals[tail..]) {
            for (oi, &x) in o.iter_mut().zip(row_of_j(k)) {
                *oi += x * a;
            }
        }
        out
    }

    /// Jᵀnₖ for an upper triangular J (the start's `L⁻ᵀ`) from `jt = Jᵀ`
    /// ([`Constraints::jt_times_row_from_transpose`]), the numbers of
    /// [`Constraints::jt_times_normal`] to the bit: J's columns before a row's first nonzero
    /// column index are zero on all of the row's nonzeros, and are skipped.
    fn upper_jt_times_normal_from_transpose(
        &self,
        id: ConstraintId,
        jt: &DMatrix<f64>,
        scratch: &mut Vec<f64>,
    ) -> DVector<f64> {
        let first = |i: usize| self.row(i).0.first().copied().unwrap_or(self.n);
        match side_of(id, self.n, self.m) {
            ConstraintSide::RowLower(i) => {
                self.jt_times_row_from_transpose(i, jt, first(i), scratch)
            }
            ConstraintSide::RowUpper(i) => {
                -self.jt_times_row_from_transpose(i, jt, first(i), scratch)
            }
            ConstraintSide::VarLower(c) => jt.column(c).into_owned(),
            ConstraintSide::VarUpper(c) => -jt.column(c).into_owned(),
        }
    }

    fn count(&self) -> usize {
        2 * (self.n + self.m)
    }

    /// Right-hand side bₖ, or None when that bound is infinite.
    fn rhs(&self, id: ConstraintId) -> Option<f64> {
        let p = self.problem;
        let b = match side_of(id, self.n, self.m) {
            ConstraintSide::VarLower(j) => p.dl[j],
            ConstraintSide::VarUpper(j) => -p.du[j],
            ConstraintSide::RowLower(i) => p.bl[i],
            ConstraintSide::RowUpper(i) => -p.bu[i],
        };
        b.is_finite().then_some(b)
    }

    /// Whether the constraint is one side of an equality (then only the lower side is used).
    fn is_equality_lower(&self, id: ConstraintId) -> bool {
        let p = self.problem;
        match side_of(id, self.n, self.m) {
            ConstraintSide::VarLower(j) => p.dl[j] == p.du[j],
            ConstraintSide::RowLower(i) => p.bl[i] == p.bu[i],
            _ => false,
        }
    }

    fn is_equality_upper(&self, id: ConstraintId) -> bool {
        let p = self.problem;
        match side_of(id, self.n, self.m) {
            ConstraintSide::VarUpper(j) => p.dl[j] == p.du[j],
            ConstraintSide::RowUpper(i) => p.bl[i] == p.bu[i],
            _ => false,
        }
    }

    /// nₖᵀv.
    fn dot(&self, id: ConstraintId, v: &DVector<f64>) -> f64 {
        match side_of(id, self.n, self.m) {
            ConstraintSide::VarLower(j) => v[j],
            ConstraintSide::VarUpper(j) => -v[j],
            ConstraintSide::RowLower(i) => self.row_dot(i, v),
            ConstraintSide::RowUpper(i) => -self.row_dot(i, v),
        }
    }

    /// Jᵀnₖ.
    fn jt_times_normal(&self, id: ConstraintId, j: &DMatrix<f64>) -> DVector<f64> {
        match side_of(id, self.n, self.m) {
            ConstraintSide::VarLower(c) => j.row(c).transpose(),
            ConstraintSide::VarUpper(c) => -j.row(c).transpose(),
            ConstraintSide::RowLower(i) => self.jt_times_row(i, j),
            ConstraintSide::RowUpper(i) => -self.jt_times_row(i, j),
        }
    }

    fn normal_norm(&self, id: ConstraintId) -> f64 {
        match side_of(id, self.n, self.m) {
            ConstraintSide::VarLower(_) | ConstraintSide::VarUpper(_) => 1.0,
            ConstraintSide::RowLower(i) | ConstraintSide::RowUpper(i) => self.row_norms[i],
        }
    }
}

/// Where the tail of nalgebra's dense dot product (length `n`) starts among a sparse row's
/// increasing column indices `cols`: indices below `n − n mod 8` go to the partial sum
/// `c mod 8`, the partial sums are combined as (s₀ + s₄), (s₁ + s₅), (s₂ + s₆), (s₃ + s₇) in
/// turn, and the rest is added one by one after them. Summing a sparse row's nonzeros this way
/// gives the dense product's number to the bit (a zero term changes no sum), so the QP's
/// iterates do not depend on how A is stored.
fn dense_dot_tail(cols: &[usize], n: usize) -> usize {
    cols.partition_point(|&c| c < n - n % 8)
}

/// Result of a dense QP solve together with the final working set (for warm starts).
#[derive(Debug, Clone)]
pub struct DenseQpResult {
    /// The solution in the shared convention.
    pub solution: QpSolution,
    /// Constraint ids active at the end (equalities included).
    pub working_set: Vec<ConstraintId>,
}

/// Givens rotation (c, s, h) with `[c s; −s c]·[a; b] = [h; 0]`.
fn givens(a: f64, b: f64) -> (f64, f64, f64) {
    let h = a.hypot(b);
    if h == 0.0 {
        (1.0, 0.0, 0.0)
    } else {
        (a / h, b / h, h)
    }
}

/// Rotates columns `p` < `q` of `mat`: `(colp, colq) ← (c·colp + s·colq, −s·colp + c·colq)`.
fn rotate_columns(mat: &mut DMatrix<f64>, p: usize, q: usize, c: f64, s: f64) {
    let n = mat.nrows();
    let (left, right) = mat.as_mut_slice().split_at_mut(q * n);
    let column_p = &mut left[p * n..(p + 1) * n];
    for (x, y) in column_p.iter_mut().zip(&mut right[..n]) {
        let (a, b) = (*x, *y);
        *x = c * a + s * b;
        *y = -s * a + c * b;
    }
}

/// `y ← a·x + y` over slices of equal length, each entry as nalgebra's `axpy(a, x, 1)`
/// computes it (`(a·xᵢ)·1 + 1·yᵢ`, the products by 1 exact), so the same numbers.
fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    for (yi, &xi) in y.iter_mut().zip(x) {
        *yi += a * xi;
    }
}

/// The Goldfarb–Idnani state.
#[derive(Debug, Clone)]
struct ActiveSet {
    /// J with J Jᵀ = H⁻¹, rotated so that its first `iq` columns span the active normals.
    j: DMatrix<f64>,
    /// Rᵀ: R upper triangular (first `iq` columns used), held transposed so that the back
    /// substitution in [`ActiveSet::directions`] reads R's rows contiguously.
    rt: DMatrix<f64>,
    /// Active constraint ids in order.
    ids: Vec<ConstraintId>,
    /// Multipliers of the active constraints (≥ 0 for inequalities).
    u: Vec<f64>,
    /// Whether each active constraint is an equality (never dropped).
    equality: Vec<bool>,
    /// Largest |R diagonal| seen, for the linear-dependence test.
    r_norm: f64,
}

impl ActiveSet {
    fn len(&self) -> usize {
        self.ids.len()
    }

    /// z = J[:, iq..] d[iq..] (the primal direction) and r = R⁻¹ d[..iq] (the dual one).
    fn directions(&self, d: &DVector<f64>) -> (DVector<f64>, DVector<f64>) {
        let n = self.j.nrows();
        let iq = self.len();
        let mut z = DVector::zeros(n);
        let columns = self.j.as_slice()[iq * n..].chunks_exact(n.max(1));
        for (column, &dc) in columns.zip(&d.as_slice()[iq..]) {
            axpy(dc, column, z.as_mut_slice());
        }
        let mut r = DVector::<f64>::zeros(iq);
        let (rt, r_slice) = (self.rt.as_slice(), r.as_mut_slice());
        for i in (0..iq).rev() {
            // Row i of R (column i of Rᵀ), entries i + 1..iq.
            let row = &rt[i * n + i + 1..i * n + iq];
            let mut s = d[i];
            for (&t, &rk) in row.iter().zip(&r_slice[i + 1..iq]) {
                s -= t * rk;
            }
            r_slice[i] = s / rt[i * n + i];
        }
        (z, r)
    }

    /// Appends an inequality whose `d = Jᵀn` is given; false when it is linearly dependent on
    /// the active constraints (to working precision).
    ///
    /// J's inactive columns `iq..n` are turned by the chain of Givens rotations of Goldfarb and
    /// Idnani (6n(n − iq) multiply-adds and n − iq square roots) so that `d[iq..]` becomes
    /// `(α, 0, …)`, |α| = ‖d[iq..]‖: `J Jᵀ = H⁻¹` is kept and column iq of `Jᵀ N` becomes
    /// `(d[..iq], α, 0, …)`, R's new column. (The equalities are factored as one block,
    /// [`ActiveSet::add_reflected`].)
    fn add(&mut self, mut d: DVector<f64>, id: ConstraintId, u: f64) -> bool {
        let n = self.j.nrows();
        let iq = self.len();
        if iq >= n {
            return false;
        }
        for c in (iq + 1..n).rev() {
            let (cs, sn, h) = givens(d[c - 1], d[c]);
            if sn == 0.0 {
                continue;
            }
            d[c - 1] = h;
            d[c] = 0.0;
            rotate_columns(&mut self.j, c - 1, c, cs, sn);
        }
        if self.negligible(d[iq]) {
            return false;
        }
        self.push(&d.as_slice()[..=iq], id, u, false);
        true
    }

    /// Appends the equality `id` whose `Jᵀn` is column `c` of `m` (n × m_E), the column
    /// brought up to date with the earlier equalities' reflections ([`Reflectors`], which turn
    /// J and m's later columns in panels). The Householder reflection that maps `m[iq.., c]`
    /// to `(α, 0, …)` is added to `reflectors`, and R's new column is `(m[..iq, c], α)`. False
    /// (nothing added) when the column is dependent on the active ones to working precision:
    /// |α| = ‖m[iq.., c]‖ negligible, the test of [`ActiveSet::add`].
    fn add_reflected(
        &mut self,
        m: &mut DMatrix<f64>,
        c: usize,
        id: ConstraintId,
        reflectors: &mut Reflectors,
    ) -> bool {
        let n = self.j.nrows();
        let iq = self.len();
        debug_assert_eq!(reflectors.len(), iq);
        if iq >= n {
            return false;
        }
        let sigma = m.view((iq, c), (n - iq, 1)).norm();
        if self.negligible(sigma) {
            return false;
        }
        reflectors.reduce(m, c, sigma, &mut self.j);
        self.push(&m.column(c).as_slice()[..=iq], id, 0.0, true);
        true
    }

    /// Whether a new diagonal entry of R of magnitude `|r|` is zero to working precision
    /// (relative to the largest one so far).
    fn negligible(&self, r: f64) -> bool {
        r.abs() <= f64::EPSILON * self.r_norm.max(1.0) * 1e2
    }

    /// Appends constraint `id` with R's new column `r` (its entries `0..=iq`), multiplier `u`.
    fn push(&mut self, r: &[f64], id: ConstraintId, u: f64, equality: bool) {
        let iq = self.len();
        for (i, &ri) in r.iter().enumerate() {
            self.rt[(iq, i)] = ri;
        }
        self.r_norm = self.r_norm.max(r[iq].abs());
        self.ids.push(id);
        self.u.push(u);
        self.equality.push(equality);
    }

    /// Removes the active constraint at position `pos` and restores R's triangular form.
    fn remove(&mut self, pos: usize) {
        let iq = self.len();
        for c in pos..iq - 1 {
            for i in 0..=c + 1 {
                self.rt[(c, i)] = self.rt[(c + 1, i)];
            }
        }
        for i in 0..iq {
            self.rt[(iq - 1, i)] = 0.0;
        }
        self.ids.remove(pos);
        self.u.remove(pos);
        self.equality.remove(pos);
        let iq = iq - 1;
        for c in pos..iq {
            let (cs, sn, h) = givens(self.rt[(c, c)], self.rt[(c, c + 1)]);
            if sn == 0.0 {
                continue;
            }
            self.rt[(c, c)] = h;
            self.rt[(c, c + 1)] = 0.0;
            for k in c + 1..iq {
                let (a, b) = (self.rt[(k, c)], self.rt[(k, c + 1)]);
                self.rt[(k, c)] = cs * a + sn * b;
                self.rt[(k, c + 1)] = -sn * a + cs * b;
            }
            rotate_columns(&mut self.j, c, c + 1, cs, sn);
        }
    }

    /// The minimizer of `½xᵀHx + gᵀx` on the active constraints taken as equalities
    /// `Nᵀx = b`, and its multipliers u (`Hx + g = N u`). With `y = J⁻¹x`, `JᵀH = J⁻¹` and
    /// `JᵀN = [R; 0]`: `Rᵀy₁ = b`, `y₂ = −J₂ᵀg` and `R u = y₁ + J₁ᵀg`, where J₁ is J's first
    /// iq columns and J₂ the rest; `x = J y`.
    fn equality_point(&self, b: &[f64], g: &DVector<f64>) -> (DVector<f64>, Vec<f64>) {
        let iq = self.len();
        // −Jᵀg: y₂, and −J₁ᵀg in the first iq entries before y₁ replaces them.
        let mut y = -self.j.tr_mul(g);
        let j1g: Vec<f64> = y.iter().take(iq).map(|v| -v).collect();
        for c in 0..iq {
            let mut s = b[c];
            for i in 0..c {
                s -= self.rt[(c, i)] * y[i];
            }
            y[c] = s / self.rt[(c, c)];
        }
        let x = &self.j * &y;
        let mut u = vec![0.0; iq];
        for i in (0..iq).rev() {
            let mut s = y[i] + j1g[i];
            for (k, uk) in u.iter().enumerate().skip(i + 1) {
                s -= self.rt[(k, i)] * uk;
            }
            u[i] = s / self.rt[(i, i)];
        }
        (x, u)
    }

    /// `u ← u − t·r`: the active multipliers after a step of length `t` along `r`.
    fn step_multipliers(&mut self, t: f64, r: &DVector<f64>) {
        for (uk, rk) in self.u.iter_mut().zip(r.iter()) {
            *uk -= t * rk;
        }
    }

    /// The largest dual step keeping the active inequality multipliers non-negative along
    /// `r`, and the position of the one that blocks it (`(∞, None)` when none does).
    fn dual_step_limit(&self, r: &DVector<f64>) -> (f64, Option<usize>) {
        let mut t1 = f64::INFINITY;
        let mut drop: Option<usize> = None;
        for k in 0..self.len() {
            if !self.equality[k] && r[k] > 0.0 {
                let t = self.u[k] / r[k];
                if t < t1 {
                    t1 = t;
                    drop = Some(k);
                }
            }
        }
        (t1, drop)
    }
}

/// `U⁻¹` for an upper triangular `u` with a positive diagonal (a Cholesky factor's `Lᵀ`).
/// Column k solves `U x = eₖ` by back substitution over rows `0..=k` only (the rest of x is
/// zero): n³/6 multiply-adds instead of a full solve's n³/2, in the same order of operations
/// as `solve_upper_triangular` (so the same numbers). Columns are solved in pairs, each with
/// its own operations in that order: the pair's two chains of divisions overlap, and each
/// column of U is read once for both.
fn inverse_of_upper(u: &DMatrix<f64>) -> DMatrix<f64> {
    let n = u.nrows();
    let mut inv = DMatrix::zeros(n, n);
    let u = u.as_slice();
    let column = |i: usize| &u[i * n..i * n + i];
    for (pair, block) in inv.as_mut_slice().chunks_mut(2 * n).enumerate() {
        let k = 2 * pair;
        let (a, b) = block.split_at_mut(n);
        a[k] = 1.0;
        if b.is_empty() {
            back_substitute(a, k, u, n);
            continue;
        }
        // Column k + 1 alone down to row k, then both columns together.
        b[k + 1] = 1.0;
        let coeff = b[k + 1] / u[(k + 1) * n + k + 1];
        b[k + 1] = coeff;
        for (x, &ur) in b[..k + 1].iter_mut().zip(column(k + 1)) {
            *x += -coeff * ur;
        }
        for i in (0..=k).rev() {
            let diagonal = u[i * n + i];
            let (ca, cb) = (a[i] / diagonal, b[i] / diagonal);
            a[i] = ca;
            b[i] = cb;
            for ((xa, xb), &ur) in a[..i].iter_mut().zip(&mut b[..i]).zip(column(i)) {
                *xa += -ca * ur;
                *xb += -cb * ur;
            }
        }
    }
    inv
}

/// Back substitution of `U x = x` over rows `0..=k` (U column-major in `u`, n×n), in place.
fn back_substitute(x: &mut [f64], k: usize, u: &[f64], n: usize) {
    for i in (0..=k).rev() {
        let coeff = x[i] / u[i * n + i];
        x[i] = coeff;
        for (xr, &ur) in x[..i].iter_mut().zip(&u[i * n..i * n + i]) {
            *xr += -coeff * ur;
        }
    }
}

/// Iteration cap of the dual active-set loop, in additions plus drops.
fn iteration_cap(n: usize, m: usize) -> usize {
    50 + 10 * (n + m)
}

/// Solves the QP with a dense positive definite `h`. `preferred` lists constraint ids to try
/// first (the previous working set). A non-positive-definite `h` gives `QpStatus::Numerical`.
pub fn solve(h: &DMatrix<f64>, problem: &QpProblem, preferred: &[ConstraintId]) -> DenseQpResult {
    solve_factored(h, None, problem, preferred)
}

/// [`solve`] with the Cholesky factor L of `h` (`h = L Lᵀ`, L in the lower triangle, the
/// strict upper triangle ignored) already computed, as nalgebra's `cholesky` computes it: the
/// same iterates without factoring `h` again.
///
/// `phase` carries the factored equality rows from one solve to the next of the same `h`
/// (the caller drops it when `h` changes): a solve whose A, g and equality rows equal those
/// of the kept phase (a second-order correction: only the right-hand sides move) starts from
/// it instead of forming `J = L⁻ᵀ` and factoring the equalities again, with the same
/// numbers; any other solve replaces it.
pub fn solve_with_factor(
    h: &DMatrix<f64>,
    factor: &DMatrix<f64>,
    problem: &QpProblem,
    preferred: &[ConstraintId],
    phase: &mut Option<EqualityPhase>,
) -> DenseQpResult {
    solve_factored(h, Some((factor, phase)), problem, preferred)
}

/// The state of a dense solve after its equality phase (`J`, `R` and the factored equality
/// rows; the unconstrained minimizer `−H⁻¹g`; the rows found dependent), with what it was
/// computed from besides H: A, g and the equality constraints. See [`solve_with_factor`].
#[derive(Debug, Clone)]
pub struct EqualityPhase {
    a_offsets: Vec<usize>,
    a_columns: Vec<usize>,
    a_values: Vec<f64>,
    g: Vec<f64>,
    equalities: Vec<ConstraintId>,
    set: ActiveSet,
    x: DVector<f64>,
    dependent: Vec<ConstraintId>,
    iterations: usize,
}

impl EqualityPhase {
    /// Whether this phase was computed for `problem`'s A, g and equality constraints.
    fn fits(&self, problem: &QpProblem, equalities: &[ConstraintId]) -> bool {
        let a = problem.a;
        self.equalities == equalities
            && self.g == problem.g
            && self.a_offsets == a.row_offsets()
            && self.a_columns == a.col_indices()
            && self.a_values == a.values()
    }
}

/// [`solve`], factoring `h` unless its factor is given (with the kept equality phase).
fn solve_factored(
    h: &DMatrix<f64>,
    factor: Option<(&DMatrix<f64>, &mut Option<EqualityPhase>)>,
    problem: &QpProblem,
    preferred: &[ConstraintId],
) -> DenseQpResult {
    let n = problem.g.len();
    let m = problem.a.nrows();
    let fail = |status| DenseQpResult {
        solution: QpSolution {
            status,
            d: vec![0.0; n],
            lambda: vec![0.0; m],
            z: vec![0.0; n],
            iterations: 0,
        },
        working_set: Vec::new(),
    };
    if problem.dl.iter().zip(problem.du).any(|(l, u)| l > u)
        || problem.bl.iter().zip(problem.bu).any(|(l, u)| l > u)
    {
        return fail(QpStatus::Infeasible);
    }
    let (factor, phase) = match factor {
        Some((factor, phase)) => (Some(factor), Some(phase)),
        None => (None, None),
    };
    let cons = Constraints::new(problem);
    let equalities: Vec<ConstraintId> = (0..cons.count())
        .filter(|&id| cons.is_equality_lower(id) && cons.rhs(id).is_some())
        .collect();
    let kept = (phase.as_deref())
        .and_then(Option::as_ref)
        .filter(|kept| kept.fits(problem, &equalities));
    let (mut dual, dependent) = match kept {
        Some(kept) => (
            DualIteration::resume(kept, cons, preferred),
            kept.dependent.clone(),
        ),
        None => {
            let Some(mut dual) = DualIteration::start(h, factor, cons, preferred) else {
                return fail(QpStatus::Numerical);
            };
            let dependent = dual.factor_equalities(&equalities);
            if let Some(phase) = phase {
                *phase = Some(EqualityPhase {
                    a_offsets: problem.a.row_offsets().to_vec(),
                    a_columns: problem.a.col_indices().to_vec(),
                    a_values: problem.a.values().to_vec(),
                    g: problem.g.to_vec(),
                    equalities,
                    set: dual.set.clone(),
                    x: dual.x.clone(),
                    dependent: dependent.clone(),
                    iterations: dual.iterations,
                });
            }
            (dual, dependent)
        }
    };
    if let Err(status) = dual.equality_point(&dependent) {
        return fail(status);
    }
    loop {
        if dual.iterations > dual.cap {
            return dual.finish(QpStatus::IterationLimit);
        }
        let Some(ip) = dual.most_violated() else {
            return dual.finish(QpStatus::Optimal);
        };
        if let Err(status) = dual.add_violated(ip) {
            return dual.finish(status);
        }
    }
}

/// The violation below which a constraint with right-hand side `b` and normal norm
/// `normal_norm` counts as met at an x with `‖x‖∞ = x_max`.
fn tolerance_of(b: f64, normal_norm: f64, x_max: f64) -> f64 {
    1e-11 * (1.0 + b.abs() + normal_norm * x_max)
}

/// The dual active-set iteration in progress: the constraints, the factored active set, the
/// primal iterate `x` and the counters.
struct DualIteration<'a> {
    cons: Constraints<'a>,
    set: ActiveSet,
    x: DVector<f64>,
    /// Additions plus drops so far, and their cap ([`iteration_cap`]).
    iterations: usize,
    cap: usize,
    /// Whether each constraint is in the active set.
    active: Vec<bool>,
    /// Whether each constraint was in the previous working set.
    preferred: Vec<bool>,
}

impl<'a> DualIteration<'a> {
    /// The start: `J = L⁻ᵀ` (so that `J Jᵀ = H⁻¹`) from the Cholesky factor `L` of `h` (given,
    /// or computed here), the unconstrained minimizer `x = −H⁻¹g` and an empty active set;
    /// `None` when `h` is not positive definite.
    fn start(
        h: &DMatrix<f64>,
        factor: Option<&DMatrix<f64>>,
        cons: Constraints<'a>,
        preferred: &[ConstraintId],
    ) -> Option<Self> {
        let n = cons.n;
        let computed;
        let lower = match factor {
            Some(l) => l,
            None => {
                computed = h.clone().cholesky()?.unpack_dirty();
                &computed
            }
        };
        let j = inverse_of_upper(&lower.lower_triangle().transpose());
        // −H⁻¹g by the two triangular solves of nalgebra's `Cholesky::solve`.
        let mut x = DVector::from_column_slice(cons.problem.g);
        lower.solve_lower_triangular_unchecked_mut(&mut x);
        lower.ad_solve_lower_triangular_unchecked_mut(&mut x);
        let set = ActiveSet {
            j,
            rt: DMatrix::zeros(n, n),
            ids: Vec::new(),
            u: Vec::new(),
            equality: Vec::new(),
            r_norm: 1.0,
        };
        Some(Self::with(cons, set, -x, 0, preferred))
    }

    /// The state of a kept equality phase, before its minimizer is formed
    /// ([`DualIteration::equality_point`]).
    fn resume(kept: &EqualityPhase, cons: Constraints<'a>, preferred: &[ConstraintId]) -> Self {
        let mut dual = Self::with(
            cons,
            kept.set.clone(),
            kept.x.clone(),
            kept.iterations,
            preferred,
        );
        for &id in &kept.set.ids {
            dual.active[id] = true;
        }
        dual
    }

    /// The iteration at `x` with the active set `set` (none of it marked active yet).
    fn with(
        cons: Constraints<'a>,
        set: ActiveSet,
        x: DVector<f64>,
        iterations: usize,
        preferred: &[ConstraintId],
    ) -> Self {
        let mut is_preferred = vec![false; cons.count()];
        for &id in preferred {
            if id < cons.count() {
                is_preferred[id] = true;
            }
        }
        DualIteration {
            set,
            x,
            iterations,
            cap: iteration_cap(cons.n, cons.m),
            active: vec![false; cons.count()],
            preferred: is_preferred,
            cons,
        }
    }

    /// The violation below which constraint `id` (right-hand side `b`) counts as met at `x`,
    /// `x_max` being `‖x‖∞` (passed in: the scan over all constraints computes it once).
    fn violation_tol(&self, id: ConstraintId, b: f64, x_max: f64) -> f64 {
        tolerance_of(b, self.cons.normal_norm(id), x_max)
    }

    /// Factors the equalities `equalities` (the lower sides of equality constraints with a
    /// finite right-hand side, in order) into the empty active set without a step, and
    /// returns those dependent on earlier ones. As one block: `M = J₀ᵀ N_E` (n × m_E, one
    /// column per equality), a Householder QR of M column by column in their order, J turned
    /// by the same reflections in panels ([`Reflectors`]): the factorization of one reflection
    /// of J per equality (`Jᵀn` of the turned J is M's column with the earlier reflections
    /// applied), with matrix products instead of rank-one updates of J. A row is dependent when
    /// its part `m[iq.., c]` outside the earlier ones' span is negligible (`‖m[iq.., c]‖² = nᵀz`
    /// for the step `z` that a primal step would take), or when [`ActiveSet::add_reflected`]
    /// finds it so. The minimizer on their manifold follows from
    /// [`DualIteration::equality_point`].
    fn factor_equalities(&mut self, equalities: &[ConstraintId]) -> Vec<ConstraintId> {
        debug_assert_eq!(self.set.len(), 0);
        let n = self.cons.n;
        let mut m = DMatrix::zeros(n, equalities.len());
        let jt = self.set.j.transpose();
        let mut scratch = Vec::new();
        for (c, &id) in equalities.iter().enumerate() {
            let column = self
                .cons
                .upper_jt_times_normal_from_transpose(id, &jt, &mut scratch);
            m.set_column(c, &column);
        }
        let mut reflectors = Reflectors::new(n);
        let mut dependent = Vec::new();
        for (c, &id) in equalities.iter().enumerate() {
            reflectors.bring_up_to_date(&mut m, c);
            let iq = self.set.len();
            let outside = m.view((iq, c), (n - iq, 1)).norm_squared();
            if outside <= 1e-14 * (1.0 + self.cons.normal_norm(id).powi(2)) {
                dependent.push(id);
                continue;
            }
            if self.set.add_reflected(&mut m, c, id, &mut reflectors) {
                self.active[id] = true;
            } else {
                dependent.push(id);
            }
            self.iterations += 1;
        }
        reflectors.finish(&mut self.set.j);
        dependent
    }

    /// Sets `x` and the multipliers at once to the minimizer on the factored equalities'
    /// manifold ([`ActiveSet::equality_point`]; no drops are possible, the multipliers of
    /// equalities having no sign); `Err(Infeasible)` when one of the `dependent` rows is
    /// inconsistent with the others there.
    fn equality_point(&mut self, dependent: &[ConstraintId]) -> Result<(), QpStatus> {
        if self.set.len() > 0 {
            let b: Vec<f64> = (self.set.ids.iter())
                .map(|&id| self.cons.rhs(id).unwrap_or(0.0))
                .collect();
            let g = DVector::from_column_slice(self.cons.problem.g);
            let (x, u) = self.set.equality_point(&b, &g);
            self.x = x;
            self.set.u = u;
        }
        let x_max = self.x.amax();
        for &id in dependent {
            let b = self.cons.rhs(id).unwrap_or(0.0);
            let s = self.cons.dot(id, &self.x) - b;
            if s.abs() > self.violation_tol(id, b, x_max) * 1e3 {
                return Err(QpStatus::Infeasible);
            }
        }
        Ok(())
    }

    /// Step 1: the most violated inactive inequality (violation over the norm of its
    /// normal), constraints of the previous working set first; `None` when all are met.
    fn most_violated(&self) -> Option<ConstraintId> {
        let cons = &self.cons;
        let mut best: Option<(ConstraintId, f64, bool)> = None;
        let x_max = self.x.amax();
        for &Inequality {
            id,
            rhs: b,
            normal_norm,
        } in &cons.inequalities
        {
            if self.active[id] {
                continue;
            }
            let s = cons.dot(id, &self.x) - b;
            if s >= -tolerance_of(b, normal_norm, x_max) {
                continue;
            }
            let score = s / normal_norm;
            let pref = self.preferred[id];
            let better = match best {
                None => true,
                Some((_, bs, bp)) => (pref && !bp) || (pref == bp && score < bs),
            };
            if better {
                best = Some((id, score, pref));
            }
        }
        best.map(|(id, _, _)| id)
    }

    /// Step 2: moves until the violated constraint `ip` is met, by primal steps or dual steps
    /// that drop a blocking active constraint, then adds it. `Err(IterationLimit)` past the
    /// cap, `Err(Infeasible)` when `ip` can be reached neither way.
    fn add_violated(&mut self, ip: ConstraintId) -> Result<(), QpStatus> {
        let b_ip = self.cons.rhs(ip).unwrap_or(0.0);
        let mut u_new = 0.0;
        loop {
            self.iterations += 1;
            if self.iterations > self.cap {
                return Err(QpStatus::IterationLimit);
            }
            let s = self.cons.dot(ip, &self.x) - b_ip;
            let d = self.cons.jt_times_normal(ip, &self.set.j);
            let (z, r) = self.set.directions(&d);
            let (t1, drop) = self.set.dual_step_limit(&r);
            let zn = self.cons.dot(ip, &z);
            let znorm = z.norm();
            let t2 = if znorm > 1e-14 * (1.0 + self.x.amax()) && zn > 0.0 {
                -s / zn
            } else {
                f64::INFINITY
            };
            let t = t1.min(t2);
            if !t.is_finite() {
                return Err(QpStatus::Infeasible);
            }
            if t2.is_infinite() {
                // Dual step only.
                self.set.step_multipliers(t, &r);
                u_new += t;
                self.drop_active(drop.expect("finite t1 has a blocking constraint"));
                continue;
            }
            self.x.axpy(t, &z, 1.0);
            self.set.step_multipliers(t, &r);
            u_new += t;
            if t2 <= t1 {
                if self.set.add(d, ip, u_new) {
                    self.active[ip] = true;
                } else {
                    // Numerically dependent although z ≠ 0: treat as satisfied.
                }
                return Ok(());
            }
            self.drop_active(drop.expect("partial step has a blocking constraint"));
        }
    }

    /// Drops the active constraint at position `pos` of the active set.
    fn drop_active(&mut self, pos: usize) {
        self.active[self.set.ids[pos]] = false;
        self.set.remove(pos);
    }

    /// The result with `status` at the current iterate.
    fn finish(self, status: QpStatus) -> DenseQpResult {
        finish(&self.cons, &self.set, self.x, self.iterations, status)
    }
}

/// Maps the active-set multipliers to the shared (λ, z) convention.
fn finish(
    cons: &Constraints,
    set: &ActiveSet,
    x: DVector<f64>,
    iterations: usize,
    status: QpStatus,
) -> DenseQpResult {
    let (n, m) = (cons.n, cons.m);
    let mut lambda = vec![0.0; m];
    let mut z = vec![0.0; n];
    for (&id, &u) in set.ids.iter().zip(&set.u) {
        // Lagrangian ½dᵀHd + gᵀd − Σ u (nᵀd − b): lower sides carry −u, upper sides +u.
        match side_of(id, n, m) {
            ConstraintSide::VarLower(j) => z[j] -= u,
            ConstraintSide::VarUpper(j) => z[j] += u,
            ConstraintSide::RowLower(i) => lambda[i] -= u,
            ConstraintSide::RowUpper(i) => lambda[i] += u,
        }
    }
    DenseQpResult {
        solution: QpSolution {
            status,
            d: x.as_slice().to_vec(),
            lambda,
            z,
            iterations,
        },
        working_set: set.ids.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra_sparse::{CooMatrix, CsrMatrix};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    struct Owned {
        h: DMatrix<f64>,
        g: Vec<f64>,
        a: CsrMatrix<f64>,
        dl: Vec<f64>,
        du: Vec<f64>,
        bl: Vec<f64>,
        bu: Vec<f64>,
    }

    impl Owned {
        fn problem(&self) -> QpProblem<'_> {
            QpProblem {
                h: super::super::QpHessian::Dense(&self.h),
                g: &self.g,
                a: &self.a,
                dl: &self.dl,
                du: &self.du,
                bl: &self.bl,
                bu: &self.bu,
            }
        }
    }

    fn csr(rows: &DMatrix<f64>) -> CsrMatrix<f64> {
        let mut coo = CooMatrix::new(rows.nrows(), rows.ncols());
        for i in 0..rows.nrows() {
            for j in 0..rows.ncols() {
                if rows[(i, j)] != 0.0 {
                    coo.push(i, j, rows[(i, j)]);
                }
            }
        }
        CsrMatrix::from(&coo)
    }

    /// A random symmetric positive definite n×n matrix (BBᵀ + 0.1 I).
    fn random_definite(rng: &mut ChaCha8Rng, n: usize) -> DMatrix<f64> {
        let b = DMatrix::from_fn(n, n, |_, _| rng.random_range(-1.0..1.0));
        &b * b.transpose() + DMatrix::identity(n, n) * 0.1
    }

    /// A random strictly convex QP that is feasible by construction (bounds around a known
    /// point), with a mix of equalities, one- and two-sided rows, and variable bounds.
    fn random_qp(rng: &mut ChaCha8Rng, n: usize, m: usize) -> Owned {
        let h = random_definite(rng, n);
        let g = (0..n).map(|_| rng.random_range(-5.0..5.0)).collect();
        let a = DMatrix::from_fn(m, n, |_, _| {
            if rng.random_range(0.0..1.0) < 0.6 {
                rng.random_range(-2.0..2.0)
            } else {
                0.0
            }
        });
        let x0: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
        let ax0 = &a * DVector::from_column_slice(&x0);
        let (mut bl, mut bu) = (vec![0.0; m], vec![0.0; m]);
        for i in 0..m {
            match i % 4 {
                0 => (bl[i], bu[i]) = (ax0[i], ax0[i]),
                1 => (bl[i], bu[i]) = (ax0[i] - 0.3, f64::INFINITY),
                2 => (bl[i], bu[i]) = (f64::NEG_INFINITY, ax0[i] + 0.2),
                _ => (bl[i], bu[i]) = (ax0[i] - 0.1, ax0[i] + 0.1),
            }
        }
        let dl = x0.iter().map(|x| x - 0.5).collect();
        let du = x0.iter().map(|x| x + 0.4).collect();
        Owned {
            h,
            g,
            a: csr(&a),
            dl,
            du,
            bl,
            bu,
        }
    }

    /// Largest violation of the KKT conditions of the shared convention.
    fn kkt_error(p: &Owned, s: &QpSolution) -> f64 {
        let n = p.g.len();
        let d = DVector::from_column_slice(&s.d);
        let dense_a = DMatrix::from(&p.a);
        let ad = &dense_a * &d;
        let mut grad = &p.h * &d + DVector::from_column_slice(&p.g);
        grad += dense_a.transpose() * DVector::from_column_slice(&s.lambda);
        grad += DVector::from_column_slice(&s.z);
        let mut err = grad.amax();
        let tol = 1e-9;
        for j in 0..n {
            err = err.max(p.dl[j] - d[j]).max(d[j] - p.du[j]);
            if s.z[j] < -tol {
                err = err.max((d[j] - p.dl[j]).abs());
            }
            if s.z[j] > tol {
                err = err.max((d[j] - p.du[j]).abs());
            }
        }
        for i in 0..p.bl.len() {
            err = err.max(p.bl[i] - ad[i]).max(ad[i] - p.bu[i]);
            if s.lambda[i] < -tol {
                err = err.max((ad[i] - p.bl[i]).abs());
            }
            if s.lambda[i] > tol {
                err = err.max((ad[i] - p.bu[i]).abs());
            }
        }
        err
    }

    #[test]
    fn random_feasible_qps_satisfy_kkt() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for trial in 0..60 {
            let n = 2 + trial % 9;
            let m = trial % 7;
            let p = random_qp(&mut rng, n, m);
            let r = solve(&p.h, &p.problem(), &[]);
            assert_eq!(r.solution.status, QpStatus::Optimal, "trial {trial}");
            let e = kkt_error(&p, &r.solution);
            assert!(e < 1e-8, "trial {trial}: KKT error {e}");
        }
    }

    #[test]
    fn warm_start_reproduces_the_solution_in_fewer_steps() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for _ in 0..20 {
            let p = random_qp(&mut rng, 8, 6);
            let cold = solve(&p.h, &p.problem(), &[]);
            let warm = solve(&p.h, &p.problem(), &cold.working_set);
            assert_eq!(warm.solution.status, QpStatus::Optimal);
            for (a, b) in cold.solution.d.iter().zip(&warm.solution.d) {
                assert!((a - b).abs() < 1e-9);
            }
            assert!(warm.solution.iterations <= cold.solution.iterations);
        }
    }

    #[test]
    fn equality_constrained_qps_match_their_kkt_system() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for (n, m) in [(6, 3), (12, 8), (20, 19)] {
            let h = random_definite(&mut rng, n);
            let g = DVector::from_fn(n, |_, _| rng.random_range(-5.0..5.0));
            let a = DMatrix::from_fn(m, n, |_, _| rng.random_range(-2.0..2.0));
            let rhs = DVector::from_fn(m, |_, _| rng.random_range(-1.0..1.0));
            // [H Aᵀ; A 0] [d; λ] = [−g; rhs]
            let mut kkt = DMatrix::zeros(n + m, n + m);
            kkt.view_mut((0, 0), (n, n)).copy_from(&h);
            kkt.view_mut((0, n), (n, m)).copy_from(&a.transpose());
            kkt.view_mut((n, 0), (m, n)).copy_from(&a);
            let mut right = DVector::zeros(n + m);
            right.rows_mut(0, n).copy_from(&(-&g));
            right.rows_mut(n, m).copy_from(&rhs);
            let exact = kkt.lu().solve(&right).expect("non-singular KKT matrix");
            let p = Owned {
                h,
                g: g.as_slice().to_vec(),
                a: csr(&a),
                dl: vec![f64::NEG_INFINITY; n],
                du: vec![f64::INFINITY; n],
                bl: rhs.as_slice().to_vec(),
                bu: rhs.as_slice().to_vec(),
            };
            let r = solve(&p.h, &p.problem(), &[]);
            assert_eq!(r.solution.status, QpStatus::Optimal);
            for k in 0..n {
                assert!((r.solution.d[k] - exact[k]).abs() < 1e-9, "n {n}: d[{k}]");
            }
            for i in 0..m {
                assert!(
                    (r.solution.lambda[i] - exact[n + i]).abs() < 1e-8,
                    "n {n}: λ[{i}]"
                );
            }
        }
    }

    #[test]
    fn inconsistent_rows_are_infeasible() {
        // d₀ + d₁ ≥ 1 and d₀ + d₁ ≤ 0 written as two rows, plus a harmless bound.
        let p = Owned {
            h: DMatrix::identity(2, 2),
            g: vec![1.0, -1.0],
            a: csr(&DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0])),
            dl: vec![-10.0, f64::NEG_INFINITY],
            du: vec![10.0, f64::INFINITY],
            bl: vec![1.0, f64::NEG_INFINITY],
            bu: vec![f64::INFINITY, 0.0],
        };
        assert_eq!(
            solve(&p.h, &p.problem(), &[]).solution.status,
            QpStatus::Infeasible
        );
    }

    #[test]
    fn rows_inconsistent_with_bounds_are_infeasible() {
        // d₀ + d₁ = 3 with 0 ≤ d ≤ 1.
        let p = Owned {
            h: DMatrix::identity(2, 2) * 2.0,
            g: vec![0.0, 0.0],
            a: csr(&DMatrix::from_row_slice(1, 2, &[1.0, 1.0])),
            dl: vec![0.0, 0.0],
            du: vec![1.0, 1.0],
            bl: vec![3.0],
            bu: vec![3.0],
        };
        assert_eq!(
            solve(&p.h, &p.problem(), &[]).solution.status,
            QpStatus::Infeasible
        );
        // Dependent, inconsistent equalities.
        let q = Owned {
            a: csr(&DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 2.0, 2.0])),
            dl: vec![f64::NEG_INFINITY; 2],
            du: vec![f64::INFINITY; 2],
            bl: vec![1.0, 3.0],
            bu: vec![1.0, 3.0],
            ..p
        };
        assert_eq!(
            solve(&q.h, &q.problem(), &[]).solution.status,
            QpStatus::Infeasible
        );
    }

    #[test]
    fn dependent_consistent_equalities_are_accepted() {
        let p = Owned {
            h: DMatrix::identity(3, 3),
            g: vec![1.0, 2.0, 3.0],
            a: csr(&DMatrix::from_row_slice(
                3,
                3,
                &[1.0, 1.0, 0.0, 2.0, 2.0, 0.0, 0.0, 1.0, 1.0],
            )),
            dl: vec![f64::NEG_INFINITY; 3],
            du: vec![f64::INFINITY; 3],
            bl: vec![1.0, 2.0, 0.5],
            bu: vec![1.0, 2.0, 0.5],
        };
        let r = solve(&p.h, &p.problem(), &[]);
        assert_eq!(r.solution.status, QpStatus::Optimal);
        assert!(kkt_error(&p, &r.solution) < 1e-9);
    }

    #[test]
    fn indefinite_hessian_is_a_numerical_failure() {
        let p = Owned {
            h: DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, -1.0]),
            g: vec![0.0, 0.0],
            a: csr(&DMatrix::zeros(0, 2)),
            dl: vec![-1.0; 2],
            du: vec![1.0; 2],
            bl: vec![],
            bu: vec![],
        };
        assert_eq!(
            solve(&p.h, &p.problem(), &[]).solution.status,
            QpStatus::Numerical
        );
    }

    #[test]
    fn the_triangular_inverse_is_the_full_solve_to_the_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        // Odd and even orders: columns are solved in pairs.
        for n in [1, 8, 9] {
            let h = random_definite(&mut rng, n);
            let u = h.cholesky().expect("positive definite").l().transpose();
            let inv = inverse_of_upper(&u);
            let full = u.solve_upper_triangular(&DMatrix::identity(n, n)).unwrap();
            assert_eq!(inv, full);
            assert!((&u * &inv - DMatrix::identity(n, n)).amax() < 1e-12);
        }
    }

    #[test]
    fn a_kept_equality_phase_gives_the_fresh_solve_to_the_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for (n, m) in [(6, 4), (12, 9), (20, 15)] {
            let p = random_qp(&mut rng, n, m);
            let factor = p.h.clone().cholesky().unwrap().unpack_dirty();
            let mut phase = None;
            let first = solve_with_factor(&p.h, &factor, &p.problem(), &[], &mut phase);
            assert!(phase.is_some());
            // The right-hand sides moved (a second-order correction): the kept phase is used,
            // and the solution is the one of a solve without it.
            let shift: Vec<f64> = (0..m).map(|_| rng.random_range(-0.05..0.05)).collect();
            let moved = Owned {
                bl: p.bl.iter().zip(&shift).map(|(b, s)| b + s).collect(),
                bu: p.bu.iter().zip(&shift).map(|(b, s)| b + s).collect(),
                ..p
            };
            let kept = phase.clone();
            let resumed = solve_with_factor(
                &moved.h,
                &factor,
                &moved.problem(),
                &first.working_set,
                &mut phase,
            );
            let fresh = solve(&moved.h, &moved.problem(), &first.working_set);
            assert_eq!(resumed.solution.status, fresh.solution.status);
            assert_eq!(resumed.solution.d, fresh.solution.d);
            assert_eq!(resumed.solution.lambda, fresh.solution.lambda);
            assert_eq!(resumed.solution.z, fresh.solution.z);
            assert_eq!(resumed.working_set, fresh.working_set);
            assert_eq!(resumed.solution.iterations, fresh.solution.iterations);
            // Used, not replaced: the same A, g and equality rows.
            let (before, after) = (kept.unwrap(), phase.clone().unwrap());
            assert_eq!(before.set.j, after.set.j);
            // Another g replaces it.
            let other = Owned {
                g: moved.g.iter().map(|v| v + 1.0).collect(),
                ..moved
            };
            solve_with_factor(&other.h, &factor, &other.problem(), &[], &mut phase);
            assert_eq!(phase.unwrap().g, other.g);
        }
    }

    #[test]
    fn the_directions_are_nalgebras_axpy_to_the_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        for (n, iq) in [(5, 0), (9, 3), (17, 10)] {
            let d = DVector::from_fn(n, |_, _| rng.random_range(-1.0..1.0));
            let mut set = ActiveSet {
                j: DMatrix::from_fn(n, n, |_, _| rng.random_range(-1.0..1.0)),
                rt: DMatrix::zeros(n, n),
                ids: (0..iq).collect(),
                u: vec![0.0; iq],
                equality: vec![true; iq],
                r_norm: 1.0,
            };
            // z = J₂ d₂ by nalgebra's axpy, r = R⁻¹ d₁ (R = I here).
            for k in 0..iq {
                set.rt[(k, k)] = 1.0;
            }
            let (z, r) = set.directions(&d);
            let mut z_reference = DVector::zeros(n);
            for c in iq..n {
                z_reference.axpy(d[c], &set.j.column(c), 1.0);
            }
            assert_eq!(z, z_reference);
            assert_eq!(r.as_slice(), &d.as_slice()[..iq]);
        }
    }

    /// The equality phase one reflection of J at a time (nalgebra's products): J, R's columns
    /// and the rows of `a` found dependent, by the tests of [`DualIteration::factor_equalities`].
    fn sequential_equality_phase(
        h: &DMatrix<f64>,
        a: &DMatrix<f64>,
    ) -> (DMatrix<f64>, Vec<Vec<f64>>, Vec<usize>) {
        let n = h.nrows();
        let l = h.clone().cholesky().expect("positive definite").l();
        let mut j = l.transpose().try_inverse().expect("non-singular");
        let (mut r, mut dependent, mut r_norm) = (Vec::new(), Vec::new(), 1.0_f64);
        for i in 0..a.nrows() {
            let normal = a.row(i).transpose();
            let d = j.tr_mul(&normal);
            let iq = r.len();
            let tail = d.rows(iq, n - iq);
            if tail.norm_squared() <= 1e-14 * (1.0 + normal.norm_squared()) {
                dependent.push(i);
                continue;
            }
            let sigma = tail.norm();
            if sigma <= f64::EPSILON * r_norm.max(1.0) * 1e2 {
                dependent.push(i);
                continue;
            }
            let alpha = if d[iq] > 0.0 { -sigma } else { sigma };
            let mut v = tail.into_owned();
            v[0] -= alpha;
            let beta = 1.0 / (sigma * (sigma + d[iq].abs()));
            let mut inactive = j.columns_mut(iq, n - iq);
            let w = &inactive * &v;
            inactive.ger(-beta, &w, &v, 1.0);
            let mut column = d.as_slice()[..iq].to_vec();
            column.push(alpha);
            r.push(column);
            r_norm = r_norm.max(sigma);
        }
        (j, r, dependent)
    }

    #[test]
    fn the_block_equality_phase_is_the_sequential_reflections() {
        let mut rng = ChaCha8Rng::seed_from_u64(13);
        // Dependent rows: row 3 = row 0 + 2·row 1, row 5 = row 2 (and, for 5 × 8, any row past
        // the rank).
        for (n, m) in [(5, 8), (12, 7), (30, 20)] {
            let h = random_definite(&mut rng, n);
            let mut a = DMatrix::from_fn(m, n, |_, _| {
                if rng.random_range(0.0..1.0) < 0.5 {
                    rng.random_range(-2.0..2.0)
                } else {
                    0.0
                }
            });
            let combination = a.row(0) + a.row(1) * 2.0;
            a.set_row(3, &combination);
            let copy = a.row(2).into_owned();
            a.set_row(5, &copy);
            let p = Owned {
                h: h.clone(),
                g: vec![0.0; n],
                a: csr(&a),
                dl: vec![f64::NEG_INFINITY; n],
                du: vec![f64::INFINITY; n],
                bl: vec![0.0; m],
                bu: vec![0.0; m],
            };
            let problem = p.problem();
            let cons = Constraints::new(&problem);
            let mut dual = DualIteration::start(&h, None, cons, &[]).expect("definite");
            let equalities: Vec<ConstraintId> = (0..m).map(|i| 2 * n + i).collect();
            let dependent = dual.factor_equalities(&equalities);
            let (j_reference, r_reference, dependent_reference) = sequential_equality_phase(&h, &a);
            let rows = |ids: &[ConstraintId]| ids.iter().map(|id| id - 2 * n).collect::<Vec<_>>();
            assert_eq!(rows(&dependent), dependent_reference, "{n} × {m}");
            assert!(dependent.contains(&(2 * n + 3)) && dependent.contains(&(2 * n + 5)));
            let set = &dual.set;
            let iq = set.len();
            assert_eq!(iq, r_reference.len());
            // J orthonormal in the H metric: JᵀHJ = I (J Jᵀ = H⁻¹).
            let j = &set.j;
            assert!((j.transpose() * &h * j - DMatrix::identity(n, n)).amax() < 1e-10);
            // The same span: J₁J₁ᵀ (the H⁻¹-projector onto H⁻¹N) as the sequential one's.
            let (j1, j1_reference) = (j.columns(0, iq), j_reference.columns(0, iq));
            let projector = j1 * j1.transpose();
            let projector_reference = j1_reference * j1_reference.transpose();
            assert!((projector - projector_reference).amax() < 1e-10 * h.norm());
            // R up to the signs of its rows, and JᵀN = [R; 0].
            let normals = DMatrix::from_fn(n, iq, |k, c| a[(set.ids[c] - 2 * n, k)]);
            let jt_n = j.transpose() * &normals;
            for (c, column) in r_reference.iter().enumerate() {
                for (i, &reference) in column.iter().enumerate() {
                    let sign = (set.rt[(i, i)] * r_reference[i][i]).signum();
                    assert!(
                        (set.rt[(c, i)] - sign * reference).abs()
                            < 1e-10 * reference.abs().max(1.0)
                    );
                    assert!((jt_n[(i, c)] - set.rt[(c, i)]).abs() < 1e-10);
                }
                assert!(jt_n.view((c + 1, c), (n - c - 1, 1)).amax() < 1e-10);
            }
        }
    }

    #[test]
    fn sparse_row_products_are_the_dense_ones_to_the_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for n in [5, 8, 13, 29] {
            let p = random_qp(&mut rng, n, 6);
            let problem = p.problem();
            let cons = Constraints::new(&problem);
            let dense = DMatrix::from(&p.a);
            let v = DVector::from_fn(n, |_, _| rng.random_range(-1e3..1e3));
            let j = DMatrix::from_fn(n, n, |_, _| rng.random_range(-1.0..1.0));
            // One scratch for all products, as in the equality phase: what a product leaves
            // in it must not reach the next one.
            let mut scratch = Vec::new();
            for i in 0..6 {
                let row = dense.row(i).transpose();
                assert_eq!(cons.row_dot(i, &v), row.dot(&v));
                assert_eq!(cons.jt_times_row(i, &j), j.tr_mul(&row));
                // Upper triangular J: the leading columns skipped, the same numbers (bits:
                // the signs of zeros included).
                let upper = j.upper_triangle();
                for id in [2 * n + i, 2 * n + 6 + i, i % n, n + i % n] {
                    let bits = |v: DVector<f64>| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    let from_transpose = cons.upper_jt_times_normal_from_transpose(
                        id,
                        &upper.transpose(),
                        &mut scratch,
                    );
                    assert_eq!(bits(from_transpose), bits(cons.jt_times_normal(id, &upper)));
                }
            }
        }
    }
}
