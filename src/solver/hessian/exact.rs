//! Exact Lagrangian Hessians: assembly from the problem's lower-triangle triplets, and the
//! inertia-correcting shift `H + δI` for the dense QP (which needs H ≻ 0).
//!
//! δ schedule (Wächter & Biegler 2006, §3.1, "IPOPT"): try δ = 0; else start from
//! `max(δ_min, κ⁻·δ_last)` (κ⁻ = 1/3), or δ₀ when no shift was needed before, and grow by
//! κ⁺ = 8 (κ̄⁺ = 100 the first time) until the Cholesky factorization succeeds. Unlike in an
//! interior-point method no barrier term adds curvature here, so at a solve's first iteration
//! δ₀ = 1 (the identity that quasi-Newton methods start from, on the scaled problem): a
//! singular Hessian (a linear objective at the starting multipliers) must not produce steps of
//! length ‖g‖/δ₀. Later, when the Hessian carries the constraints' curvature at estimated
//! multipliers, a first shift starts from IPOPT's δ₀ = 1e-4 ([`DELTA_0_LATER`]); and after an
//! iteration that needed a shift, δ_min is tried before `κ⁻·δ_last`. The need for a shift often
//! ends at once (a member of a truss whose force reaches zero leaves its joint a direction of
//! zero curvature, which any positive pivot covers), where κ⁻ alone takes the shift down a
//! third per iteration: warren_deck_linear spent 15 iterations of one round shrinking a shift
//! of 1 to 7e-8 with steps of 1e-5–6e-3. Measured (2026-11-28, all 18 truss files, the
//! Hock–Schittkowski set): warren_deck_linear 96 → 66 iterations, roof_scissors 67 → 41,
//! roof_fink 86 → 66, roof_warren 103 → 92, crane_derrick 1,317 → 1,386, every mass the same
//! to six digits; HS set with exact Hessians 688 → 686 iterations, the same problems solved.
//! δ₀ = 1e-4 at the first iteration as well left HS116 (linear objective) Stalled.
//! Shifts are relative to `max(1, maxᵢ|Hᵢᵢ|)`, and a factorization counts as successful only
//! when every pivot exceeds 1e-10 of that scale, so a singular H is never passed on.
//!
//! Before shifting, the augmented-Lagrangian term `γ AᵀA` over the rows expected active
//! (equalities and the previous QP's active inequalities) is tried (Debreu's lemma: if H is
//! positive definite on the null space of A, `H + γAᵀA ≻ 0` for γ large enough). On the QP's
//! feasible set `‖A d‖²` is constant for those rows, so when they stay active the QP step is
//! the one of the unmodified H and the fast local convergence of the exact Hessian is kept.
//! (The SQP first decouples the variables held at a bound, see `held`, so that this test
//! concerns the free variables only, as the second-order conditions do.) When no γ succeeds,
//! the shift δI is added to `H + γA_EᵀA_E` over the equality rows E with γ = [`FALLBACK_GAMMA`]
//! (relative): as γ → ∞ this is IPOPT's inertia correction of the KKT matrix with those rows,
//! so δ corrects the reduced Hessian only, where a shift of H alone must also overcome the
//! indefiniteness across the rows (truss: reduced eigenvalues ≥ −0.8 against a shift of ~6e3
//! for H alone, at a Hessian scale of 6e3). γ must be large: the indefiniteness across the
//! rows leaks through the term as −(coupling)²/(γ·σ²), σ the rows' singular values, and a
//! truss's balance rows are ill-conditioned (σ_min below 1e-3 of σ_max): with γ = 1e2 a roof
//! truss needed shifts of 0.3–0.6 × the Hessian scale where its reduced Hessian needed 7e-3
//! (steps of 1e-4 for thousands of iterations); γ = 1e4 (the largest of `GAMMAS`) cut that
//! 20-fold. 1e6 came within 2% of the reduced shift on the truss, but two octahedral films
//! (golden `cmc_octahedron_square_short`, `_hexagon_short`) then ended Infeasible / Stalled
//! instead of Optimal. Inequality rows are left out of that base: an inequality the QP should
//! leave would be held by the γ term (with them HS108 ends at another KKT point).
//!
//! A solve that is to converge on its model (no creep watch: `Options::progress_window` = 0)
//! then tries γ = [`PROJECTED_GAMMA`] on H alone, before the negative diagonal entries are
//! flipped (below): the flip changes H on the rows' null space even where the reduced Hessian
//! is positive definite and only the coupling across the rows needs a weight above 1e4, and the
//! steps are then a fraction of Newton's (linear convergence). Measured (2026-11-28, one
//! thread): a generated cantilever with a pier (`benches/peers/layout_variants.py`, pier_2),
//! whose last round crept 187 iterations at a mass constant to nine digits, 416 → 244
//! iterations in all at the same mass; crane_derrick 949 → 864; the other 17 shipped truss
//! files, the other 11 generated layouts and all 22 cmc files unchanged; Hock–Schittkowski
//! with the exact Hessian HS9 6 → 1 and 5 → 4, HS116 36 → 26 and 32 → 27 iterations, the same
//! optima. When γ alone fails there, a reduced Hessian that is only semidefinite is given δ_min
//! on the rows' null space, still unflipped, before the flip: the shipped pier cantilever on a
//! 1 m lattice (`spacing = 1.0`), whose last round crept 698 iterations (its optimality ×0.987
//! per full step) and now takes 89: 1,676 → 1,067 in all, the same mass (489.152473 kg); the
//! 39 truss files of the notes the same iterates, the Hock–Schittkowski set passing unchanged
//! (2026-11-29). Then the shift on that null space grows from δ_min by κ⁺ = 8 as long as it is
//! no larger than the flip's largest diagonal correction (relative), still unflipped: of the
//! two corrections the smaller one. The flip adds 2|Hᵢᵢ| to whole diagonal entries, and along a
//! mild negative curvature that overstates the model: the 1 m pier's settle round crawled 680
//! full steps of ~1e-3 m while beams collapsed, its reduced Hessian's one negative eigenvalue
//! (−0.016 to −0.1 at a scale of 734) flipped, the merit falling faster than the model said.
//! Measured (2026-11-29, `optimize truss F -q --threads 1`): that pier 1,041 → 471 iterations
//! (3.73 → 1.99 s), crane_derrick 805 → 563, crane_tripod seeds 12 and 17 1,352 → 1,305 and
//! 1,726 → 1,219, all at the same masses; the Warren deck at 1 m 130 → 135, the pier at 0.5 m
//! 1,301 → 1,294, vdeck_0 220 → 208, vpier_0 135 → 139; crane_tripod seed 4 stays Stalled,
//! 368.85 → 372.22 kg; the other 36 truss files and the 22 cmc files the same iterates, the
//! Hock–Schittkowski set passing. After a failed probe (below) these trials are skipped with
//! the others, although the unflipped shifts are not all below it in the Loewner order (the
//! measured behaviour; the schedule then goes on, on the flipped Hessian). Solves watched for
//! creep (truss rounds that a clean-up follows) keep the flip first: there the trial sent three
//! generated decks to KKT points 0.5–0.7 % heavier (deck_3 1,984.9 → 1,999.1 kg), which the
//! clean-up does not leave.
//!
//! When no γ alone succeeds, the shift is first confined to the null space of all those rows
//! (equalities and expected-active inequalities): `H + δ(I − QQᵀ) + γ·Σₖuₖuₖᵀ`, Q an
//! orthonormal basis of the span of the independent rows (Gram–Schmidt with
//! reorthogonalization, O(n·k·r) per iteration; dependent rows are left out of Q and of the γ
//! term), with the same δ schedule and γ up to [`PROJECTED_GAMMA`]. On the QP's feasible set of
//! those rows the QP step is then the Newton step of the reduced Hessian shifted by δ, and no step
//! across an active row is shortened. A shift of H alone (or of the reduced Hessian over the
//! equalities only) also damps the directions the active inequalities block, every iteration:
//! HS114 (variables from 1.5 to 16,000, a bilinear objective) crawled to its iteration limit
//! with shifts of 0.05–0.7 and steps of 0.01–0.3 where x₂ must move 3,800; with the projected
//! shift it ends Optimal in 18 iterations. Tried and not kept (docs/notes/solver.md): a
//! diagonal metric `Dⱼ = |Hⱼⱼ| + Σᵢ Aᵢⱼ²` for the shift (unit-invariant, but HS114 took 274
//! iterations and a catenoid film 70× longer), and flipping only the negative eigenvalues of
//! the reduced Hessian (HS114 in 11 iterations, but near-zero tangential curvature of mesh
//! vertices left undamped: catenoid 4× slower, its steps cut by the line search).
//! Only when no projected shift works does the fallback below run.
//!
//! Trials skipped by the Loewner order: a matrix that is larger in the Loewner order has larger
//! Cholesky pivots, so when a trial fails, every smaller one fails too. After an iteration that
//! took a shift of the schedule, the schedule's first trial (δ_min with γ = [`PROJECTED_GAMMA`],
//! on the flipped H) is made before the others; every trial the sequence above makes before it
//! is smaller (no flip, no shift or the same δ_min, a γ no larger), so when it fails they are
//! skipped and the schedule goes on from its second δ; so are a converging solve's unflipped
//! shifts above δ_min, which are not all smaller (above). Apart from those the factorizations
//! kept are the same numbers as without the probe. Measured (pier_cantilever_linear,
//! callgrind): 245 → 199 trial factorizations per run, 625 → 615 M instructions; all 39 truss
//! files of the notes the same iterates.
//!
//! Damping floor: the SQP passes a floor δ_f (absolute) that it raises after a Newton step its
//! line search had to cut severely and lowers after full steps (`Sqp::damp_exact_steps`,
//! shared with the sparse path); it is added on the same null space, `H + δ_f(I − QQᵀ)`,
//! before the tests above. Without it, HS114 took 63 iterations with 40 steps cut to 2–5 %
//! (full Newton steps of length ~2,000 on a bilinear problem); with it, 18. Its curvature
//! measure leaves out the γ term (γ‖A d‖², of the linearized residual, not of the problem):
//! with it in, roof_warren.toml ended Stalled.
//!
//! Multipliers: the QP with `H + γΣuₖuₖᵀ` returns row multipliers offset by `γ·uₖᵀd/‖aₖ‖`,
//! nonzero where the linearized residual is (see [`Convexified::row_weight`]); the SQP adds
//! them back, or γ ≫ 1 times an infeasibility would enter the next Hessian and the penalty
//! weights.

use nalgebra::{DMatrix, DVector};

use crate::solver::columns::add_scaled_columns;

/// Dense symmetric matrix from lower-triangle triplets (duplicates summed).
pub fn assemble_dense(n: usize, rows: &[usize], cols: &[usize], values: &[f64]) -> DMatrix<f64> {
    let mut h = DMatrix::zeros(n, n);
    for ((&r, &c), &v) in rows.iter().zip(cols).zip(values) {
        h[(r, c)] += v;
        if r != c {
            h[(c, r)] += v;
        }
    }
    h
}

/// A convexified Hessian.
#[derive(Debug, Clone)]
pub struct Convexified {
    /// The positive definite matrix handed to the QP.
    pub matrix: DMatrix<f64>,
    /// Its Cholesky factor L (`matrix = L Lᵀ`) in the lower triangle, the number for number
    /// that nalgebra's `cholesky` gives; the strict upper triangle is not part of it (it holds
    /// `matrix`'s). The definiteness test computes it, so that the dense QP need not factor
    /// `matrix` again.
    pub factor: DMatrix<f64>,
    /// The shift δ, relative to `max(1, maxᵢ|Hᵢᵢ|)` (0 when none was needed).
    pub shift: f64,
    /// The weight γ (absolute) of the term `γ·Σₖ uₖuₖᵀ` over the unit rows `uₖ = aₖ/‖aₖ‖`,
    /// k ∈ `weighted`, that the matrix contains, 0 when none. A QP solved with it
    /// returns row multipliers λ̃ₖ; those of the unmodified H are
    /// `λₖ = λ̃ₖ + γ·aₖᵀd/‖aₖ‖²` (the term's gradient `γ uₖ uₖᵀd` moved to the rows).
    pub row_weight: f64,
    /// The rows (indices into those given) that carry `row_weight`: an independent subset.
    pub weighted: Vec<usize>,
}

/// The remembered inertia-correction shift.
#[derive(Debug, Clone, Default)]
pub struct InertiaShift {
    last: f64,
    /// Whether a Hessian of this solve was convexified before (the first iteration's shift
    /// starts higher, see the module header).
    started: bool,
    /// Whether the solve is to converge on this model (see [`InertiaShift::converging`]).
    converging: bool,
    /// Whether the last convexification took a shift of the δ schedule (the probe of
    /// [`InertiaShift::smallest_shift_passes`] is made after one).
    took_shift: bool,
}

/// First shift of a solve's first iteration (relative; see the module header).
const DELTA_0: f64 = 1.0;
/// First shift at a later iteration when the one before needed none (relative; IPOPT's
/// `first_hessian_perturbation`).
pub const DELTA_0_LATER: f64 = 1e-4;
const DELTA_MIN: f64 = 1e-10;
const DELTA_MAX: f64 = 1e40;
/// Growth of δ after a failed trial once a shift was needed (κ⁺); the first search grows by
/// [`FIRST_SHIFT_GROWTH`] (κ̄⁺).
const SHIFT_GROWTH: f64 = 8.0;
/// Growth of δ in a first search (κ̄⁺).
const FIRST_SHIFT_GROWTH: f64 = 100.0;
/// Relative size of the smallest acceptable Cholesky pivot.
const PIVOT_MIN: f64 = 1e-10;
/// Augmentation weights tried, relative to the Hessian scale over the row scale.
const GAMMAS: [f64; 3] = [1.0, 1e2, 1e4];
/// Largest augmentation weight of the projected shift (relative), tried after [`GAMMAS`]: the
/// shift lifts the null space, so the weight only has to overcome the coupling across the rows
/// (see the module header), which grows as the rows' smallest singular value falls.
const PROJECTED_GAMMA: f64 = 1e6;
/// Augmentation weights of the projected shift, and of a converging solve's first trials
/// (relative): [`GAMMAS`], then [`PROJECTED_GAMMA`] (module header).
const PROJECTED_GAMMAS: [f64; 4] = [GAMMAS[0], GAMMAS[1], GAMMAS[2], PROJECTED_GAMMA];
/// Augmentation weight under the shift when none of `GAMMAS` suffices (relative; see the
/// module header for why it is large, and not larger).
pub const FALLBACK_GAMMA: f64 = 1e4;

/// The rows' independent subset and Q, an orthonormal basis of their span (`rows` k×n, unit or
/// any scaling), from which [`RowBasis::projector`] forms the projector `I − QQᵀ` onto their
/// null space when it is needed. Q by classical Gram–Schmidt
/// with reorthogonalization where the first pass cancelled (CGS2, "twice is enough":
/// orthogonal to working precision like two passes of modified Gram–Schmidt) over the unit
/// rows in order, O(n·k·r); a row within
/// [`RANK_TOLERANCE`] of the span of those before it is left out. (A thin QR of dependent rows
/// returns k columns spanning more than the rows, and leaves part of their null space
/// unshifted.) The basis is held as the rows of a k×n matrix, so that both projections run
/// over contiguous columns, the first one over the row's nonzeros only (a truss balance row
/// has a handful), and `QQᵀ` is one matrix product.
fn independent_rows(rows: &DMatrix<f64>) -> RowBasis {
    let (k, n) = rows.shape();
    let mut basis = DMatrix::<f64>::zeros(k, n);
    let mut kept = Vec::new();
    let mut v = vec![0.0; n];
    let mut c = vec![0.0; k];
    let mut terms = Vec::with_capacity(n);
    let entries = rows.as_slice();
    for index in 0..k {
        // Row `index` (entry i at i·k + index); its norm as nalgebra's of a row view: the
        // squares summed one column after the other.
        let row = (0..n).map(|i| entries[i * k + index]);
        let norm = row.clone().fold(0.0, |sum, x| sum + x * x).sqrt();
        if norm == 0.0 || !norm.is_finite() {
            continue;
        }
        let r = kept.len();
        for (vi, x) in v.iter_mut().zip(row) {
            *vi = x / norm;
        }
        for pass in 0..2 {
            // The second pass only when the first removed more than half of the row's square
            // norm (Daniel, Gragg, Kaufman & Stewart 1976): otherwise the cancellation that
            // loses orthogonality has not happened.
            if pass == 1 && dense_dot(&v, &v) > 0.5 {
                break;
            }
            // Column i of the basis matrix: every basis vector's entry i, the first r in use.
            let q = basis.as_slice();
            let column = |i: usize| &q[i * k..i * k + r];
            let c = &mut c[..r];
            c.fill(0.0);
            // c = Qv: the columns of the nonzero entries of v, four per pass over c.
            terms.clear();
            terms.extend(
                (v.iter().enumerate()).filter_map(|(i, &vi)| (vi != 0.0).then_some((vi, i * k))),
            );
            add_scaled_columns(c, q, &terms);
            for (i, vi) in v.iter_mut().enumerate() {
                *vi -= dense_dot(column(i), c);
            }
        }
        let residual = dense_dot(&v, &v).sqrt();
        if residual > RANK_TOLERANCE {
            for (i, vi) in v.iter().enumerate() {
                basis[(r, i)] = vi / residual;
            }
            kept.push(index);
        }
    }
    RowBasis { kept, basis }
}

/// `aᵀb` for slices of equal length as nalgebra's `dot` of two dynamic vectors computes it (so
/// the same number): eight partial sums over blocks of eight, added to 0 as (s₀ + s₄),
/// (s₁ + s₅), (s₂ + s₆), (s₃ + s₇), then the tail one by one. Its norms are `dense_dot(v, v)`
/// (`norm_squared`, 0 + the dot) and its square root.
#[inline(always)]
fn dense_dot(a: &[f64], b: &[f64]) -> f64 {
    let blocks = a.len() / 8 * 8;
    let mut partial = [0.0; 8];
    for (x, y) in a[..blocks].chunks_exact(8).zip(b[..blocks].chunks_exact(8)) {
        for p in 0..8 {
            partial[p] += x[p] * y[p];
        }
    }
    let mut sum = 0.0;
    for p in 0..4 {
        sum += partial[p] + partial[p + 4];
    }
    for (x, y) in a[blocks..].iter().zip(&b[blocks..]) {
        sum += x * y;
    }
    sum
}

/// `a + s·b` entry by entry (the numbers of nalgebra's `a + b * s`).
fn plus_scaled(a: &DMatrix<f64>, b: &DMatrix<f64>, s: f64) -> DMatrix<f64> {
    let mut sum = a.clone();
    for (x, &y) in sum.as_mut_slice().iter_mut().zip(b.as_slice()) {
        *x += y * s;
    }
    sum
}

/// The independent rows found by [`independent_rows`] and the orthonormal basis of their span.
struct RowBasis {
    /// Indices of the independent rows, in order.
    kept: Vec<usize>,
    /// Q: its first `kept.len()` rows are the basis vectors (the rest is unused).
    basis: DMatrix<f64>,
}

impl RowBasis {
    /// `I − QQᵀ`, the projector onto the rows' null space: one matrix product, formed only
    /// where a shift on the null space is tried (the floor, or the projected shift).
    fn projector(&self) -> DMatrix<f64> {
        let n = self.basis.ncols();
        let q = self.basis.rows(0, self.kept.len());
        let mut projector = DMatrix::identity(n, n);
        projector.gemm(-1.0, &q.transpose(), &q, 1.0);
        projector
    }
}

/// `UᵀU` for the rows U (k×n) over each row's nonzeros only: a truss's balance rows have a
/// handful of n entries, so this is O(Σ nnz²) instead of the dense product's O(k·n²).
fn gram_of(unit: &DMatrix<f64>) -> DMatrix<f64> {
    let n = unit.ncols();
    let mut gram = DMatrix::zeros(n, n);
    let mut nonzeros = Vec::with_capacity(n);
    for row in unit.row_iter() {
        nonzeros.clear();
        nonzeros.extend(
            row.iter()
                .enumerate()
                .filter(|(_, v)| **v != 0.0)
                .map(|(j, &v)| (j, v)),
        );
        for &(j, vj) in &nonzeros {
            let mut column = gram.column_mut(j);
            for &(i, vi) in &nonzeros {
                column[i] += vi * vj;
            }
        }
    }
    gram
}

/// `h` as it is (no shift, no row term), with its Cholesky factor.
fn unmodified(h: &DMatrix<f64>, factor: DMatrix<f64>) -> Convexified {
    Convexified {
        matrix: h.clone(),
        factor,
        shift: 0.0,
        row_weight: 0.0,
        weighted: Vec::new(),
    }
}

/// `h + γ·gram` (gram the unit rows' `UᵀU`) for the first γ of `gammas` (relative to
/// `scale`) that makes it safely positive definite: every pivot above `PIVOT_MIN·scale`, h's
/// own scale as in the projected shift. (A bound relative to the sum's diagonal, which the γ
/// term inflates by up to 1e4, failed reduced Hessians whose smallest eigenvalue lies between
/// the two, 3e-8 of h's scale on a cantilever with a pier: the convexification then fell
/// through to the flipped diagonal, which changes h on the rows' null space, and the last
/// round crept for 385 iterations at a mass constant to nine digits; docs/notes/truss.md.)
fn augmented(
    h: &DMatrix<f64>,
    gram: &DMatrix<f64>,
    kept: &[usize],
    scale: f64,
    gammas: &[f64],
) -> Option<Convexified> {
    if kept.is_empty() {
        return None;
    }
    gammas.iter().find_map(|g| {
        let factor = definite_factor_of_sum(h, Some((gram, g * scale)), scale)?;
        Some(Convexified {
            matrix: plus_scaled(h, gram, g * scale),
            factor,
            shift: 0.0,
            row_weight: g * scale,
            weighted: kept.to_vec(),
        })
    })
}

/// `2·max(0, −Hᵢᵢ)` per variable: the diagonal that turns every negative diagonal entry into
/// its absolute value.
fn negative_diagonal_flip(h: &DMatrix<f64>) -> Vec<f64> {
    h.diagonal().iter().map(|&v| (-2.0 * v).max(0.0)).collect()
}

/// Relative residual below which a unit row counts as dependent on the rows before it.
const RANK_TOLERANCE: f64 = 1e-8;

/// `max(1, maxᵢ|Hᵢᵢ|)`: the scale shifts are relative to.
pub fn scale_of(h: &DMatrix<f64>) -> f64 {
    h.diagonal().iter().fold(1.0_f64, |a, v| a.max(v.abs()))
}

/// The Cholesky factor of `h` if it is positive definite with every squared pivot above
/// `PIVOT_MIN·scale`, else None: a left-looking factorization of a copy (column j of L from the
/// columns before it, over contiguous column slices) that stops at the first pivot below the
/// bound, so a failed trial of the δ or γ schedules costs only the columns up to it. L is in
/// the lower triangle, the strict upper triangle keeps h's entries. The operations are
/// nalgebra's `cholesky` (the same left-looking column updates `c − Lⱼₖ·v`, four k per pass
/// over the column, the same square roots and divisions), so the factor is the same to the
/// bit and the dense QP takes it instead of factoring h again ([`Convexified::factor`]).
fn definite_factor(h: &DMatrix<f64>, scale: f64) -> Option<DMatrix<f64>> {
    definite_factor_of_sum(h, None, scale)
}

/// [`definite_factor`] of `h + s·b` (`extra = (b, s)`, the numbers of [`plus_scaled`]) without
/// forming the sum: each column is formed when the factorization reaches it, so a failed trial
/// of the γ schedule forms only the columns up to its failure.
fn definite_factor_of_sum(
    h: &DMatrix<f64>,
    extra: Option<(&DMatrix<f64>, f64)>,
    scale: f64,
) -> Option<DMatrix<f64>> {
    let n = h.nrows();
    let bound = PIVOT_MIN * scale;
    let entry = |i: usize, j: usize| match extra {
        Some((b, s)) => h[(i, j)] + b[(i, j)] * s,
        None => h[(i, j)],
    };
    // A pivot is its diagonal entry less squares (each subtraction of a square can only lower
    // it, in floating point too): a diagonal entry below the bound fails the factorization.
    if (0..n).any(|i| {
        let d = entry(i, i);
        d.is_nan() || d < bound
    }) {
        return None;
    }
    let mut l = Vec::with_capacity(n * n);
    let mut updates: Vec<(f64, usize)> = Vec::with_capacity(n);
    for j in 0..n {
        l.extend_from_slice(&h.as_slice()[j * n..(j + 1) * n]);
        if let Some((b, s)) = extra {
            for (x, &y) in l[j * n..].iter_mut().zip(&b.as_slice()[j * n..(j + 1) * n]) {
                *x += y * s;
            }
        }
        let (before, rest) = l.split_at_mut(j * n);
        let column = &mut rest[j..n];
        // `c −= Lⱼₖ·L[j.., k]` for every k < j with Lⱼₖ ≠ 0, in order (negation is exact).
        updates.clear();
        updates.extend((0..j).filter_map(|k| {
            let factor = before[k * n + j];
            (factor != 0.0).then_some((-factor, k * n + j))
        }));
        add_scaled_columns(column, before, &updates);
        let pivot = column[0];
        if pivot.is_nan() || pivot < bound {
            return None;
        }
        let root = pivot.sqrt();
        column[0] = root;
        for c in &mut column[1..] {
            *c /= root;
        }
    }
    Some(DMatrix::from_vec(n, n, l))
}

impl InertiaShift {
    /// The shift memory of a solve that is to converge on its model (no creep watch, see
    /// `Options::progress_window`): a reduced Hessian that is positive definite, but coupled
    /// across the rows more strongly than the weights up to 1e4 cover, is kept unmodified with
    /// γ up to 1e6 (relative) before the negative diagonal is flipped (module header).
    pub fn converging() -> Self {
        InertiaShift {
            converging: true,
            ..InertiaShift::default()
        }
    }

    /// `h + δ·(I − QQᵀ) + γ·Σₖ uₖuₖᵀ` with Q an orthonormal basis of the span of the unit rows
    /// uₖ (equalities and expected-active inequalities; `gram` = Σₖ uₖuₖᵀ, `projector` =
    /// I − QQᵀ): the shift of the δ schedule acts
    /// on their null space only, where the second-order conditions ask for positive
    /// curvature, and γ ∈ [`GAMMAS`] or [`PROJECTED_GAMMA`] (relative to `scale`) makes the
    /// whole positive definite across the rows. None when no δ up to `DELTA_MAX` works.
    /// `started`: whether this solve convexified a Hessian before (the schedule's δ₀).
    fn projected_shift(
        &mut self,
        h: &DMatrix<f64>,
        gram: &DMatrix<f64>,
        projector: &DMatrix<f64>,
        scale: f64,
        started: bool,
        skip_smallest: bool,
    ) -> Option<(DMatrix<f64>, DMatrix<f64>, f64, f64)> {
        let ((matrix, factor, weight), delta) = shift_schedule(self.last, started, |delta| {
            if skip_smallest && delta == DELTA_MIN {
                return None;
            }
            projected_trial(h, gram, projector, delta, &PROJECTED_GAMMAS, scale)
        })?;
        self.last = delta;
        Some((matrix, factor, delta, weight))
    }

    /// Last δ used (0 when none was needed).
    pub fn last(&self) -> f64 {
        self.last
    }

    /// `h + δI` with the smallest δ of the schedule that makes it positive definite, or None
    /// when h is not finite.
    pub fn convexify(&mut self, h: &DMatrix<f64>) -> Option<(DMatrix<f64>, f64)> {
        self.convexify_with_rows(h, &DMatrix::zeros(0, h.nrows()), 0, 0.0)
            .map(|c| (c.matrix, c.shift))
    }

    /// As [`InertiaShift::convexify`], trying `h + γ·rowsᵀrows` first (rows k×n normalized),
    /// then the projected shift, and, when neither succeeds, shifting h plus the term of the
    /// first `equalities` rows (the equality rows) with γ = [`FALLBACK_GAMMA`] (see the module
    /// header). `floor` (absolute, ≥ 0) is the SQP's damping of Newton steps its line search
    /// had to cut, added on the rows' null space before any of these, `δ_f(I − QQᵀ)`;
    /// `shift` reports the inertia correction on top of it.
    pub fn convexify_with_rows(
        &mut self,
        h: &DMatrix<f64>,
        rows: &DMatrix<f64>,
        equalities: usize,
        floor: f64,
    ) -> Option<Convexified> {
        if !h.iter().all(|v| v.is_finite()) {
            return None;
        }
        let scale = scale_of(h);
        let started = std::mem::replace(&mut self.started, true);
        // After an iteration that needed a shift, the rows' basis is computed now for the probe
        // below; otherwise for the floor now, or below if h needs correcting.
        let probe = std::mem::replace(&mut self.took_shift, false) && rows.nrows() > 0;
        let basis = (floor > 0.0 || probe).then(|| independent_rows(rows));
        let mut projector = basis.as_ref().map(RowBasis::projector);
        let damped;
        let h = match &projector {
            Some(projector) if floor > 0.0 => {
                damped = plus_scaled(h, projector, floor);
                &damped
            }
            _ => h,
        };
        let weighted = basis.map(|basis| WeightedRows::of(rows, basis, equalities));
        // h with its negative diagonal entries flipped (see `qp::sparse`'s convexification): a
        // separable concavity is corrected on its own variables before any shift damps every
        // step. Tried after the γ term on h alone (below).
        let flip = negative_diagonal_flip(h);
        let flipped = flipped(h, &flip);
        if probe
            && let (Some(weighted), Some(projector)) = (&weighted, &projector)
            && !weighted.basis.kept.is_empty()
        {
            let h = flipped.as_ref().unwrap_or(h);
            if !self.smallest_shift_passes(h, &weighted.gram, projector, scale) {
                // Every trial before the schedule's first shift is below this one in the
                // Loewner order, so it fails too: the schedule starts at its second shift.
                return self.shifted(h, weighted, projector, scale, started, true);
            }
        }
        if let Some(factor) = definite_factor(h, scale) {
            self.last = 0.0;
            return Some(unmodified(h, factor));
        }
        let weighted =
            weighted.unwrap_or_else(|| WeightedRows::of(rows, independent_rows(rows), equalities));
        let gammas: &[f64] = if self.converging {
            &PROJECTED_GAMMAS
        } else {
            &GAMMAS
        };
        let kept = &weighted.basis.kept;
        if let Some(found) = augmented(h, &weighted.gram, kept, scale, gammas) {
            return Some(found);
        }
        if self.converging && !kept.is_empty() {
            // A reduced Hessian that is only semidefinite, or indefinite by less than the flip
            // would add: the smallest shift on the rows' null space, from δ_min up to the flip's
            // largest diagonal correction, before the flip (module header).
            let projector = projector.get_or_insert_with(|| weighted.basis.projector());
            let largest_flip = flip.iter().fold(0.0_f64, |a, &v| a.max(v)) / scale;
            // The schedule as after a shift of δ_min: δ_min, then up by κ⁺ from 8·δ_min.
            let unflipped = shift_schedule(DELTA_MIN, true, |delta| {
                if delta > DELTA_MIN && delta > largest_flip {
                    return None;
                }
                projected_trial(
                    h,
                    &weighted.gram,
                    projector,
                    delta,
                    &PROJECTED_GAMMAS,
                    scale,
                )
            });
            if let Some(((matrix, factor, row_weight), delta)) = unflipped {
                self.last = delta;
                self.took_shift = true;
                return Some(Convexified {
                    matrix,
                    factor,
                    shift: delta,
                    row_weight,
                    weighted: kept.clone(),
                });
            }
        }
        if let Some(flipped) = &flipped {
            if let Some(factor) = definite_factor(flipped, scale) {
                self.last = 0.0;
                return Some(unmodified(flipped, factor));
            }
            if let Some(found) = augmented(flipped, &weighted.gram, kept, scale, &GAMMAS) {
                return Some(found);
            }
        }
        let h = flipped.as_ref().unwrap_or(h);
        let projector = projector.get_or_insert_with(|| weighted.basis.projector());
        self.shifted(h, &weighted, projector, scale, started, false)
    }

    /// Whether the first trial of the projected shift's schedule after an iteration that
    /// needed a shift, `h + δ_min(I − QQᵀ) + γ·Σₖuₖuₖᵀ` with the largest γ
    /// ([`PROJECTED_GAMMA`]), is positive definite: the same numbers as that trial in
    /// [`InertiaShift::projected_shift`]. h is the flipped Hessian the schedule shifts. Every
    /// trial [`InertiaShift::convexify_with_rows`] makes before it is smaller in the Loewner
    /// order (no flip, no shift or the same δ_min, a γ no larger: each difference is positive
    /// semidefinite), except a converging solve's unflipped shifts above δ_min, which a failed
    /// probe skips as well (module header); a smaller matrix has smaller Cholesky pivots (pivot
    /// j is `1/[(A₁..ⱼ)⁻¹]ⱼⱼ`), so when this one fails, the others all fail: on
    /// pier_cantilever_linear, 10–15 trial factorizations of the iterations that needed a
    /// shift, each failing three quarters of the way through, are one.
    fn smallest_shift_passes(
        &self,
        h: &DMatrix<f64>,
        gram: &DMatrix<f64>,
        projector: &DMatrix<f64>,
        scale: f64,
    ) -> bool {
        projected_trial(h, gram, projector, DELTA_MIN, &[PROJECTED_GAMMA], scale).is_some()
    }

    /// The projected shift (h flipped where it had to be), and when none works, the shift of h
    /// plus the equality rows' term ([`FALLBACK_GAMMA`]). `skip_smallest`: the projected
    /// schedule's δ_min is known to fail ([`InertiaShift::smallest_shift_passes`]).
    fn shifted(
        &mut self,
        h: &DMatrix<f64>,
        weighted: &WeightedRows,
        projector: &DMatrix<f64>,
        scale: f64,
        started: bool,
        skip_smallest: bool,
    ) -> Option<Convexified> {
        self.took_shift = true;
        let kept = &weighted.basis.kept;
        let mut base = (h.clone(), 0.0, Vec::new());
        if !kept.is_empty() {
            if let Some((matrix, factor, shift, row_weight)) =
                self.projected_shift(h, &weighted.gram, projector, scale, started, skip_smallest)
            {
                return Some(Convexified {
                    matrix,
                    factor,
                    shift,
                    row_weight,
                    weighted: kept.clone(),
                });
            }
            let equality_rows = weighted.equality_rows;
            if equality_rows > 0 {
                let gram = gram_of(&weighted.unit.rows(0, equality_rows).into_owned());
                base = (
                    h + &gram * (FALLBACK_GAMMA * scale),
                    FALLBACK_GAMMA * scale,
                    kept[..equality_rows].to_vec(),
                );
            }
        }
        let base_scale = scale_of(&base.0);
        let ((matrix, factor), delta) = shift_schedule(self.last, started, |delta| {
            let mut shifted = base.0.clone();
            for i in 0..h.nrows() {
                shifted[(i, i)] += delta * scale;
            }
            let factor = definite_factor(&shifted, base_scale)?;
            Some((shifted, factor))
        })?;
        self.last = delta;
        Some(Convexified {
            matrix,
            factor,
            shift: delta,
            row_weight: base.1,
            weighted: base.2,
        })
    }
}

/// The expected-active rows' independent subset, scaled to unit length so that a short row
/// counts as much as a long one, and their term `Σₖ uₖuₖᵀ`.
struct WeightedRows {
    basis: RowBasis,
    unit: DMatrix<f64>,
    gram: DMatrix<f64>,
    /// How many of the kept rows are equality rows (they come first).
    equality_rows: usize,
}

impl WeightedRows {
    /// `rows`' first `equalities` rows are the equality rows.
    fn of(rows: &DMatrix<f64>, basis: RowBasis, equalities: usize) -> Self {
        let mut unit = rows.select_rows(&basis.kept);
        for mut r in unit.row_iter_mut() {
            r /= r.norm();
        }
        let gram = gram_of(&unit);
        let equality_rows = basis.kept.iter().take_while(|&&k| k < equalities).count();
        WeightedRows {
            basis,
            unit,
            gram,
            equality_rows,
        }
    }
}

/// The first of `h + δ·(I − QQᵀ) + γ·Σₖ uₖuₖᵀ` over `gammas` (relative to `scale`, as δ) that is
/// positive definite (`projector` = I − QQᵀ, `gram` = Σₖ uₖuₖᵀ): the matrix, its Cholesky
/// factor and γ (absolute).
fn projected_trial(
    h: &DMatrix<f64>,
    gram: &DMatrix<f64>,
    projector: &DMatrix<f64>,
    delta: f64,
    gammas: &[f64],
    scale: f64,
) -> Option<(DMatrix<f64>, DMatrix<f64>, f64)> {
    let shifted = plus_scaled(h, projector, delta * scale);
    gammas.iter().find_map(|g| {
        let factor = definite_factor_of_sum(&shifted, Some((gram, g * scale)), scale)?;
        Some((plus_scaled(&shifted, gram, g * scale), factor, g * scale))
    })
}

/// h plus `flip` ([`negative_diagonal_flip`] of h) on its diagonal, None when nothing flips.
fn flipped(h: &DMatrix<f64>, flip: &[f64]) -> Option<DMatrix<f64>> {
    flip.iter()
        .any(|&f| f > 0.0)
        .then(|| h + DMatrix::from_diagonal(&DVector::from_column_slice(flip)))
}

/// The δ schedule (module header): from the remembered shift `last` (or δ₀), growing until
/// `works` accepts one; its result and the δ taken.
fn shift_schedule<T>(
    last: f64,
    started: bool,
    mut works: impl FnMut(f64) -> Option<T>,
) -> Option<(T, f64)> {
    let first = last == 0.0;
    if !first && let Some(found) = works(DELTA_MIN) {
        return Some((found, DELTA_MIN));
    }
    let mut delta = match (first, started) {
        (true, false) => DELTA_0,
        (true, true) => DELTA_0_LATER,
        // δ_min was tried above: the next one up, as the growth below would take.
        (false, _) if last / 3.0 <= DELTA_MIN => SHIFT_GROWTH * DELTA_MIN,
        (false, _) => last / 3.0,
    };
    while delta <= DELTA_MAX {
        if let Some(found) = works(delta) {
            return Some((found, delta));
        }
        delta *= if first {
            FIRST_SHIFT_GROWTH
        } else {
            SHIFT_GROWTH
        };
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_first_shift_starts_lower_after_the_first_iteration() {
        // Eigenvalues ≈ −5e-7 and 2: a small shift suffices.
        let nearly = assemble_dense(2, &[0, 1, 1], &[0, 0, 1], &[1.0, 1.0, 1.0 - 1e-6]);
        let (_, fresh) = InertiaShift::default().convexify(&nearly).unwrap();
        assert_eq!(fresh, DELTA_0);
        let mut shift = InertiaShift::default();
        let (_, none) = shift.convexify(&DMatrix::identity(2, 2)).unwrap();
        assert_eq!(none, 0.0);
        let (m, later) = shift.convexify(&nearly).unwrap();
        assert_eq!(later, DELTA_0_LATER);
        assert!(m.cholesky().is_some());
    }

    #[test]
    fn a_shift_no_longer_needed_drops_to_the_smallest_at_once() {
        let indefinite = assemble_dense(2, &[0, 1, 1], &[0, 0, 1], &[1.0, 1.5, 1.0]);
        let mut shift = InertiaShift::default();
        let (_, first) = shift.convexify(&indefinite).unwrap();
        assert!(first > 0.5);
        // Singular (eigenvalues 0 and 2): any positive pivot covers it, and δ_min is tried
        // before a third of the last shift.
        let singular = assemble_dense(2, &[0, 1, 1], &[0, 0, 1], &[1.0, 1.0, 1.0]);
        let (m, next) = shift.convexify(&singular).unwrap();
        assert_eq!(next, DELTA_MIN);
        assert!(m.cholesky().is_some());
    }

    #[test]
    fn shift_makes_indefinite_matrix_definite_and_is_remembered() {
        // A negative diagonal entry alone is flipped, without a shift.
        let diagonal = assemble_dense(2, &[0, 1, 1], &[0, 0, 1], &[1.0, 0.0, -2.0]);
        assert_eq!(diagonal[(0, 1)], 0.0);
        let (m, d) = InertiaShift::default().convexify(&diagonal).unwrap();
        assert_eq!(d, 0.0);
        assert_eq!(m[(1, 1)], 2.0);
        // Indefinite through the coupling (eigenvalues −0.5 and 2.5, no negative diagonal
        // entry): shifted, and the shift remembered.
        let h = assemble_dense(2, &[0, 1, 1], &[0, 0, 1], &[1.0, 1.5, 1.0]);
        let mut shift = InertiaShift::default();
        let (m, d) = shift.convexify(&h).unwrap();
        assert!(d > 0.5 && m.cholesky().is_some());
        let (_, d2) = shift.convexify(&h).unwrap();
        assert!(d2 > 0.5 && d2 <= d * 8.0);
        // Positive definite on the null space of the row (1, 0): augmentation, no shift.
        let rows = DMatrix::from_row_slice(1, 2, &[0.0, 1.0]);
        let c = shift.convexify_with_rows(&h, &rows, 1, 0.0).unwrap();
        assert_eq!(c.shift, 0.0);
        assert!(c.row_weight > 0.0);
        assert!(c.matrix.cholesky().is_some());
        // Indefinite on the null space of the row e₁ (the block of x₀, x₂ has eigenvalue
        // −0.005) and along the row through its coupling to x₂: shifted on the null space only
        // (the row's own direction is lifted by the augmentation), by much less than the shift
        // of h alone (≥ 2.5).
        let h3 = assemble_dense(3, &[0, 2, 2, 2], &[0, 0, 1, 2], &[1.0, 1.005, 3.0, 1.0]);
        let rows3 = DMatrix::from_row_slice(1, 3, &[0.0, 1.0, 0.0]);
        let (mut on_rows, mut alone) = (InertiaShift::default(), InertiaShift::default());
        for _ in 0..4 {
            let c = on_rows.convexify_with_rows(&h3, &rows3, 1, 0.0).unwrap();
            assert!(c.row_weight > 0.0);
            assert!(c.matrix.cholesky().is_some());
            alone.convexify(&h3).unwrap();
        }
        assert!(on_rows.last() < 0.05 && on_rows.last() > 0.0);
        assert!(alone.last() > 1.0);
    }

    #[test]
    fn the_probe_after_a_shift_changes_no_convexification() {
        // Indefinite on the null space of the row e₁ (as above), with a negative diagonal
        // entry (flipped first) and the memory of a shift: the probe fails, and the result is
        // the one of the full sequence of trials, to the bit.
        let h = assemble_dense(
            4,
            &[0, 2, 2, 2, 3, 3],
            &[0, 0, 1, 2, 0, 3],
            &[1.0, 1.005, 3.0, 1.0, 0.3, -0.2],
        );
        let rows = DMatrix::from_row_slice(1, 4, &[0.0, 1.0, 0.0, 0.0]);
        for last in [1e-10, 1e-3, 0.3] {
            let remembered = |took_shift| InertiaShift {
                last,
                started: true,
                converging: false,
                took_shift,
            };
            let (mut probed, mut plain) = (remembered(true), remembered(false));
            let a = probed.convexify_with_rows(&h, &rows, 1, 0.0).unwrap();
            let b = plain.convexify_with_rows(&h, &rows, 1, 0.0).unwrap();
            assert!(a.shift > DELTA_MIN);
            assert_eq!((a.shift, a.row_weight), (b.shift, b.row_weight));
            assert_eq!(a.matrix, b.matrix);
            assert_eq!(a.factor, b.factor);
            assert_eq!(probed.last(), plain.last());
        }
    }

    #[test]
    fn a_larger_matrix_in_the_loewner_order_has_larger_pivots() {
        // The probe's premise: A + γ₁B fails the pivot test whenever A + γ₂B (γ₂ > γ₁, B ⪰ 0)
        // does, and h fails it whenever h with its negative diagonal flipped does.
        let mut seed = 12345_u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let n = 6;
        let (mut failures, mut passes, mut flips) = (0, 0, 0);
        for _ in 0..400 {
            // Positive semidefinite less a random shift, so that some weights suffice and some
            // do not; a few diagonal entries then come out negative (the flip's case).
            let m = DMatrix::from_fn(n, n, |_, _| next());
            let a = &m * m.transpose() - DMatrix::identity(n, n) * (0.6 * (next() + 0.5));
            let u = DMatrix::from_fn(4, n, |_, _| next());
            let b = u.transpose() * &u;
            let scale = scale_of(&a);
            let gammas = [0.1, 1.0, 10.0, 100.0];
            let passed: Vec<bool> = gammas
                .iter()
                .map(|g| definite_factor_of_sum(&a, Some((&b, g * scale)), scale).is_some())
                .collect();
            for pair in passed.windows(2) {
                assert!(pair[1] || !pair[0], "a pass below a failure: {passed:?}");
            }
            if let Some(f) = flipped(&a, &negative_diagonal_flip(&a)) {
                let top = gammas[3] * scale;
                let flipped_passes = definite_factor_of_sum(&f, Some((&b, top)), scale).is_some();
                assert!(flipped_passes || !passed[3]);
                flips += 1;
            }
            failures += passed.iter().filter(|p| !**p).count();
            passes += passed.iter().filter(|p| **p).count();
        }
        // Both outcomes occur, so the assertions above were put to the test.
        assert!(
            failures > 100 && passes > 100,
            "{failures} failures, {passes} passes"
        );
        assert!(flips > 20, "{flips} flips");
    }

    #[test]
    fn a_converging_solve_keeps_a_strongly_coupled_hessian_unflipped() {
        // Positive definite on the null space of the row e₁ (h₀₀ = 1e-3), but the coupling
        // h₀₁ = 10 needs γ > b²/a − h₁₁ ≈ 1e5 across the row, and h₁₁ = −1 is a negative diagonal
        // entry the flip would change.
        let h = assemble_dense(2, &[0, 1, 1], &[0, 0, 1], &[1e-3, 10.0, -1.0]);
        let row = DMatrix::from_row_slice(1, 2, &[0.0, 1.0]);
        let kept = InertiaShift::converging()
            .convexify_with_rows(&h, &row, 1, 0.0)
            .unwrap();
        assert_eq!(kept.shift, 0.0);
        assert_eq!(kept.row_weight, PROJECTED_GAMMA);
        assert_eq!(kept.matrix[(0, 0)], h[(0, 0)]);
        assert_eq!(kept.matrix[(1, 1)], h[(1, 1)] + PROJECTED_GAMMA);
        assert!(kept.matrix.clone().cholesky().is_some());
        // A solve watched for creep flips h₁₁ first and shifts.
        let watched = InertiaShift::default()
            .convexify_with_rows(&h, &row, 1, 0.0)
            .unwrap();
        assert!(watched.shift > 0.0 || watched.matrix[(1, 1)] != h[(1, 1)] + watched.row_weight);
    }

    #[test]
    fn a_converging_solve_shifts_a_small_negative_curvature_instead_of_flipping_it() {
        // The row e₂ leaves the null space {e₀, e₁}, where h has curvature −0.5 along e₀: the
        // flip would add 1.0 to h₀₀; the schedule's shifts from δ_min by ×8 reach 8¹¹·δ_min ≈
        // 0.86 (relative to the scale 1) first, which covers it and is no larger.
        let h = assemble_dense(3, &[0, 1, 2], &[0, 1, 2], &[-0.5, 1.0, 1.0]);
        let row = DMatrix::from_row_slice(1, 3, &[0.0, 0.0, 1.0]);
        let converging = InertiaShift::converging()
            .convexify_with_rows(&h, &row, 1, 0.0)
            .unwrap();
        let expected = DELTA_MIN * 8f64.powi(11);
        assert_eq!(converging.shift, expected);
        assert!((converging.matrix[(0, 0)] - (expected - 0.5)).abs() < 1e-12);
        assert!(converging.matrix.clone().cholesky().is_some());
        // A solve watched for creep flips h₀₀.
        let watched = InertiaShift::default()
            .convexify_with_rows(&h, &row, 1, 0.0)
            .unwrap();
        assert_eq!(watched.matrix[(0, 0)], 0.5);
        // A negative curvature beyond the flip's size is left to the flip and the schedule
        // after it: coupled, −0.87 along a mix of e₀ and e₁, while the flip adds 1.0.
        let coupled = assemble_dense(3, &[0, 1, 1, 2], &[0, 0, 1, 2], &[-0.5, 0.6, 0.1, 1.0]);
        let beyond = InertiaShift::converging()
            .convexify_with_rows(&coupled, &row, 1, 0.0)
            .unwrap();
        assert!(beyond.matrix[(0, 0)] >= 0.5, "{}", beyond.matrix[(0, 0)]);
    }

    #[test]
    fn row_basis_leaves_out_dependent_rows_and_projects_onto_the_null_space() {
        // Rows 0 and 1 sparse and nearly parallel, row 2 = row 0 + 2·row 1 (dependent), row 3
        // zero, row 4 dense; n = 6.
        let rows = DMatrix::from_row_slice(
            5,
            6,
            &[
                1.0, 0.0, 2.0, 0.0, 0.0, 0.0, //
                1.0, 1e-3, 2.0, 0.0, 0.0, 0.0, //
                3.0, 2e-3, 6.0, 0.0, 0.0, 0.0, //
                0.0, 0.0, 0.0, 0.0, 0.0, 0.0, //
                0.5, -1.0, 0.25, 2.0, 1.0, -3.0,
            ],
        );
        let basis = independent_rows(&rows);
        assert_eq!(basis.kept, vec![0, 1, 4]);
        let projector = basis.projector();
        // P is symmetric, idempotent, of rank n − 3, and annihilates every row.
        assert!((&projector - projector.transpose()).amax() < 1e-14);
        assert!((&projector * &projector - &projector).amax() < 1e-13);
        assert!((projector.trace() - 3.0).abs() < 1e-12);
        assert!((&rows * &projector).amax() < 1e-12);
        // The sparse Gram matrix is the dense product.
        let gram = gram_of(&rows);
        assert!((&gram - rows.tr_mul(&rows)).amax() < 1e-13);
    }

    #[test]
    fn the_slice_kernels_are_nalgebras_to_the_bit() {
        // Lengths around the blocks of eight, values of mixed signs and magnitudes.
        for len in [0, 1, 7, 8, 9, 16, 23, 89] {
            let a = DVector::from_fn(len, |i, _| {
                ((i * 37 % 11) as f64 - 5.3) * 1.7e-3_f64.powi(i as i32 % 3)
            });
            let b = DVector::from_fn(len, |i, _| ((i * 13 % 7) as f64 - 2.9) / 3.0);
            assert_eq!(dense_dot(a.as_slice(), b.as_slice()), a.dot(&b));
            assert_eq!(dense_dot(a.as_slice(), a.as_slice()).sqrt(), a.norm());
        }
        let h = DMatrix::from_fn(9, 9, |i, j| (i as f64 - 2.0 * j as f64) / 7.0);
        let g = DMatrix::from_fn(9, 9, |i, j| ((i * j) % 5) as f64 / 3.0 - 0.4);
        assert_eq!(plus_scaled(&h, &g, 1e3 / 7.0), &h + &g * (1e3 / 7.0));
    }

    #[test]
    fn the_definiteness_test_factor_is_nalgebras_cholesky_to_the_bit() {
        // A dense SPD matrix with exact zeros in it (skipped columns), and an indefinite one.
        let b = DMatrix::from_fn(9, 9, |i, j| {
            if (i + 2 * j) % 5 == 0 {
                0.0
            } else {
                ((i * 7 + j * 3) % 11) as f64 / 11.0 - 0.4
            }
        });
        let h = &b * b.transpose() + DMatrix::identity(9, 9) * 0.05;
        let factor = definite_factor(&h, scale_of(&h)).expect("positive definite");
        let reference = h.clone().cholesky().unwrap().unpack_dirty();
        assert_eq!(factor.lower_triangle(), reference.lower_triangle());
        assert!(
            (factor.lower_triangle() * factor.lower_triangle().transpose() - &h).amax() < 1e-12
        );
        let mut indefinite = h.clone();
        indefinite[(4, 4)] = -1.0;
        assert!(definite_factor(&indefinite, scale_of(&indefinite)).is_none());
    }

    #[test]
    fn the_shift_follows_the_reduced_hessian_despite_a_strong_coupling_across_the_row() {
        // Row e₀, coupled by 100 to x₁; on the row's null space (x₁, x₂) the block
        // [[1, 1.005], [1.005, 1]] has eigenvalue −0.005 (no negative diagonal entry, so no
        // flip). The coupling leaks through the term γ·e₀e₀ᵀ as −100²/γ on x₁: with γ = 1e2 a
        // shift of ~1e2 was needed; with γ = PROJECTED_GAMMA the least shift is −λ_min of the
        // block with the leak.
        let h = assemble_dense(
            3,
            &[0, 1, 1, 2, 2],
            &[0, 0, 1, 1, 2],
            &[0.0, 100.0, 1.0, 1.005, 1.0],
        );
        let rows = DMatrix::from_row_slice(1, 3, &[1.0, 0.0, 0.0]);
        let mut shift = InertiaShift::default();
        for _ in 0..12 {
            let c = shift.convexify_with_rows(&h, &rows, 1, 0.0).unwrap();
            assert!(c.matrix.cholesky().is_some());
        }
        // The schedule settles within its factor 8 of the least shift.
        // (Hessian scale 1, so shifts are absolute here.)
        let leaked =
            DMatrix::from_row_slice(2, 2, &[1.0 - 1e4 / PROJECTED_GAMMA, 1.005, 1.005, 1.0]);
        let least = -leaked.symmetric_eigenvalues().min();
        let last = shift.last();
        assert!(least > 0.0);
        assert!(last >= least && last < 8.0 * least, "{last} vs {least}");
    }
}
