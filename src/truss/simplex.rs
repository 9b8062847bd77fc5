//! The revised simplex method with a dense basis inverse, for the intermediate LPs of member
//! adding ([`super::member_adding`]): LPs of a few dozen to a few hundred rows whose next LP
//! differs by added columns, so each solve starts from the previous optimal basis.
//!
//! Standard form `min cᵀx  s.t.  A x = b,  x ≥ 0`, A sparse by columns. Rows with b < 0 are
//! negated (signs S, so b' = S·b ≥ 0); every row r has an artificial variable a_r ≥ 0 with
//! column e_r, so the all-artificial basis is feasible. A basis B (m columns of `[S·A  I]`) is
//! kept as its explicit inverse B⁻¹ (m × m), updated by the pivot's elementary row operations
//! (O(m²)) and recomputed from an LU factorization every `REFACTOR_EVERY` pivots and before the
//! solution is read.
//!
//! One pivot: duals y' = B⁻ᵀc_B; reduced costs d_j = c_j − y'ᵀa'_j of the nonbasic columns
//! (artificials never enter); the entering column q has the most negative d_j (Dantzig), or,
//! after `DEGENERATE_RUN` degenerate pivots in a row, the first negative one (Bland); the
//! direction w = B⁻¹a'_q; the leaving row is the smallest ratio x_B,r / w_r over w_r > 0, ties by
//! the basic variable's index (columns first, then artificials), as Bland's rule asks, so the
//! method cannot cycle. A basic artificial at zero in phase 2 (a redundant row) leaves at ratio
//! 0 as soon as it would move.
//!
//! Phases: phase 1 minimizes Σ a_r (infeasible when its optimum exceeds a tolerance relative
//! to ‖b‖₁), phase 2 the objective with the artificials at cost 0. A warm start from a given
//! basis skips phase 1 when that basis is nonsingular, primal feasible (x_B ≥ 0 to a
//! tolerance) and holds no positive artificial; a basis that is feasible but holds one runs
//! phase 1 from it; otherwise the solve starts cold. In member adding the previous LP's optimal
//! basis is primal feasible for the next LP (the new columns are nonbasic at 0), so only the
//! added columns that price negative enter.
//!
//! Duals: y = S·y' (`Aᵀy ≤ c` at the optimum and `bᵀy = cᵀx`), reported with the same residuals
//! as [`super::lp::solve`], recomputed from the input.

use nalgebra_sparse::CscMatrix;

use super::lp::{LpError, LpSolution};
use crate::solver::Interrupt;

/// A basic variable: column j of A, or the artificial variable of row r.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Basic {
    /// Column j of A.
    Column(usize),
    /// The artificial variable of row r.
    Artificial(usize),
}

/// An optimal solution and its basis (one basic variable per row, in row order of B).
#[derive(Debug, Clone, PartialEq)]
pub struct Solved {
    /// The primal–dual pair.
    pub solution: LpSolution,
    /// The optimal basis, to warm-start an LP with more columns.
    pub basis: Vec<Basic>,
}

/// Smallest |w_r| accepted as a pivot (A is scaled to entries ≲ 1).
const PIVOT_TOLERANCE: f64 = 1e-7;

/// Degenerate pivots in a row after which Bland's rule takes over. Long: Bland's rule ignores
/// the pivots' size, and on the layout LPs (heavily degenerate: most balance rows have b = 0)
/// an early switch led to singular bases (m = 93: after 150–250 pivots with a run of 50); a
/// cycle still meets it, and a numerical failure leaves the LP to the interior point.
const DEGENERATE_RUN: usize = 500;

/// Pivots between recomputations of B⁻¹ from an LU factorization.
const REFACTOR_EVERY: usize = 50;

/// Reduced cost below −this (relative to the largest |c|, at least 1) enters.
const OPTIMALITY_TOLERANCE: f64 = 1e-10;

/// A Gauss–Jordan pivot of at most this magnitude makes B singular (A is scaled to entries ≲ 1).
const SINGULAR_PIVOT: f64 = 1e-13;

/// A step of at most this length counts as degenerate.
const DEGENERATE_STEP: f64 = 1e-12;

/// Largest negative basic value (relative to 1 + max b') that counts as feasible.
const FEASIBILITY_TOLERANCE: f64 = 1e-9;

/// Solves `min cᵀx s.t. A x = b, x ≥ 0` (module header), from `warm` if it is a usable basis,
/// stopping when `interrupt` is raised.
pub fn solve(
    a: &CscMatrix<f64>,
    b: &[f64],
    c: &[f64],
    warm: Option<&[Basic]>,
    interrupt: &Interrupt,
) -> Result<Solved, LpError> {
    let (m, n) = (a.nrows(), a.ncols());
    assert_eq!(b.len(), m);
    assert_eq!(c.len(), n);
    let mut lp = Revised::new(a, b);
    let feasible = 1.0 + lp.b.iter().copied().fold(0.0, f64::max);
    let started = warm.is_some_and(|w| lp.start_from(w, FEASIBILITY_TOLERANCE * feasible));
    if !started {
        lp.set_basis((n..n + m).collect());
        lp.inverse.fill(0.0);
        for r in 0..m {
            lp.inverse[r * m + r] = 1.0;
        }
        lp.x = lp.b.clone();
    }
    let positive_artificial = (lp.basis.iter().zip(&lp.x)).any(|(&v, &x)| v >= n && x > 0.0);
    if positive_artificial {
        let mut phase_one = vec![0.0; n + m];
        phase_one[n..].fill(1.0);
        lp.optimize(&phase_one, OPTIMALITY_TOLERANCE, false, interrupt)?;
        lp.refactor()?;
        let infeasibility: f64 = (lp.basis.iter().zip(&lp.x))
            .filter(|&(&v, _)| v >= n)
            .map(|(_, x)| x.max(0.0))
            .sum();
        let scale = 1.0 + lp.b.iter().sum::<f64>();
        if infeasibility > FEASIBILITY_TOLERANCE * scale {
            return Err(LpError::Infeasible);
        }
        lp.drive_out_artificials(interrupt)?;
    }
    let cost_scale = c.iter().map(|v| v.abs()).fold(1.0, f64::max);
    let mut phase_two = c.to_vec();
    phase_two.resize(n + m, 0.0);
    lp.optimize(
        &phase_two,
        OPTIMALITY_TOLERANCE * cost_scale,
        true,
        interrupt,
    )?;
    lp.refactor()?;
    let basis = (lp.basis.iter())
        .map(|&v| {
            if v < n {
                Basic::Column(v)
            } else {
                Basic::Artificial(v - n)
            }
        })
        .collect();
    Ok(Solved {
        solution: lp.solution(a, b, &phase_two),
        basis,
    })
}

/// The simplex state: the sign-adjusted LP by columns, the basis, B⁻¹ and x_B. Variables are
/// numbered columns first (0..n), then artificials (n + r), which is also Bland's order.
struct Revised {
    m: usize,
    n: usize,
    /// Column j of S·A: entries `start[j]..start[j + 1]` of `rows` and `values`.
    start: Vec<usize>,
    rows: Vec<usize>,
    values: Vec<f64>,
    /// Row signs S (b' = S·b ≥ 0).
    sign: Vec<f64>,
    /// b'.
    b: Vec<f64>,
    /// The basic variable of each row of B.
    basis: Vec<usize>,
    /// Whether each variable is basic.
    basic: Vec<bool>,
    /// B⁻¹, row-major.
    inverse: Vec<f64>,
    /// The basic variables' values, in basis order.
    x: Vec<f64>,
    pivots: usize,
    limit: usize,
}

impl Revised {
    fn new(a: &CscMatrix<f64>, b: &[f64]) -> Self {
        let (m, n) = (a.nrows(), a.ncols());
        let sign: Vec<f64> = b
            .iter()
            .map(|&v| if v < 0.0 { -1.0 } else { 1.0 })
            .collect();
        let mut start = Vec::with_capacity(n + 1);
        let (mut rows, mut values) = (Vec::new(), Vec::new());
        for j in 0..n {
            start.push(rows.len());
            let col = a.col(j);
            for (&r, &v) in col.row_indices().iter().zip(col.values()) {
                rows.push(r);
                values.push(sign[r] * v);
            }
        }
        start.push(rows.len());
        Revised {
            m,
            n,
            start,
            rows,
            values,
            b: b.iter().zip(&sign).map(|(v, s)| v * s).collect(),
            sign,
            basis: Vec::new(),
            basic: vec![false; n + m],
            inverse: vec![0.0; m * m],
            x: Vec::new(),
            pivots: 0,
            limit: 50 * (m + n) + 1000,
        }
    }

    fn set_basis(&mut self, basis: Vec<usize>) {
        self.basic.fill(false);
        for &v in &basis {
            self.basic[v] = true;
        }
        self.basis = basis;
    }

    /// Installs `warm` if it is a basis of m distinct valid variables, nonsingular and primal
    /// feasible to `tolerance` (negative values within it set to 0); false otherwise.
    fn start_from(&mut self, warm: &[Basic], tolerance: f64) -> bool {
        let (m, n) = (self.m, self.n);
        let index = |k: &Basic| match *k {
            Basic::Column(j) => (j < n).then_some(j),
            Basic::Artificial(r) => (r < m).then_some(n + r),
        };
        let Some(basis) = warm.iter().map(index).collect::<Option<Vec<usize>>>() else {
            return false;
        };
        let distinct: std::collections::HashSet<usize> = basis.iter().copied().collect();
        if basis.len() != m || distinct.len() != m {
            return false;
        }
        self.set_basis(basis);
        if self.refactor().is_err() || self.x.iter().any(|&v| v < -tolerance) {
            return false;
        }
        self.x.iter_mut().for_each(|v| *v = v.max(0.0));
        true
    }

    /// The entries of variable v's column in S·A (an artificial's: e_r), as (row, value) pairs.
    fn entries(&self, v: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let (column, artificial) = if v < self.n {
            (self.start[v]..self.start[v + 1], None)
        } else {
            (0..0, Some((v - self.n, 1.0)))
        };
        (column.map(|k| (self.rows[k], self.values[k]))).chain(artificial)
    }

    /// Recomputes B⁻¹ and x_B = B⁻¹b' from the basis by Gauss–Jordan elimination with partial
    /// pivoting in place (row operations skip the zeros of the sparse B); a singular B is a
    /// numerical failure.
    fn refactor(&mut self) -> Result<(), LpError> {
        let m = self.m;
        let a = &mut self.inverse;
        a.fill(0.0);
        for (k, &v) in self.basis.iter().enumerate() {
            let range = if v < self.n {
                self.start[v]..self.start[v + 1]
            } else {
                0..0
            };
            for i in range {
                a[self.rows[i] * m + k] += self.values[i];
            }
            if v >= self.n {
                a[(v - self.n) * m + k] += 1.0;
            }
        }
        let mut swaps = Vec::with_capacity(m);
        for k in 0..m {
            let p = (k..m)
                .max_by(|&i, &j| a[i * m + k].abs().total_cmp(&a[j * m + k].abs()))
                .unwrap_or(k);
            if a[p * m + k].abs() <= SINGULAR_PIVOT {
                return Err(LpError::IterationLimit);
            }
            if p != k {
                for c in 0..m {
                    a.swap(k * m + c, p * m + c);
                }
            }
            swaps.push(p);
            let (before, rest) = a.split_at_mut(k * m);
            let (pivot_row, after) = rest.split_at_mut(m);
            let scale = 1.0 / pivot_row[k];
            pivot_row[k] = 1.0;
            pivot_row.iter_mut().for_each(|v| *v *= scale);
            for row in before.chunks_exact_mut(m).chain(after.chunks_exact_mut(m)) {
                let f = row[k];
                if f != 0.0 {
                    row[k] = 0.0;
                    row.iter_mut()
                        .zip(&*pivot_row)
                        .for_each(|(t, p)| *t -= f * p);
                }
            }
        }
        // The row swaps of B are column swaps of B⁻¹, undone in reverse order.
        for (k, &p) in swaps.iter().enumerate().rev() {
            if p != k {
                for row in a.chunks_exact_mut(m) {
                    row.swap(k, p);
                }
            }
        }
        self.x = (self.inverse.chunks_exact(m))
            .map(|row| row.iter().zip(&self.b).map(|(a, b)| a * b).sum())
            .collect();
        Ok(())
    }

    /// w = B⁻¹a'_q.
    fn direction(&self, q: usize) -> Vec<f64> {
        let m = self.m;
        (self.inverse.chunks_exact(m))
            .map(|row| self.entries(q).map(|(r, v)| row[r] * v).sum())
            .collect()
    }

    /// y' = B⁻ᵀc_B.
    fn duals(&self, cost: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; self.m];
        for (row, &v) in self.inverse.chunks_exact(self.m).zip(&self.basis) {
            let c = cost[v];
            if c != 0.0 {
                y.iter_mut().zip(row).for_each(|(y, a)| *y += c * a);
            }
        }
        y
    }

    /// (y'ᵀa')_j for column j.
    fn dot(&self, j: usize, y: &[f64]) -> f64 {
        let range = self.start[j]..self.start[j + 1];
        (self.rows[range.clone()].iter().zip(&self.values[range]))
            .map(|(&r, &v)| y[r] * v)
            .sum()
    }

    /// Pivots variable q into row `row` along w (x_B, B⁻¹ and the basis updated).
    fn pivot(&mut self, row: usize, q: usize, w: &[f64]) {
        let m = self.m;
        let theta = self.x[row].max(0.0) / w[row];
        for (x, wi) in self.x.iter_mut().zip(w) {
            *x -= theta * wi;
        }
        self.x[row] = theta;
        let (before, rest) = self.inverse.split_at_mut(row * m);
        let (pivot_row, after) = rest.split_at_mut(m);
        let p = 1.0 / w[row];
        pivot_row.iter_mut().for_each(|v| *v *= p);
        let others = before.chunks_exact_mut(m).chain(after.chunks_exact_mut(m));
        let factors = (w.iter().enumerate()).filter_map(|(i, &wi)| (i != row).then_some(wi));
        for (target, wi) in others.zip(factors) {
            if wi != 0.0 {
                target
                    .iter_mut()
                    .zip(&*pivot_row)
                    .for_each(|(t, p)| *t -= wi * p);
            }
        }
        self.basic[self.basis[row]] = false;
        self.basis[row] = q;
        self.basic[q] = true;
        self.pivots += 1;
    }

    /// The ratio test along w: the leaving row and the step (module header). Pivots below
    /// `PIVOT_TOLERANCE` relative to the largest |w_r| are refused. Bland's mode takes the
    /// smallest ratio, ties by the basic variable's index; otherwise Harris's two passes take,
    /// among the rows whose ratio is within `FEASIBILITY_TOLERANCE` of the smallest, the
    /// largest pivot (small pivots make B nearly singular). In phase 2 a basic artificial with
    /// a usable pivot leaves first, at step 0.
    fn leaving(&self, w: &[f64], phase_two: bool, bland: bool) -> Option<(f64, usize)> {
        let n = self.n;
        let tiny = PIVOT_TOLERANCE * w.iter().fold(1.0, |a: f64, v| a.max(v.abs()));
        if phase_two {
            let stuck = (0..self.m)
                .filter(|&r| self.basis[r] >= n && w[r].abs() > tiny)
                .max_by(|&a, &b| w[a].abs().total_cmp(&w[b].abs()));
            if let Some(r) = stuck {
                return Some((0.0, r));
            }
        }
        let eligible = || (0..self.m).filter(|&r| w[r] > tiny);
        if bland {
            let mut best: Option<(f64, usize)> = None;
            for r in eligible() {
                let ratio = self.x[r].max(0.0) / w[r];
                let v = self.basis[r];
                if best.is_none_or(|(q, br)| ratio < q || (ratio == q && v < self.basis[br])) {
                    best = Some((ratio, r));
                }
            }
            return best;
        }
        let bound = eligible()
            .map(|r| (self.x[r].max(0.0) + FEASIBILITY_TOLERANCE) / w[r])
            .fold(f64::INFINITY, f64::min);
        let row = eligible()
            .filter(|&r| self.x[r].max(0.0) / w[r] <= bound)
            .max_by(|&a, &b| w[a].total_cmp(&w[b]).then(b.cmp(&a)))?;
        Some((self.x[row].max(0.0) / w[row], row))
    }

    /// Simplex pivots under `cost` (per variable) until no column prices below −`tolerance`
    /// (module header); with `phase_two`, a basic artificial leaves as soon as it would move.
    fn optimize(
        &mut self,
        cost: &[f64],
        tolerance: f64,
        phase_two: bool,
        interrupt: &Interrupt,
    ) -> Result<(), LpError> {
        let (m, n) = (self.m, self.n);
        let mut degenerate = 0;
        let mut since_refactor = 0;
        let mut y = self.duals(cost);
        loop {
            if interrupt.is_raised() {
                return Err(LpError::Interrupted);
            }
            let bland = degenerate > DEGENERATE_RUN;
            let mut entering: Option<(usize, f64)> = None;
            for j in (0..n).filter(|&j| !self.basic[j]) {
                let d = cost[j] - self.dot(j, &y);
                if d < -tolerance && entering.is_none_or(|(_, best)| d < best) {
                    entering = Some((j, d));
                    if bland {
                        break;
                    }
                }
            }
            let Some((q, reduced)) = entering else {
                return Ok(());
            };
            let w = self.direction(q);
            let Some((ratio, row)) = self.leaving(&w, phase_two, bland) else {
                return Err(LpError::Unbounded);
            };
            degenerate = if ratio <= DEGENERATE_STEP {
                degenerate + 1
            } else {
                0
            };
            self.pivot(row, q, &w);
            since_refactor += 1;
            if since_refactor == REFACTOR_EVERY {
                since_refactor = 0;
                self.refactor()?;
                y = self.duals(cost);
            } else {
                // y' gains d_q times the new row of B⁻¹ (c_B changed in that row only).
                let new_row = &self.inverse[row * m..(row + 1) * m];
                y.iter_mut()
                    .zip(new_row)
                    .for_each(|(y, a)| *y += reduced * a);
            }
            if self.pivots > self.limit {
                return Err(LpError::PivotLimit);
            }
        }
    }

    /// After phase 1, pivots each basic artificial (at zero) out on the largest entry of its
    /// row of B⁻¹A'; one without a usable entry stays (its row is redundant).
    fn drive_out_artificials(&mut self, interrupt: &Interrupt) -> Result<(), LpError> {
        let (m, n) = (self.m, self.n);
        for r in 0..m {
            if interrupt.is_raised() {
                return Err(LpError::Interrupted);
            }
            if self.basis[r] < n {
                continue;
            }
            let rho = self.inverse[r * m..(r + 1) * m].to_vec();
            let best = (0..n)
                .filter(|&j| !self.basic[j])
                .map(|j| (j, self.dot(j, &rho).abs()))
                .fold(None, |best: Option<(usize, f64)>, c| match best {
                    Some(b) if b.1 >= c.1 => Some(b),
                    _ => Some(c),
                });
            if let Some((j, v)) = best
                && v > PIVOT_TOLERANCE
            {
                let w = self.direction(j);
                self.x[r] = 0.0;
                self.pivot(r, j, &w);
            }
        }
        self.refactor()
    }

    /// The solution in the original signs (`cost` the phase-2 costs per variable), with
    /// residuals recomputed from the input A and b.
    fn solution(&self, a: &CscMatrix<f64>, b: &[f64], cost: &[f64]) -> LpSolution {
        let (m, n) = (self.m, self.n);
        let mut x = vec![0.0; n];
        for (&v, &value) in self.basis.iter().zip(&self.x) {
            if v < n {
                x[v] = value.max(0.0);
            }
        }
        let y: Vec<f64> = (self.duals(cost).iter().zip(&self.sign))
            .map(|(y, s)| y * s)
            .collect();
        let mut ax = vec![0.0; m];
        let mut dual_infeasibility: f64 = 0.0;
        for (j, &xj) in x.iter().enumerate() {
            let col = a.col(j);
            let mut aty = 0.0;
            for (&r, &v) in col.row_indices().iter().zip(col.values()) {
                ax[r] += v * xj;
                aty += v * y[r];
            }
            dual_infeasibility = dual_infeasibility.max(aty - cost[j]);
        }
        let primal_residual = (0..m).map(|r| (ax[r] - b[r]).abs()).fold(0.0, f64::max);
        LpSolution {
            objective: x.iter().zip(cost).map(|(x, c)| x * c).sum(),
            x,
            y,
            iterations: self.pivots,
            primal_residual,
            dual_infeasibility,
        }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};
    use nalgebra_sparse::CsrMatrix;

    use super::*;
    use crate::truss::lp;

    /// A deterministic generator of uniform numbers in [0, 1) (splitmix64).
    struct Numbers(u64);

    impl Numbers {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// A random feasible, bounded LP: sparse A (m × n, about 3 nonzeros a column, some columns
    /// repeated to tie), b = A·x₀ for a random x₀ ≥ 0 with m/2 nonzeros, c > 0.
    fn random_lp(m: usize, n: usize, seed: u64) -> (DMatrix<f64>, Vec<f64>, Vec<f64>) {
        let mut rng = Numbers(seed);
        let mut a = DMatrix::<f64>::zeros(m, n);
        for j in 0..n {
            if j % 7 == 6 {
                let copy = a.column(j - 1).clone_owned();
                a.set_column(j, &copy);
                continue;
            }
            for _ in 0..3 {
                let r = (rng.next() * m as f64) as usize;
                a[(r, j)] = 2.0 * rng.next() - 1.0;
            }
        }
        let mut x0 = vec![0.0; n];
        for _ in 0..m / 2 {
            x0[(rng.next() * n as f64) as usize] = rng.next();
        }
        let b = (&a * DVector::from_column_slice(&x0)).as_slice().to_vec();
        let c = (0..n).map(|_| 0.1 + rng.next()).collect();
        (a, b, c)
    }

    fn certified(s: &LpSolution, b: &[f64]) {
        assert!(s.primal_residual < 1e-9, "residual {}", s.primal_residual);
        assert!(s.dual_infeasibility < 1e-9, "dual {}", s.dual_infeasibility);
        let dual: f64 = s.y.iter().zip(b).map(|(y, b)| y * b).sum();
        assert!((dual - s.objective).abs() <= 1e-9 * s.objective.abs().max(1.0));
        assert!(s.x.iter().all(|&v| v >= 0.0));
    }

    #[test]
    fn random_lps_match_the_interior_point_cold_and_warm() {
        let interrupt = Interrupt::new();
        for seed in 0..20 {
            let (m, n) = (8 + (seed as usize % 5) * 6, 60 + (seed as usize % 4) * 40);
            let (a, b, c) = random_lp(m, n, seed);
            let sparse = CsrMatrix::from(&a);
            let reference = lp::solve_sparse(&sparse, &b, &c, false, &interrupt).unwrap();
            let csc = CscMatrix::from(&a);
            let cold = solve(&csc, &b, &c, None, &interrupt).unwrap();
            let value = reference.objective;
            let gap = (cold.solution.objective - value).abs();
            assert!(gap <= 1e-9 * value.abs().max(1.0), "seed {seed}: {gap}");
            certified(&cold.solution, &b);
            // Warm: the first half of the columns, then all of them from its basis.
            let half = n / 2;
            let first = CscMatrix::from(&a.columns(0, half).clone_owned());
            let partial = solve(&first, &b, &c[..half], None, &interrupt);
            if let Ok(partial) = partial {
                let warm = solve(&csc, &b, &c, Some(&partial.basis), &interrupt).unwrap();
                let gap = (warm.solution.objective - value).abs();
                assert!(
                    gap <= 1e-9 * value.abs().max(1.0),
                    "seed {seed} warm: {gap}"
                );
                certified(&warm.solution, &b);
                // Started from the half's basis, it pivots less than from scratch.
                assert!(warm.solution.iterations <= cold.solution.iterations + 1);
            }
        }
    }

    #[test]
    fn infeasible_unbounded_redundant_and_unusable_warm_starts() {
        let interrupt = Interrupt::new();
        let csc = |rows: usize, cols: usize, v: &[f64]| {
            CscMatrix::from(&DMatrix::from_row_slice(rows, cols, v))
        };
        // x1 + x2 = −1 has no x ≥ 0.
        let a = csc(1, 2, &[1.0, 1.0]);
        assert_eq!(
            solve(&a, &[-1.0], &[1.0, 1.0], None, &interrupt),
            Err(LpError::Infeasible)
        );
        // min −x1 s.t. x1 − x2 = 0 is unbounded.
        let a = csc(1, 2, &[1.0, -1.0]);
        assert_eq!(
            solve(&a, &[0.0], &[-1.0, 0.0], None, &interrupt),
            Err(LpError::Unbounded)
        );
        // −x1 − x2 = −2 twice (a redundant row), min x1 + 2x2 → x = (2, 0), f = 2.
        let a = csc(2, 2, &[-1.0, -1.0, -1.0, -1.0]);
        let s = solve(&a, &[-2.0, -2.0], &[1.0, 2.0], None, &interrupt).unwrap();
        assert_eq!(s.basis.len(), 2);
        assert!((s.solution.objective - 2.0).abs() < 1e-12);
        certified(&s.solution, &[-2.0, -2.0]);
        // A warm basis that is singular, infeasible or of the wrong size starts cold.
        let a = csc(2, 3, &[1.0, 1.0, 0.0, 0.0, 1.0, 1.0]);
        let (b, c) = ([1.0, 1.0], [1.0, 3.0, 1.0]);
        for warm in [
            vec![Basic::Column(0), Basic::Column(0)],
            vec![Basic::Column(1)],
            vec![Basic::Column(5), Basic::Artificial(0)],
        ] {
            let s = solve(&a, &b, &c, Some(&warm), &interrupt).unwrap();
            assert!((s.solution.objective - 2.0).abs() < 1e-12, "{warm:?}");
        }
        let raised = Interrupt::new();
        raised.raise();
        assert_eq!(solve(&a, &b, &c, None, &raised), Err(LpError::Interrupted));
    }
}
