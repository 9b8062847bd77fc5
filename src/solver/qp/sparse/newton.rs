//! The interior-point Newton system, its factorization, and convexification.
//!
//! ```text
//!     [ H + δ_c I + Σ_d    Aᵀ   ] [Δd]   [ρ_d]        Σ_d = Z_l T_l⁻¹ + Z_u T_u⁻¹   (bounds on d)
//!     [ A                 −D_y  ] [Δy] = [ρ_y]        D_y = Σ_s⁻¹ (inequality rows), 0 (equalities)
//! ```
//! Fixed variables get an identity row (Δd_j = 0) and free rows an identity (−1) row (Δy_i = 0),
//! so the pattern — and hence the symbolic analysis — depends only on the sparsity of H and A.
//! The pattern is cached across calls: the SQP's QPs share it, so the AMD ordering and the
//! elimination tree are computed once per solve of the NLP.
//!
//! Low-rank Hessians `H = δI − W M Wᵀ` use Sherman–Morrison–Woodbury on top of the sparse
//! factorization of the quasi-definite K₀ (H replaced by δI), with U = [W; 0]:
//! ```text
//!     (K₀ − U M Uᵀ)⁻¹ = K₀⁻¹ + V (I − M Uᵀ V)⁻¹ M Uᵀ K₀⁻¹,    V = K₀⁻¹ U   (p solves)
//! ```
//! followed by iterative refinement against the full operator. This keeps K₀'s pattern that of
//! a diagonal Hessian (cheap, quasi-definite, no n×n matrix) at the price of p extra solves per
//! factorization.
//!
//! Convexification (IPOPT §3.1 inertia correction, Wächter & Biegler 2006): for sparse and
//! dense H, δ_c ∈ {0, δ₀, κδ₀, κ²δ₀, …} (δ₀, κ chosen by the caller) is raised until `[H + δ_c I, A_Eᵀ; A_E, −εI]` (equality rows
//! only; inequality and free rows replaced by −1) has inertia (n, m), i.e. H + δ_c I is positive
//! definite on the null space of the equality constraints, which makes the QP convex. For the
//! low-rank form δ_c is computed in closed form from the p×p eigenproblem of `R M Rᵀ`
//! (WᵀW = RᵀR), making H + δ_c I positive definite.

use nalgebra::DMatrix;

use super::convexification::{Convexification, negative_diagonal_flip};
use super::layout::{Layout, RowKind};
use super::operators::dot;
use crate::solver::kkt::{Inertia, KktError, KktSolver, Regularization};
use crate::solver::qp::{QpHessian, QpProblem};

/// Dual regularization δ_d (relative to the equilibrated matrix) of the inertia test when H is
/// given explicitly (sparse or dense), and of the Newton solves once the default 1e-9 proved
/// unstable. H may be indefinite, and then the unpivoted LDLᵀ is stable only if the dual pivots
/// dominate. Eliminating a row with pivot −δ_d adds `aᵢaᵢᵀ/δ_d` to the primal block, so the
/// factored matrix is congruent to `[H + AᵀA/δ_d, 0; 0, −δ_d I]` (Sylvester): its inertia is
/// (n, m) only if H is positive definite on the null space of A (Debreu's lemma), a sound test
/// whatever the elimination order. With 1e-9 the `1/δ_d` terms swamp H in rounding: a double
/// bubble KKT matrix whose reduced Hessian is positive definite (smallest eigenvalue 1e-6 of
/// the largest) reported 27 extra negative pivots and refinement diverged, so every QP was
/// convexified by a shift making H itself definite. 1e-5 gave the right inertia and converged
/// in ≤ 3 refinement steps (1e-7 needed 10). The Newton solves keep 1e-9 while it is accurate:
/// with dependent equality rows (gait collocation) the larger δ_d selects another solution
/// that refinement cannot remove, and the SQP took other steps.
const STRONG_DUAL_REGULARIZATION: f64 = 1e-5;

/// Relative residual `‖b − Kx‖∞ / (1 + ‖b‖∞)` above which a refined Newton solve counts as
/// unstable and is repeated with [`STRONG_DUAL_REGULARIZATION`].
const UNSTABLE_RESIDUAL: f64 = 1e-8;

/// Refinement steps allowed per KKT solve.
const REFINEMENT_STEPS: usize = 4;
/// Relative residual at which refinement stops.
const REFINEMENT_TOL: f64 = 1e-14;

/// The sparsity that determines the KKT pattern.
#[derive(Debug, PartialEq)]
enum HessianPattern {
    Sparse {
        offsets: Vec<usize>,
        rows: Vec<usize>,
    },
    Dense,
    LowRank,
}

/// The Newton system of one pattern, with its factorization and scatter maps.
pub struct NewtonSystem {
    n: usize,
    m: usize,
    hessian: HessianPattern,
    a_offsets: Vec<usize>,
    a_cols: Vec<usize>,
    kkt: KktSolver,
    /// KKT value position of each stored H entry (SparseLower nnz order, or the dense lower
    /// triangle column by column).
    h_pos: Vec<usize>,
    /// KKT value position of each A entry (CSR order).
    a_pos: Vec<usize>,
    /// Low-rank correction: U = [W; 0] with fixed rows zeroed (its n leading rows, n × p
    /// column-major), V = K₀⁻¹U column-major (dim × p), and the LU of I − M UᵀV.
    u: Vec<f64>,
    v: Vec<f64>,
    capacitance: Option<nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>>,
    /// Scratch of length dim and 2p.
    work: Vec<f64>,
    work_rhs: Vec<f64>,
    small: Vec<f64>,
    /// The Newton solves use [`STRONG_DUAL_REGULARIZATION`] (set once the default was unstable;
    /// kept for the later QPs of the same pattern).
    strong_dual: bool,
    /// The Newton solves of the current QP use [`STRONG_DUAL_REGULARIZATION`] from the start:
    /// set for a QP whose Newton matrix is the matrix of its successful inertia test (no
    /// complementarity pairs), so that the test's factors serve every step.
    pub strong_step: bool,
    /// The current factors were computed with [`STRONG_DUAL_REGULARIZATION`].
    factored_strong: bool,
}

impl NewtonSystem {
    /// Analyses the pattern of `qp` (symbolic factorization).
    pub fn new(qp: &QpProblem<'_>) -> Result<Self, KktError> {
        let (n, m) = (qp.g.len(), qp.a.nrows());
        let (mut rows, mut cols) = (Vec::new(), Vec::new());
        let hessian = match qp.h {
            QpHessian::SparseLower(lower) => {
                for (r, c, _) in lower.triplet_iter() {
                    rows.push(r.max(c));
                    cols.push(r.min(c));
                }
                HessianPattern::Sparse {
                    offsets: lower.col_offsets().to_vec(),
                    rows: lower.row_indices().to_vec(),
                }
            }
            QpHessian::Dense(_) => {
                for c in 0..n {
                    for r in c..n {
                        rows.push(r);
                        cols.push(c);
                    }
                }
                HessianPattern::Dense
            }
            QpHessian::LowRank { .. } => HessianPattern::LowRank,
        };
        let h_count = rows.len();
        let (offsets, a_cols, _) = qp.a.csr_data();
        for i in 0..m {
            for &c in &a_cols[offsets[i]..offsets[i + 1]] {
                rows.push(n + i);
                cols.push(c);
            }
        }
        let (kkt, mut positions) = KktSolver::from_lower_triplets(n, m, &rows, &cols)?;
        let a_pos = positions.split_off(h_count);
        let p = low_rank_width(qp);
        Ok(NewtonSystem {
            n,
            m,
            hessian,
            a_offsets: offsets.to_vec(),
            a_cols: a_cols.to_vec(),
            h_pos: positions,
            a_pos,
            u: vec![0.0; n * p],
            v: vec![0.0; (n + m) * p],
            capacitance: None,
            work: vec![0.0; n + m],
            work_rhs: vec![0.0; n + m],
            small: vec![0.0; 2 * p],
            kkt,
            strong_dual: false,
            strong_step: false,
            factored_strong: false,
        })
    }

    /// True when `qp` has this system's pattern (so the symbolic analysis can be reused).
    pub fn matches(&self, qp: &QpProblem<'_>) -> bool {
        let (offsets, cols, _) = qp.a.csr_data();
        let same_h = match (&self.hessian, qp.h) {
            (HessianPattern::Sparse { offsets, rows }, QpHessian::SparseLower(lower)) => {
                offsets == lower.col_offsets() && rows == lower.row_indices()
            }
            (HessianPattern::Dense, QpHessian::Dense(_)) => true,
            (HessianPattern::LowRank, QpHessian::LowRank { .. }) => {
                self.v.len() == (self.n + self.m) * low_rank_width(qp)
            }
            _ => false,
        };
        same_h
            && self.n == qp.g.len()
            && self.m == qp.a.nrows()
            && self.a_offsets == offsets
            && self.a_cols == cols
    }

    /// Returns the system to the state [`NewtonSystem::new`] left it in (pattern, positions and
    /// buffers kept): no factors, the default dual regularization of the Newton solves.
    pub fn reset(&mut self) {
        self.kkt.forget_factorizations();
        self.capacitance = None;
        self.strong_dual = false;
        self.strong_step = false;
        self.factored_strong = false;
    }

    /// Entries of the KKT factor L.
    pub fn factor_nnz(&self) -> usize {
        self.kkt.factor_nnz()
    }

    /// Dimension n + m.
    pub fn dim(&self) -> usize {
        self.n + self.m
    }

    /// Writes the KKT values: `H + diag(primal_shift)` on non-fixed variables (identity rows
    /// for fixed ones), A on rows with `include_row[i]` (zero otherwise), `dual_diag` on the
    /// dual diagonal. For the low-rank form only `δ I + diag(primal_shift)` enters.
    pub fn assemble(
        &mut self,
        qp: &QpProblem<'_>,
        layout: &Layout,
        primal_shift: &[f64],
        include_row: impl Fn(usize) -> bool,
        dual_diag: &[f64],
    ) {
        let n = self.n;
        let values = self.kkt.values_mut();
        values.fill(0.0);
        match qp.h {
            QpHessian::SparseLower(lower) => {
                for (k, (r, c, v)) in lower.triplet_iter().enumerate() {
                    if !layout.fixed[r] && !layout.fixed[c] {
                        values[self.h_pos[k]] += *v;
                    }
                }
            }
            QpHessian::Dense(dense) => {
                let mut k = 0;
                for c in 0..n {
                    for r in c..n {
                        if !layout.fixed[r] && !layout.fixed[c] {
                            values[self.h_pos[k]] += dense[(r, c)];
                        }
                        k += 1;
                    }
                }
            }
            QpHessian::LowRank { .. } => {}
        }
        let base = match qp.h {
            QpHessian::LowRank { delta, .. } => delta,
            _ => 0.0,
        };
        for (j, shift) in primal_shift.iter().enumerate().take(n) {
            let p = self.kkt.diagonal_position(j);
            let values = self.kkt.values_mut();
            if layout.fixed[j] {
                values[p] = 1.0;
            } else {
                values[p] += base + shift;
            }
        }
        let (offsets, cols, a_values) = qp.a.csr_data();
        let values = self.kkt.values_mut();
        for i in 0..self.m {
            if include_row(i) && layout.row[i] != RowKind::Free {
                for k in offsets[i]..offsets[i + 1] {
                    if !layout.fixed[cols[k]] {
                        values[self.a_pos[k]] = a_values[k];
                    }
                }
            }
        }
        for (i, &value) in dual_diag.iter().enumerate().take(self.m) {
            let p = self.kkt.diagonal_position(n + i);
            self.kkt.values_mut()[p] = value;
        }
    }

    /// Numeric factorizations performed since creation (a refactorization of the values
    /// already factored is not one: [`KktSolver::factor`] keeps the factors).
    pub fn factorizations(&self) -> usize {
        self.kkt.numeric_factorizations()
    }

    /// Factors the assembled K₀ and, for a low-rank Hessian, prepares the Woodbury correction.
    pub fn factor(&mut self, qp: &QpProblem<'_>, layout: &Layout) -> Result<Inertia, KktError> {
        let strong = self.strong_dual || self.strong_step;
        self.factor_with(qp, layout, strong)
    }

    /// [`NewtonSystem::factor`] with the dual regularization chosen: `strong` takes
    /// [`STRONG_DUAL_REGULARIZATION`] for an explicit H.
    fn factor_with(
        &mut self,
        qp: &QpProblem<'_>,
        layout: &Layout,
        strong: bool,
    ) -> Result<Inertia, KktError> {
        self.factored_strong = strong;
        // K₀ of the low-rank form is equilibrated too: without it the chain's QPs (Schur
        // complement eigenvalues below the absolute dual regularization) were reported
        // infeasible and L-BFGS stalled on the sparse path.
        let inertia = self.kkt.factor(regularization(qp, strong))?;
        if let QpHessian::LowRank { w, m, .. } = qp.h {
            let (n, dim, p) = (self.n, self.dim(), w.ncols());
            // U = W with the rows of fixed variables zeroed, then V = K₀⁻¹U in one
            // multi-column solve; its error is removed by the refinement in `solve`.
            for k in 0..p {
                let u_column = &mut self.u[k * n..(k + 1) * n];
                u_column.copy_from_slice(w.column(k).as_slice());
                for (u, &fixed) in u_column.iter_mut().zip(&layout.fixed) {
                    if fixed {
                        *u = 0.0;
                    }
                }
                let v_column = &mut self.v[k * dim..(k + 1) * dim];
                v_column[..n].copy_from_slice(u_column);
                v_column[n..].fill(0.0);
            }
            self.kkt.solve_factored_columns(&mut self.v, p);
            // C = I − M (Uᵀ V), p×p, with a blocked matrix product over the n primal rows.
            let u = nalgebra::DMatrixView::from_slice(&self.u, n, p);
            let v_primal = nalgebra::DMatrixView::from_slice_with_strides(&self.v, n, p, 1, dim);
            let utv = u.transpose() * v_primal;
            let capacitance = DMatrix::identity(p, p) - m * utv;
            self.capacitance = Some(capacitance.lu());
        }
        Ok(inertia)
    }

    /// Solves the Newton system in place (`rhs` of length n + m).
    pub fn solve(&mut self, qp: &QpProblem<'_>, rhs: &mut [f64]) -> Result<(), KktError> {
        if !matches!(qp.h, QpHessian::LowRank { .. }) {
            let b_norm = rhs.iter().fold(0.0f64, |a, x| a.max(x.abs()));
            self.work_rhs.copy_from_slice(rhs);
            let report = self
                .kkt
                .solve_refined(rhs, REFINEMENT_STEPS, REFINEMENT_TOL)?;
            if !self.factored_strong && report.residual > UNSTABLE_RESIDUAL * (1.0 + b_norm) {
                // The factors of the same values with the dominant dual pivots.
                self.strong_dual = true;
                self.factored_strong = true;
                self.kkt.factor(regularization(qp, true))?;
                rhs.copy_from_slice(&self.work_rhs);
                self.kkt
                    .solve_refined(rhs, REFINEMENT_STEPS, REFINEMENT_TOL)?;
            }
            return Ok(());
        }
        let mut b = std::mem::take(&mut self.work_rhs);
        let mut r = std::mem::take(&mut self.work);
        b.copy_from_slice(rhs);
        self.apply_inverse(qp, rhs)?;
        let b_norm = b.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        for _ in 0..REFINEMENT_STEPS {
            let norm = self.full_residual(qp, &b, rhs, &mut r);
            if norm <= REFINEMENT_TOL * (1.0 + b_norm) {
                break;
            }
            self.apply_inverse(qp, &mut r)?;
            for (x, dx) in rhs.iter_mut().zip(&r) {
                *x += dx;
            }
        }
        self.work_rhs = b;
        self.work = r;
        Ok(())
    }

    /// `x ← (K₀ − U M Uᵀ)⁻¹ x` by Woodbury, with the factors of K₀ only (the caller refines
    /// against the full operator).
    fn apply_inverse(&mut self, qp: &QpProblem<'_>, x: &mut [f64]) -> Result<(), KktError> {
        self.kkt.solve_factored(x);
        let QpHessian::LowRank { m, .. } = qp.h else {
            return Ok(());
        };
        let (n, dim) = (self.n, self.dim());
        let p = m.nrows();
        if p == 0 {
            // An empty update (L-BFGS before its first pair): H = δI, nothing to correct.
            return Ok(());
        }
        let (utx, rhs) = self.small.split_at_mut(p);
        for (k, slot) in utx.iter_mut().enumerate() {
            *slot = dot(&self.u[k * n..(k + 1) * n], &x[..n]);
        }
        for (a, slot) in rhs.iter_mut().enumerate() {
            *slot = (0..p).map(|b| m[(a, b)] * utx[b]).sum();
        }
        let capacitance = self.capacitance.as_ref().ok_or(KktError::NotFactored)?;
        let q = capacitance
            .solve(&nalgebra::DVector::from_column_slice(rhs))
            .ok_or(KktError::Breakdown(dim))?;
        for (k, qk) in q.iter().enumerate() {
            let column = &self.v[k * dim..(k + 1) * dim];
            for (xi, vi) in x.iter_mut().zip(column) {
                *xi += qk * vi;
            }
        }
        Ok(())
    }

    /// `r ← b − (K₀ − U M Uᵀ) x`, returning ‖r‖∞.
    fn full_residual(&mut self, qp: &QpProblem<'_>, b: &[f64], x: &[f64], r: &mut [f64]) -> f64 {
        self.kkt.multiply(x, r);
        if let QpHessian::LowRank { m, .. } = qp.h {
            let n = self.n;
            let p = m.nrows();
            let (utx, mutx) = self.small.split_at_mut(p);
            for (k, slot) in utx.iter_mut().enumerate() {
                *slot = dot(&self.u[k * n..(k + 1) * n], &x[..n]);
            }
            for (a, slot) in mutx.iter_mut().enumerate() {
                *slot = (0..p).map(|c| m[(a, c)] * utx[c]).sum();
            }
            for (k, coefficient) in mutx.iter().enumerate() {
                for (ri, ui) in r[..n].iter_mut().zip(&self.u[k * n..(k + 1) * n]) {
                    *ri -= coefficient * ui;
                }
            }
        }
        let mut norm = 0.0f64;
        for (ri, bi) in r.iter_mut().zip(b) {
            *ri = bi - *ri;
            norm = norm.max(ri.abs());
        }
        norm
    }

    /// Finds the convexification (see the module header): trials `floor` (absolute, usually 0)
    /// on H alone; then, when H has negative diagonal entries, the same shift with them flipped
    /// (`convexification.rs`); then `first_shift` relative to `max(1, maxⱼ|Hⱼⱼ|)` (or `floor`
    /// when larger) growing by `growth`, with the flip. `scratch_n` and `scratch_m` are
    /// length-n and length-m buffers. `None` when no shift up to 1e20 works.
    #[allow(clippy::too_many_arguments)]
    pub fn convexify(
        &mut self,
        qp: &QpProblem<'_>,
        layout: &Layout,
        floor: f64,
        first_shift: f64,
        growth: f64,
        scratch_n: &mut [f64],
        scratch_m: &mut [f64],
    ) -> Result<Option<Convexification>, KktError> {
        if let QpHessian::LowRank { delta, w, m } = qp.h {
            return Ok(Some(Convexification::uniform(low_rank_shift(delta, w, m))));
        }
        let diag_scale = (0..self.n)
            .map(|j| self.diagonal_of_h(qp, j).abs())
            .fold(1.0f64, f64::max);
        let mut trial = Convexification::uniform(floor.max(0.0));
        let mut flip_tried = false;
        while trial.shift <= 1e20 * diag_scale {
            if self.passes(qp, layout, &trial, scratch_n, scratch_m)? {
                return Ok(Some(trial));
            }
            if !flip_tried {
                flip_tried = true;
                trial.flip = negative_diagonal_flip(
                    (0..self.n).map(|j| self.diagonal_of_h(qp, j)),
                    &layout.fixed,
                );
                if !trial.flip.is_empty() {
                    continue;
                }
            }
            trial.shift = if trial.shift == 0.0 {
                first_shift * diag_scale
            } else {
                (growth * trial.shift).max(first_shift * diag_scale)
            };
        }
        Ok(None)
    }

    /// Whether `H + E` (E the diagonal of `trial`) is positive definite on the null space of the
    /// equality rows: the inertia test of [`Self::convexify`], one factorization.
    pub fn passes(
        &mut self,
        qp: &QpProblem<'_>,
        layout: &Layout,
        trial: &Convexification,
        scratch_n: &mut [f64],
        scratch_m: &mut [f64],
    ) -> Result<bool, KktError> {
        for (i, slot) in scratch_m.iter_mut().enumerate() {
            *slot = if layout.row[i] == RowKind::Equality {
                0.0
            } else {
                -1.0
            };
        }
        for (j, slot) in scratch_n.iter_mut().enumerate() {
            *slot = trial.added(j);
        }
        self.assemble(
            qp,
            layout,
            scratch_n,
            |i| layout.row[i] == RowKind::Equality,
            scratch_m,
        );
        let inertia = self.factor_with(qp, layout, true)?;
        Ok(inertia.is_quasi_definite_like(self.n, self.m))
    }

    /// H_jj for the sparse and dense forms (used to scale the first convexification shift).
    fn diagonal_of_h(&self, qp: &QpProblem<'_>, j: usize) -> f64 {
        match qp.h {
            QpHessian::Dense(dense) => dense[(j, j)],
            QpHessian::SparseLower(lower) => {
                lower.get_entry(j, j).map(|e| e.into_value()).unwrap_or(0.0)
            }
            QpHessian::LowRank { delta, .. } => delta,
        }
    }
}

/// The static regularization of a factorization of K₀; `strong` takes
/// [`STRONG_DUAL_REGULARIZATION`] for an explicit H.
fn regularization(qp: &QpProblem<'_>, strong: bool) -> Regularization {
    // The low-rank form's K₀ has the diagonal δI + Σ as its Hessian block: its inertia is
    // known, so it keeps the default dual regularization.
    let low_rank = matches!(qp.h, QpHessian::LowRank { .. });
    Regularization {
        dual: if strong && !low_rank {
            STRONG_DUAL_REGULARIZATION
        } else {
            Regularization::default().dual
        },
        ..Regularization::default()
    }
}

/// Columns of W, or 0 for the other forms.
fn low_rank_width(qp: &QpProblem<'_>) -> usize {
    match qp.h {
        QpHessian::LowRank { w, .. } => w.ncols(),
        _ => 0,
    }
}

/// The smallest shift making `δI − W M Wᵀ + shift·I` positive definite (with a relative
/// margin of 1e-8): the eigenvalues of W M Wᵀ are those of R M Rᵀ where WᵀW = RᵀR.
fn low_rank_shift(delta: f64, w: &DMatrix<f64>, m: &DMatrix<f64>) -> f64 {
    if w.ncols() == 0 {
        return if delta > 0.0 { 0.0 } else { 1e-8 - delta };
    }
    let gram = w.transpose() * w;
    let eig = gram.symmetric_eigen();
    let sqrt_lambda = eig.eigenvalues.map(|l| l.max(0.0).sqrt());
    let r = DMatrix::from_diagonal(&sqrt_lambda) * eig.eigenvectors.transpose();
    let sym_m = (m + m.transpose()) * 0.5;
    let inner = &r * sym_m * r.transpose();
    let largest = inner.symmetric_eigenvalues().max();
    let needed = largest.max(0.0) - delta;
    if needed < 0.0 {
        0.0
    } else {
        needed + 1e-8 * largest.abs().max(delta.abs()).max(1.0)
    }
}
