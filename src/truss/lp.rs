//! Linear programs of the truss module, two ways:
//! - [`solve`]: a small dense solver used to certify truss results, the two-phase primal
//!   simplex method on a tableau (a vertex solution);
//! - [`solve_sparse`]: large sparse LPs (layout LPs of whole ground structures) by the crate's
//!   sparse interior-point QP (`solver::qp::sparse`, Mehrotra predictor–corrector) with a zero
//!   Hessian, then a crossover to a vertex.
//!
//! Simplex details: The entering column is the most negative reduced cost (Dantzig);
//! after a run of degenerate pivots it switches to Bland's rule, which cannot cycle, until a pivot
//! makes progress again.
//!
//! Standard form: `min cᵀx  s.t.  A x = b,  x ≥ 0`. Rows with b < 0 are negated first; phase 1
//! minimizes the sum of artificial variables, phase 2 the objective with artificials barred from
//! entering. The duals `y` (with `Aᵀy ≤ c` at the optimum and `bᵀy = cᵀx`) are read from the
//! reduced costs of the artificial columns, so a result can be certified independently:
//! primal feasibility, dual feasibility and a zero duality gap.
//!
//! The dense simplex is meant for ground structures of up to a few hundred bars.
//!
//! Interior point: the solution is a point of the optimal face, not necessarily a vertex (where
//! the optimum is not unique the interior-point limit lies near the face's analytic centre and
//! spreads x over tied columns). Crossover: the columns with x_j above `SUPPORT_FRACTION` of the
//! largest (the others are O(tolerance)) and the rows they touch form a small LP, which the
//! dense simplex solves to a vertex; that vertex is optimal for the whole LP when its objective
//! matches the interior-point one (to `CROSSOVER_GAP`), otherwise the interior-point x is kept.
//! The interior-point duals are kept either way: a dual optimum is complementary to every
//! primal optimum, so the pair stays certified. The QP multipliers λ of `A x = b` follow `c + Aᵀλ + z = 0` with z ≤ 0 at
//! x = 0, so the LP duals are y = −λ (`Aᵀy = c + z ≤ c`). Both solvers report the same
//! residuals recomputed from the input, so their results are certified the same way.
//!
//! Interrupt: both poll the run's flag ([`Interrupt`]), the simplex before every pivot (one
//! pivot is O(m·(m + n)) flops, the poll one relaxed atomic load), the interior-point method
//! before every iteration; a raised flag ends the LP with [`LpError::Interrupted`] and no
//! solution (an interrupted crossover keeps the interior-point solution).

use nalgebra::DMatrix;
use nalgebra_sparse::{CscMatrix, CsrMatrix};

use crate::solver::Interrupt;
use crate::solver::qp::{QpHessian, QpProblem, QpStatus, sparse};

/// Why an LP has no optimal solution.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum LpError {
    /// No x ≥ 0 satisfies A x = b.
    #[error("the linear program is infeasible")]
    Infeasible,
    /// The objective decreases without bound.
    #[error("the linear program is unbounded")]
    Unbounded,
    /// The pivot limit was reached.
    #[error("the simplex method reached its pivot limit")]
    PivotLimit,
    /// The interior-point method stopped short of its tolerance (iteration limit or a
    /// numerical failure).
    #[error("the interior-point method did not converge")]
    IterationLimit,
    /// The run's interrupt flag was raised.
    #[error("the linear program was interrupted")]
    Interrupted,
}

/// An optimal primal–dual pair.
#[derive(Debug, Clone, PartialEq)]
pub struct LpSolution {
    /// Primal solution.
    pub x: Vec<f64>,
    /// Duals of the equality rows.
    pub y: Vec<f64>,
    /// cᵀx.
    pub objective: f64,
    /// Simplex pivots taken (both phases), or interior-point iterations.
    pub iterations: usize,
    /// max |A x − b| recomputed from the input.
    pub primal_residual: f64,
    /// max(0, max_j (Aᵀy − c)_j) recomputed from the input.
    pub dual_infeasibility: f64,
}

/// Smallest pivot element accepted by the ratio test (the tableau is scaled to entries ≲ 1).
const PIVOT_TOLERANCE: f64 = 1e-9;

/// Degenerate pivots in a row after which Bland's rule takes over.
const DEGENERATE_RUN: usize = 50;

/// Pivots between refactorizations of the tableau from the original data.
const REFACTOR_EVERY: usize = 50;

struct Tableau {
    /// (m + 1) × (cols + 1): constraint rows, then the reduced-cost row; last column is the RHS.
    t: DMatrix<f64>,
    /// The sign-adjusted `[A I b]` the tableau was built from.
    original: DMatrix<f64>,
    /// Costs of the current phase (length cols).
    costs: Vec<f64>,
    basis: Vec<usize>,
    m: usize,
    cols: usize,
    tol: f64,
}

impl Tableau {
    /// Rebuilds the tableau as B⁻¹·[A I b] for the current basis, discarding the rounding that
    /// pivots accumulate, and recomputes the reduced costs of the current phase.
    fn refactor(&mut self) {
        let mut basis_matrix = DMatrix::<f64>::zeros(self.m, self.m);
        for (k, &j) in self.basis.iter().enumerate() {
            basis_matrix.set_column(k, &self.original.column(j));
        }
        if let Some(rows) = basis_matrix.lu().solve(&self.original) {
            self.t.rows_mut(0, self.m).copy_from(&rows);
        }
        for j in 0..=self.cols {
            let base = if j == self.cols { 0.0 } else { self.costs[j] };
            self.t[(self.m, j)] = base
                - (0..self.m)
                    .map(|r| self.costs[self.basis[r]] * self.t[(r, j)])
                    .sum::<f64>();
        }
    }

    fn pivot(&mut self, row: usize, col: usize) {
        let p = self.t[(row, col)];
        let width = self.cols + 1;
        for k in 0..width {
            self.t[(row, k)] /= p;
        }
        for r in 0..=self.m {
            if r == row {
                continue;
            }
            let factor = self.t[(r, col)];
            if factor != 0.0 {
                for k in 0..width {
                    let v = self.t[(row, k)];
                    self.t[(r, k)] -= factor * v;
                }
            }
        }
        self.basis[row] = col;
    }

    /// Runs simplex pivots on columns `0..allowed` until optimal (module header).
    fn optimize(
        &mut self,
        allowed: usize,
        pivots: &mut usize,
        limit: usize,
        interrupt: &Interrupt,
    ) -> Result<(), LpError> {
        let mut degenerate = 0;
        loop {
            if interrupt.is_raised() {
                return Err(LpError::Interrupted);
            }
            let candidates = (0..allowed).filter(|&j| self.t[(self.m, j)] < -self.tol);
            let entering = if degenerate > DEGENERATE_RUN {
                candidates.min()
            } else {
                candidates.min_by(|&a, &b| self.t[(self.m, a)].total_cmp(&self.t[(self.m, b)]))
            };
            let Some(col) = entering else {
                return Ok(());
            };
            let mut best: Option<(f64, usize)> = None;
            for r in 0..self.m {
                let a = self.t[(r, col)];
                // Tiny pivots amplify rounding; slightly negative right-hand sides are rounding.
                if a > PIVOT_TOLERANCE {
                    let ratio = self.t[(r, self.cols)].max(0.0) / a;
                    let better = match best {
                        None => true,
                        Some((q, br)) => {
                            ratio < q - self.tol * q.abs().max(1.0)
                                || (ratio <= q + self.tol * q.abs().max(1.0)
                                    && self.basis[r] < self.basis[br])
                        }
                    };
                    if better {
                        best = Some((ratio, r));
                    }
                }
            }
            let Some((ratio, row)) = best else {
                return Err(LpError::Unbounded);
            };
            if ratio.abs() <= self.tol {
                degenerate += 1;
            } else {
                degenerate = 0;
            }
            self.pivot(row, col);
            *pivots += 1;
            if pivots.is_multiple_of(REFACTOR_EVERY) {
                self.refactor();
            }
            if *pivots > limit {
                return Err(LpError::PivotLimit);
            }
        }
    }
}

/// Solves `min cᵀx s.t. A x = b, x ≥ 0` (module header), stopping when `interrupt` is raised.
pub fn solve(
    a: &DMatrix<f64>,
    b: &[f64],
    c: &[f64],
    interrupt: &Interrupt,
) -> Result<LpSolution, LpError> {
    let (m, n) = a.shape();
    solve_limited(a, b, c, 50 * (m + n) + 1000, interrupt)
}

/// [`solve`] with at most `limit` pivots (`LpError::PivotLimit` beyond).
fn solve_limited(
    a: &DMatrix<f64>,
    b: &[f64],
    c: &[f64],
    limit: usize,
    interrupt: &Interrupt,
) -> Result<LpSolution, LpError> {
    let (m, n) = a.shape();
    assert_eq!(b.len(), m);
    assert_eq!(c.len(), n);
    let cols = n + m;
    let scale = a
        .iter()
        .chain(b.iter())
        .map(|v| v.abs())
        .fold(1.0, f64::max);
    let mut t = DMatrix::<f64>::zeros(m + 1, cols + 1);
    let mut sign = vec![1.0; m];
    for r in 0..m {
        sign[r] = if b[r] < 0.0 { -1.0 } else { 1.0 };
        for j in 0..n {
            t[(r, j)] = sign[r] * a[(r, j)];
        }
        t[(r, n + r)] = 1.0;
        t[(r, cols)] = sign[r] * b[r];
    }
    // Phase 1 reduced costs: minimize Σ artificials.
    for j in 0..=cols {
        if (n..cols).contains(&j) {
            continue;
        }
        t[(m, j)] = -(0..m).map(|r| t[(r, j)]).sum::<f64>();
    }
    let mut original = DMatrix::<f64>::zeros(m, cols + 1);
    original.copy_from(&t.rows(0, m));
    let mut tab = Tableau {
        t,
        original,
        costs: (0..cols).map(|j| if j < n { 0.0 } else { 1.0 }).collect(),
        basis: (n..cols).collect(),
        m,
        cols,
        tol: 1e-10 * scale,
    };
    let mut pivots = 0;
    tab.optimize(n, &mut pivots, limit, interrupt)?;
    tab.refactor();
    let infeasibility = -tab.t[(m, cols)];
    if infeasibility > 1e-9 * scale * (1.0 + b.iter().map(|v| v.abs()).sum::<f64>()) {
        return Err(LpError::Infeasible);
    }
    // Drive artificials out of the basis on the largest entry of their row. A row without a
    // usable entry is redundant: it is cleared so that no later pivot can move its artificial.
    for r in 0..m {
        if interrupt.is_raised() {
            return Err(LpError::Interrupted);
        }
        if tab.basis[r] < n {
            continue;
        }
        let (j, v) = (0..n)
            .map(|j| (j, tab.t[(r, j)].abs()))
            .fold((0, 0.0), |best, c| if c.1 > best.1 { c } else { best });
        if v > PIVOT_TOLERANCE {
            tab.pivot(r, j);
            pivots += 1;
        } else {
            for k in 0..n {
                tab.t[(r, k)] = 0.0;
            }
            tab.t[(r, cols)] = 0.0;
        }
    }
    // Phase 2: the objective's costs, artificials at 0.
    tab.costs = (0..cols).map(|j| if j < n { c[j] } else { 0.0 }).collect();
    tab.refactor();
    tab.tol = 1e-9 * c.iter().map(|v| v.abs()).fold(0.0, f64::max);
    tab.optimize(n, &mut pivots, limit, interrupt)?;
    tab.refactor();
    let mut x = vec![0.0; n];
    for r in 0..m {
        if tab.basis[r] < n {
            x[tab.basis[r]] = tab.t[(r, cols)];
        }
    }
    // Reduced cost of artificial r is −y'_r for the sign-adjusted rows.
    let y: Vec<f64> = (0..m).map(|r| -tab.t[(m, n + r)] * sign[r]).collect();
    let objective = x.iter().zip(c).map(|(x, c)| x * c).sum();
    let ax = a * nalgebra::DVector::from_column_slice(&x);
    let primal_residual = (0..m).map(|r| (ax[r] - b[r]).abs()).fold(0.0, f64::max);
    let yv = nalgebra::DVector::from_column_slice(&y);
    let aty = a.transpose() * &yv;
    let dual_infeasibility = (0..n).map(|j| aty[j] - c[j]).fold(0.0, f64::max);
    Ok(LpSolution {
        x,
        y: yv.as_slice().to_vec(),
        objective,
        iterations: pivots,
        primal_residual,
        dual_infeasibility,
    })
}

/// Relative KKT tolerance of the interior-point solve (the `sparse` module header).
const INTERIOR_TOLERANCE: f64 = 1e-10;

/// Columns with x_j above this fraction of the largest enter the crossover LP.
const SUPPORT_FRACTION: f64 = 1e-7;

/// Largest relative objective increase accepted from the crossover vertex.
const CROSSOVER_GAP: f64 = 1e-8;

/// Pivots allowed to the crossover simplex per row and column of its LP. On a support with
/// many tied members the degenerate dense simplex can run for minutes (cooling_tower with
/// self-weight in the LP); past this budget the interior-point solution is kept (the layout
/// start needs only each member's sign and whether it is idle).
const CROSSOVER_PIVOTS: usize = 2;

/// Solves `min cᵀx s.t. A x = b, x ≥ 0` by the sparse interior-point method, then, with
/// `to_vertex`, a crossover to a vertex (module header). Components of x below zero by rounding
/// are set to zero. Without the crossover x is the interior-point limit on the optimal face
/// (the duals are the same either way); the crossover's dense simplex dominates the time on
/// LPs of thousands of columns. Stops when `interrupt` is raised (module header).
pub fn solve_sparse(
    a: &CsrMatrix<f64>,
    b: &[f64],
    c: &[f64],
    to_vertex: bool,
    interrupt: &Interrupt,
) -> Result<LpSolution, LpError> {
    let (m, n) = (a.nrows(), a.ncols());
    assert_eq!(b.len(), m);
    assert_eq!(c.len(), n);
    let zero_hessian = CscMatrix::zeros(n, n);
    let lower = vec![0.0; n];
    let upper = vec![f64::INFINITY; n];
    let problem = QpProblem {
        h: QpHessian::SparseLower(&zero_hessian),
        g: c,
        a,
        dl: &lower,
        du: &upper,
        bl: b,
        bu: b,
    };
    let mut solver = sparse::SparseQp::new();
    solver.interrupt = interrupt.clone();
    let (sol, _) = solver.solve(&problem, INTERIOR_TOLERANCE);
    match sol.status {
        QpStatus::Optimal => {}
        QpStatus::Infeasible => return Err(LpError::Infeasible),
        QpStatus::Unbounded => return Err(LpError::Unbounded),
        QpStatus::IterationLimit | QpStatus::Numerical => return Err(LpError::IterationLimit),
        QpStatus::Interrupted => return Err(LpError::Interrupted),
    }
    let mut x: Vec<f64> = sol.d.iter().map(|v| v.max(0.0)).collect();
    let y: Vec<f64> = sol.lambda.iter().map(|l| -l).collect();
    let mut objective: f64 = x.iter().zip(c).map(|(x, c)| x * c).sum();
    let vertex = to_vertex.then(|| crossover(a, b, c, &x, interrupt));
    if let Some((vertex, value)) = vertex.flatten()
        && value <= objective + CROSSOVER_GAP * objective.abs().max(f64::MIN_POSITIVE)
    {
        x = vertex;
        objective = value;
    }
    let mut ax = vec![0.0; m];
    let mut aty = vec![0.0; n];
    for (r, row) in a.row_iter().enumerate() {
        for (&j, &v) in row.col_indices().iter().zip(row.values()) {
            ax[r] += v * x[j];
            aty[j] += v * y[r];
        }
    }
    let primal_residual = (0..m).map(|r| (ax[r] - b[r]).abs()).fold(0.0, f64::max);
    let dual_infeasibility = (0..n).map(|j| aty[j] - c[j]).fold(0.0, f64::max);
    Ok(LpSolution {
        x,
        y,
        objective,
        iterations: sol.iterations,
        primal_residual,
        dual_infeasibility,
    })
}

/// The vertex of the LP restricted to the support of `x` and the rows it touches, scattered to
/// full length, and its objective (module header); None when that LP fails or a row it leaves
/// out has a nonzero right-hand side.
fn crossover(
    a: &CsrMatrix<f64>,
    b: &[f64],
    c: &[f64],
    x: &[f64],
    interrupt: &Interrupt,
) -> Option<(Vec<f64>, f64)> {
    let largest = x.iter().copied().fold(0.0, f64::max);
    let mut column = vec![usize::MAX; x.len()];
    let mut support = Vec::new();
    for (j, &v) in x.iter().enumerate() {
        if v > SUPPORT_FRACTION * largest {
            column[j] = support.len();
            support.push(j);
        }
    }
    let touches = |r: usize| (a.row(r).col_indices().iter()).any(|&j| column[j] != usize::MAX);
    let mut rows = Vec::new();
    for (r, &rhs) in b.iter().enumerate() {
        if touches(r) {
            rows.push(r);
        } else if rhs != 0.0 {
            return None;
        }
    }
    let mut dense = DMatrix::<f64>::zeros(rows.len(), support.len());
    for (k, &r) in rows.iter().enumerate() {
        let row = a.row(r);
        for (&j, &v) in row.col_indices().iter().zip(row.values()) {
            if column[j] != usize::MAX {
                dense[(k, column[j])] += v;
            }
        }
    }
    let sub_b: Vec<f64> = rows.iter().map(|&r| b[r]).collect();
    let sub_c: Vec<f64> = support.iter().map(|&j| c[j]).collect();
    let limit = CROSSOVER_PIVOTS * (rows.len() + support.len()) + 100;
    let vertex = solve_limited(&dense, &sub_b, &sub_c, limit, interrupt).ok()?;
    let mut full = vec![0.0; x.len()];
    for (k, &j) in support.iter().enumerate() {
        full[j] = vertex.x[k];
    }
    Some((full, vertex.objective))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_lp_with_known_optimum_and_certificate() {
        // min −x1 − 2x2  s.t. x1 + x2 + s1 = 4, x1 + 3x2 + s2 = 6  → x = (3, 1), f = −5.
        let a = DMatrix::from_row_slice(2, 4, &[1.0, 1.0, 1.0, 0.0, 1.0, 3.0, 0.0, 1.0]);
        let b = [4.0, 6.0];
        let c = [-1.0, -2.0, 0.0, 0.0];
        let s = solve(&a, &b, &c, &Interrupt::new()).unwrap();
        assert!((s.objective + 5.0).abs() < 1e-12);
        assert!((s.x[0] - 3.0).abs() < 1e-12 && (s.x[1] - 1.0).abs() < 1e-12);
        let dual: f64 = s.y.iter().zip(&b).map(|(y, b)| y * b).sum();
        assert!((dual - s.objective).abs() < 1e-12);
        for j in 0..4 {
            let aty: f64 = (0..2).map(|r| a[(r, j)] * s.y[r]).sum();
            assert!(aty <= c[j] + 1e-12);
        }
    }

    #[test]
    fn sparse_solver_finds_the_same_vertex_and_certificate() {
        // The LP above, plus a tied column x3 (a copy of x1): the crossover returns a vertex.
        let dense =
            DMatrix::from_row_slice(2, 5, &[1.0, 1.0, 1.0, 0.0, 1.0, 1.0, 3.0, 0.0, 1.0, 1.0]);
        let a = CsrMatrix::from(&dense);
        let (b, c) = ([4.0, 6.0], [-1.0, -2.0, 0.0, 0.0, -1.0]);
        let s = solve_sparse(&a, &b, &c, true, &Interrupt::new()).unwrap();
        let reference = solve(&dense, &b, &c, &Interrupt::new()).unwrap();
        assert!((s.objective - reference.objective).abs() < 1e-9);
        assert!((s.x[0] + s.x[4] - 3.0).abs() < 1e-9 && (s.x[1] - 1.0).abs() < 1e-9);
        assert!(s.x[0].min(s.x[4]) == 0.0, "not a vertex: {:?}", s.x);
        assert!(s.primal_residual < 1e-9 && s.dual_infeasibility < 1e-9);
        let dual: f64 = s.y.iter().zip(&b).map(|(y, b)| y * b).sum();
        assert!((dual - s.objective).abs() < 1e-8);
        // x1 + x2 = −1 has no x ≥ 0.
        let a = CsrMatrix::from(&DMatrix::from_row_slice(1, 2, &[1.0, 1.0]));
        assert_eq!(
            solve_sparse(&a, &[-1.0], &[1.0, 1.0], true, &Interrupt::new()),
            Err(LpError::Infeasible)
        );
    }

    #[test]
    fn negative_right_hand_sides_redundant_rows_and_failures() {
        // −x1 − x2 = −2 (twice: redundant), min x1 + 2x2 → x = (2, 0), f = 2.
        let a = DMatrix::from_row_slice(2, 2, &[-1.0, -1.0, -1.0, -1.0]);
        let s = solve(&a, &[-2.0, -2.0], &[1.0, 2.0], &Interrupt::new()).unwrap();
        assert!((s.objective - 2.0).abs() < 1e-12);
        let dual: f64 = s.y.iter().map(|y| -2.0 * y).sum();
        assert!((dual - 2.0).abs() < 1e-12);
        // x1 + x2 = −1 has no x ≥ 0.
        let a = DMatrix::from_row_slice(1, 2, &[1.0, 1.0]);
        assert_eq!(
            solve(&a, &[-1.0], &[1.0, 1.0], &Interrupt::new()),
            Err(LpError::Infeasible)
        );
        // min −x1 s.t. x1 − x2 = 0 is unbounded.
        let a = DMatrix::from_row_slice(1, 2, &[1.0, -1.0]);
        assert_eq!(
            solve(&a, &[0.0], &[-1.0, 0.0], &Interrupt::new()),
            Err(LpError::Unbounded)
        );
    }

    #[test]
    fn a_raised_interrupt_stops_both_solvers() {
        // The LP of the test above that both solvers solve: min x1 + 2x2, x1 + x2 = 2.
        let a = DMatrix::from_row_slice(1, 2, &[1.0, 1.0]);
        let (b, c) = ([2.0], [1.0, 2.0]);
        let raised = Interrupt::new();
        raised.raise();
        assert_eq!(solve(&a, &b, &c, &raised), Err(LpError::Interrupted));
        let sparse = CsrMatrix::from(&a);
        for to_vertex in [true, false] {
            let result = solve_sparse(&sparse, &b, &c, to_vertex, &raised);
            assert_eq!(result, Err(LpError::Interrupted));
            assert!(solve_sparse(&sparse, &b, &c, to_vertex, &Interrupt::new()).is_ok());
        }
    }
}
