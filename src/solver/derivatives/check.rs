//! The derivative checker behind `--check`: an [`Nlp`]'s gradient, Jacobian and (if provided)
//! Lagrangian Hessian against central differences at one point.
//!
//! Error measure, for an analytic value a and a difference estimate d:
//!
//! ```text
//!     e = |a − d| / max(1, |a|, |d|)
//! ```
//! relative for entries larger than 1 and absolute below, so that tiny entries with roundoff do
//! not count as failures and large ones are judged by their leading digits. An entry fails when
//! e > tolerance. Duplicated pattern entries are summed before comparing.
//!
//! The Jacobian is estimated one column at a time when n ≤ `scan_limit`; then every nonzero of
//! the estimate outside the declared pattern is reported too (a missing pattern entry is a
//! common bug). Larger problems use column groups (only pattern entries are checked). The
//! Hessian of `L = f + Σ λᵢ cᵢ` is checked by central differences of the analytic ∇L, with
//! multipliers λᵢ = (−1)ⁱ·(1 + (i mod 3)/2) unless given, lower triangle only; one column at a
//! time (finding entries outside the pattern) when n ≤ `scan_limit`, else with columns grouped
//! by the symmetric Hessian pattern. The Hessian check uses the problem's Jacobian, so a wrong
//! Jacobian entry also shows up as Hessian errors.
//!
//! Stencils respect the variable bounds (see [`super::interval`]).

use std::collections::BTreeMap;
use std::fmt;

use rayon::prelude::*;
use serde::Serialize;

use super::coloring::ColumnGroups;
use super::engine::FiniteDifferences;
use super::interval::{DifferenceScheme, FiniteDifferenceOptions, Stencil};
use crate::solver::{EvalError, Nlp};

/// Settings of a derivative check. `Default` gives the documented defaults.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckOptions {
    /// Largest acceptable error e (see the module header); default 1e-5.
    pub tolerance: f64,
    /// Function precision and scale for the intervals (the scheme is always central);
    /// default [`FiniteDifferenceOptions::default`].
    pub differences: FiniteDifferenceOptions,
    /// Largest n for which columns are differenced one by one and entries outside the pattern
    /// are detected; default 2000.
    pub scan_limit: usize,
    /// Multipliers for the Hessian check (length m); default `None` (the fixed pattern above).
    pub lambda: Option<Vec<f64>>,
    /// Worst functions listed by `Display`; default 10.
    pub listed: usize,
}

impl Default for CheckOptions {
    fn default() -> Self {
        CheckOptions {
            tolerance: 1e-5,
            differences: FiniteDifferenceOptions::default(),
            scan_limit: 2000,
            lambda: None,
            listed: 10,
        }
    }
}

/// Which derivative block an entry belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub enum Block {
    /// ∂f/∂x_col.
    Gradient,
    /// ∂c_row/∂x_col.
    Jacobian,
    /// ∂²L/∂x_row∂x_col (row ≥ col).
    Hessian,
}

/// One compared entry.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EntryCheck {
    /// The block.
    pub block: Block,
    /// Constraint row (Jacobian) or Hessian row; `None` for the gradient.
    pub row: Option<usize>,
    /// Variable index.
    pub col: usize,
    /// The function's name: "objective", the constraint's name, or "Lagrangian".
    pub name: String,
    /// The problem's value (0 for an entry outside the declared pattern).
    pub analytic: f64,
    /// The central-difference estimate.
    pub estimate: f64,
    /// e = |a − d| / max(1, |a|, |d|).
    pub error: f64,
    /// Whether the entry is in the declared pattern.
    pub in_pattern: bool,
}

/// Summary of one block.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct BlockCheck {
    /// Entries compared (pattern entries, plus failing ones outside the pattern).
    pub checked: usize,
    /// Entries with e above the tolerance.
    pub failed: usize,
    /// Largest e in the block.
    pub max_error: f64,
}

/// What a derivative check found. `Display` prints a short table; `Serialize` lets a module
/// put it in `result.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DerivativeReport {
    /// Variables.
    pub n: usize,
    /// Constraints.
    pub m: usize,
    /// The tolerance applied.
    pub tolerance: f64,
    /// Gradient summary.
    pub gradient: BlockCheck,
    /// Jacobian summary.
    pub jacobian: BlockCheck,
    /// Hessian summary, when the problem provides a Hessian.
    pub hessian: Option<BlockCheck>,
    /// Whether entries outside the Jacobian pattern were looked for.
    pub scanned_outside_pattern: bool,
    /// The worst entry of each function (objective, each constraint row, the Lagrangian's
    /// Hessian), sorted by decreasing error, ties by block, row and column.
    pub worst_per_function: Vec<EntryCheck>,
    /// Functions listed by `Display`.
    pub listed: usize,
    /// `eval` plus `eval_derivatives` calls spent by the check.
    pub evaluations: usize,
}

impl DerivativeReport {
    /// Whether no entry exceeds the tolerance.
    pub fn passed(&self) -> bool {
        self.failed() == 0
    }

    /// Entries above the tolerance, over all blocks.
    pub fn failed(&self) -> usize {
        self.blocks().map(|(_, b)| b.failed).sum()
    }

    /// Largest error over all blocks.
    pub fn max_error(&self) -> f64 {
        self.blocks().map(|(_, b)| b.max_error).fold(0.0, f64::max)
    }

    fn blocks(&self) -> impl Iterator<Item = (&'static str, &BlockCheck)> {
        [
            ("gradient", Some(&self.gradient)),
            ("jacobian", Some(&self.jacobian)),
        ]
        .into_iter()
        .chain(std::iter::once(("hessian", self.hessian.as_ref())))
        .filter_map(|(name, b)| b.map(|b| (name, b)))
    }
}

impl fmt::Display for DerivativeReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "derivative check: n = {}, m = {}, central differences, error = |a - d| / max(1, |a|, |d|)",
            self.n, self.m
        )?;
        writeln!(
            f,
            "  {:<10} {:>9} {:>8} {:>11}",
            "block", "checked", "failed", "max error"
        )?;
        for (name, b) in self.blocks() {
            writeln!(
                f,
                "  {:<10} {:>9} {:>8} {:>11.3e}",
                name, b.checked, b.failed, b.max_error
            )?;
        }
        let listed = self.worst_per_function.iter().take(self.listed);
        if self.listed > 0 && !self.worst_per_function.is_empty() {
            writeln!(
                f,
                "  {:<24} {:>8} {:>13} {:>13} {:>10}",
                "worst entry of", "variable", "analytic", "difference", "error"
            )?;
            for e in listed {
                let function = match (e.block, e.row) {
                    (Block::Hessian, Some(r)) => format!("Hessian (row {r})"),
                    (_, Some(r)) => format!("{} (row {r})", e.name),
                    (_, None) => e.name.clone(),
                };
                let note = if e.in_pattern {
                    ""
                } else {
                    "  outside pattern"
                };
                writeln!(
                    f,
                    "  {:<24} {:>8} {:>13.6e} {:>13.6e} {:>10.3e}{}",
                    function,
                    format!("x[{}]", e.col),
                    e.analytic,
                    e.estimate,
                    e.error,
                    note
                )?;
            }
        }
        if self.passed() {
            write!(
                f,
                "passed: every entry within {:.1e} (max error {:.3e})",
                self.tolerance,
                self.max_error()
            )
        } else {
            write!(
                f,
                "FAILED: {} entries exceed {:.1e} (max error {:.3e})",
                self.failed(),
                self.tolerance,
                self.max_error()
            )
        }
    }
}

/// e = |a − d| / max(1, |a|, |d|); NaN on either side counts as an infinite error.
pub fn relative_error(analytic: f64, estimate: f64) -> f64 {
    let e = (analytic - estimate).abs() / 1f64.max(analytic.abs()).max(estimate.abs());
    if e.is_nan() { f64::INFINITY } else { e }
}

/// Problem data gathered once for a check.
struct Setup {
    n: usize,
    m: usize,
    xl: Vec<f64>,
    xu: Vec<f64>,
    rows: Vec<usize>,
    cols: Vec<usize>,
}

impl Setup {
    fn new(nlp: &dyn Nlp) -> Self {
        let d = nlp.dims();
        let mut xl = vec![0.0; d.n];
        let mut xu = vec![0.0; d.n];
        let mut cl = vec![0.0; d.m];
        let mut cu = vec![0.0; d.m];
        nlp.bounds(&mut xl, &mut xu, &mut cl, &mut cu);
        let mut rows = vec![0; d.jac_nnz];
        let mut cols = vec![0; d.jac_nnz];
        nlp.jacobian_structure(&mut rows, &mut cols);
        Setup {
            n: d.n,
            m: d.m,
            xl,
            xu,
            rows,
            cols,
        }
    }

    fn stencil(&self, options: &FiniteDifferenceOptions, x: &[f64], j: usize) -> Stencil {
        let h = options.interval(DifferenceScheme::Central, x[j]);
        Stencil::choose(DifferenceScheme::Central, x[j], self.xl[j], self.xu[j], h)
    }

    /// Analytic Jacobian with duplicates summed, keyed by (row, col).
    fn summed(&self, values: &[f64]) -> BTreeMap<(usize, usize), f64> {
        let mut map = BTreeMap::new();
        for ((&r, &c), &v) in self.rows.iter().zip(&self.cols).zip(values) {
            *map.entry((r, c)).or_insert(0.0) += v;
        }
        map
    }
}

/// Compares the derivatives of `nlp` at `x` with central differences (see the module header).
/// Errors from the problem's functions at `x` or at a perturbed point are returned.
pub fn check_derivatives(
    nlp: &dyn Nlp,
    x: &[f64],
    options: &CheckOptions,
) -> Result<DerivativeReport, EvalError> {
    let setup = Setup::new(nlp);
    let dims = nlp.dims();
    let mut grad = vec![0.0; setup.n];
    let mut jac = vec![0.0; dims.jac_nnz];
    nlp.eval_derivatives(x, &mut grad, &mut jac)?;
    let analytic = setup.summed(&jac);

    let scan = setup.n <= options.scan_limit;
    let (entries, mut evaluations) = if scan {
        scan_columns(nlp, &setup, x, options, &grad, &analytic)?
    } else {
        grouped_columns(nlp, &setup, x, options, &grad, &analytic)?
    };
    evaluations += 1;
    let (gradient_entries, jacobian_entries): (Vec<_>, Vec<_>) = entries
        .into_iter()
        .partition(|e| e.block == Block::Gradient);

    let mut hessian_entries = Vec::new();
    let hessian = if dims.hess_nnz > 0 {
        let (entries, count) = hessian_entries_at(nlp, &setup, x, options, scan)?;
        evaluations += count;
        hessian_entries = entries;
        Some(summarize(&hessian_entries, options.tolerance))
    } else {
        None
    };

    let gradient = summarize(&gradient_entries, options.tolerance);
    let jacobian = summarize(&jacobian_entries, options.tolerance);
    let mut worst: BTreeMap<(Block, Option<usize>), EntryCheck> = BTreeMap::new();
    for e in gradient_entries
        .into_iter()
        .chain(jacobian_entries)
        .chain(hessian_entries)
    {
        // All Hessian entries belong to one function, the Lagrangian.
        let key = match e.block {
            Block::Hessian => (Block::Hessian, None),
            b => (b, e.row),
        };
        match worst.get(&key) {
            Some(w) if w.error >= e.error => {}
            _ => {
                worst.insert(key, e);
            }
        }
    }
    let mut worst_per_function: Vec<EntryCheck> = worst.into_values().collect();
    worst_per_function.sort_by(|a, b| {
        b.error
            .total_cmp(&a.error)
            .then((a.block, a.row, a.col).cmp(&(b.block, b.row, b.col)))
    });
    Ok(DerivativeReport {
        n: setup.n,
        m: setup.m,
        tolerance: options.tolerance,
        gradient,
        jacobian,
        hessian,
        scanned_outside_pattern: scan,
        worst_per_function,
        listed: options.listed,
        evaluations,
    })
}

fn summarize(entries: &[EntryCheck], tolerance: f64) -> BlockCheck {
    BlockCheck {
        checked: entries.len(),
        failed: entries.iter().filter(|e| e.error > tolerance).count(),
        max_error: entries.iter().map(|e| e.error).fold(0.0, f64::max),
    }
}

fn entry(
    nlp: &dyn Nlp,
    block: Block,
    row: Option<usize>,
    col: usize,
    analytic: f64,
    estimate: f64,
    in_pattern: bool,
) -> EntryCheck {
    let name = match (block, row) {
        (Block::Gradient, _) => "objective".to_string(),
        (Block::Jacobian, Some(r)) => nlp.constraint_name(r),
        _ => "Lagrangian".to_string(),
    };
    EntryCheck {
        block,
        row,
        col,
        name,
        analytic,
        estimate,
        error: relative_error(analytic, estimate),
        in_pattern,
    }
}

/// Function values at x + offset·e_j.
fn eval_moved(
    nlp: &dyn Nlp,
    x: &[f64],
    j: usize,
    offset: f64,
    m: usize,
) -> Result<(f64, Vec<f64>), EvalError> {
    let mut moved = x.to_vec();
    moved[j] = x[j] + offset;
    let mut f = 0.0;
    let mut c = vec![0.0; m];
    nlp.eval(&moved, &mut f, &mut c)?;
    Ok((f, c))
}

/// Column-by-column central differences: every pattern entry, plus failing entries outside it.
fn scan_columns(
    nlp: &dyn Nlp,
    setup: &Setup,
    x: &[f64],
    options: &CheckOptions,
    grad: &[f64],
    analytic: &BTreeMap<(usize, usize), f64>,
) -> Result<(Vec<EntryCheck>, usize), EvalError> {
    let m = setup.m;
    let mut f0 = 0.0;
    let mut c0 = vec![0.0; m];
    nlp.eval(x, &mut f0, &mut c0)?;
    let mut by_col: Vec<Vec<(usize, f64)>> = vec![Vec::new(); setup.n];
    for (&(r, c), &v) in analytic {
        by_col[c].push((r, v));
    }
    let columns: Vec<Result<(Vec<EntryCheck>, usize), EvalError>> = (0..setup.n)
        .into_par_iter()
        .map(|j| {
            let s = setup.stencil(&options.differences, x, j);
            let (a, b) = s.offsets();
            let (fa, ca) = eval_moved(nlp, x, j, a, m)?;
            let (fb, cb) = match b {
                Some(b) => eval_moved(nlp, x, j, b, m)?,
                None => (f0, c0.clone()),
            };
            let mut out = vec![entry(
                nlp,
                Block::Gradient,
                None,
                j,
                grad[j],
                s.derivative(f0, fa, fb),
                true,
            )];
            let mut declared = by_col[j].iter().peekable();
            for r in 0..m {
                let d = s.derivative(c0[r], ca[r], cb[r]);
                match declared.peek() {
                    Some(&&(row, v)) if row == r => {
                        declared.next();
                        out.push(entry(nlp, Block::Jacobian, Some(r), j, v, d, true));
                    }
                    _ if relative_error(0.0, d) > options.tolerance => {
                        out.push(entry(nlp, Block::Jacobian, Some(r), j, 0.0, d, false));
                    }
                    _ => {}
                }
            }
            Ok((out, 1 + usize::from(b.is_some())))
        })
        .collect();
    let mut entries = Vec::new();
    let mut evaluations = 1;
    for column in columns {
        let (mut e, count) = column?;
        entries.append(&mut e);
        evaluations += count;
    }
    Ok((entries, evaluations))
}

/// Grouped central differences: pattern entries only.
fn grouped_columns(
    nlp: &dyn Nlp,
    setup: &Setup,
    x: &[f64],
    options: &CheckOptions,
    grad: &[f64],
    analytic: &BTreeMap<(usize, usize), f64>,
) -> Result<(Vec<EntryCheck>, usize), EvalError> {
    let differences = FiniteDifferences::new(nlp, options.differences);
    let mut fd_grad = vec![0.0; setup.n];
    let mut fd_jac = vec![0.0; setup.rows.len()];
    let evaluations =
        differences.evaluate(nlp, x, DifferenceScheme::Central, &mut fd_grad, &mut fd_jac)?;
    let estimate = setup.summed(&fd_jac);
    let mut entries: Vec<EntryCheck> = (0..setup.n)
        .map(|j| entry(nlp, Block::Gradient, None, j, grad[j], fd_grad[j], true))
        .collect();
    for (&(r, c), &v) in analytic {
        entries.push(entry(
            nlp,
            Block::Jacobian,
            Some(r),
            c,
            v,
            estimate[&(r, c)],
            true,
        ));
    }
    Ok((entries, evaluations))
}

/// Default multipliers for the Hessian check: nonzero, alternating, not all equal.
fn default_lambda(m: usize) -> Vec<f64> {
    (0..m)
        .map(|i| {
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            sign * (1.0 + (i % 3) as f64 / 2.0)
        })
        .collect()
}

/// ∇L = ∇f + Jᵀλ at x.
fn lagrangian_gradient(
    nlp: &dyn Nlp,
    setup: &Setup,
    x: &[f64],
    lambda: &[f64],
) -> Result<Vec<f64>, EvalError> {
    let mut g = vec![0.0; setup.n];
    let mut jac = vec![0.0; setup.rows.len()];
    nlp.eval_derivatives(x, &mut g, &mut jac)?;
    for ((&r, &c), &v) in setup.rows.iter().zip(&setup.cols).zip(&jac) {
        g[c] += lambda[r] * v;
    }
    Ok(g)
}

/// Lower-triangle Hessian entries against central differences of ∇L.
fn hessian_entries_at(
    nlp: &dyn Nlp,
    setup: &Setup,
    x: &[f64],
    options: &CheckOptions,
    scan: bool,
) -> Result<(Vec<EntryCheck>, usize), EvalError> {
    let dims = nlp.dims();
    let lambda = options
        .lambda
        .clone()
        .unwrap_or_else(|| default_lambda(setup.m));
    let mut rows = vec![0; dims.hess_nnz];
    let mut cols = vec![0; dims.hess_nnz];
    nlp.hessian_structure(&mut rows, &mut cols);
    let mut values = vec![0.0; dims.hess_nnz];
    nlp.eval_hessian(x, 1.0, &lambda, &mut values)?;
    let mut analytic: BTreeMap<(usize, usize), f64> = BTreeMap::new();
    for ((&r, &c), &v) in rows.iter().zip(&cols).zip(&values) {
        // Store in the lower triangle whatever triangle the problem used.
        *analytic.entry((r.max(c), r.min(c))).or_insert(0.0) += v;
    }
    let mut by_col: Vec<Vec<(usize, f64)>> = vec![Vec::new(); setup.n];
    for (&(r, c), &v) in &analytic {
        by_col[c].push((r, v));
    }
    // One column per group when scanning; otherwise columns grouped so that no row of the
    // symmetric pattern meets two columns of a group.
    let groups = if scan {
        ColumnGroups::singletons(setup.n)
    } else {
        let mut pattern: Vec<Vec<usize>> = vec![Vec::new(); setup.n];
        for &(r, c) in analytic.keys() {
            pattern[r].push(c);
            if r != c {
                pattern[c].push(r);
            }
        }
        ColumnGroups::greedy(setup.n, &pattern)
    };
    let g0 = lagrangian_gradient(nlp, setup, x, &lambda)?;
    let columns: Vec<Result<(Vec<EntryCheck>, usize), EvalError>> = groups
        .groups()
        .par_iter()
        .map(|group| {
            let stencils: Vec<Stencil> = group
                .iter()
                .map(|&j| setup.stencil(&options.differences, x, j))
                .collect();
            let mut xa = x.to_vec();
            let mut xb = x.to_vec();
            let mut second = false;
            for (&j, s) in group.iter().zip(&stencils) {
                let (a, b) = s.offsets();
                xa[j] = x[j] + a;
                if let Some(b) = b {
                    xb[j] = x[j] + b;
                    second = true;
                }
            }
            let ga = lagrangian_gradient(nlp, setup, &xa, &lambda)?;
            let gb = if second {
                lagrangian_gradient(nlp, setup, &xb, &lambda)?
            } else {
                g0.clone()
            };
            let mut out = Vec::new();
            for (&j, s) in group.iter().zip(&stencils) {
                let mut declared = by_col[j].iter().peekable();
                let rows: Box<dyn Iterator<Item = usize>> = if scan {
                    Box::new(j..setup.n)
                } else {
                    Box::new(by_col[j].iter().map(|&(r, _)| r))
                };
                for r in rows {
                    let d = s.derivative(g0[r], ga[r], gb[r]);
                    match declared.peek() {
                        Some(&&(row, v)) if row == r => {
                            declared.next();
                            out.push(entry(nlp, Block::Hessian, Some(r), j, v, d, true));
                        }
                        _ if relative_error(0.0, d) > options.tolerance => {
                            out.push(entry(nlp, Block::Hessian, Some(r), j, 0.0, d, false));
                        }
                        _ => {}
                    }
                }
            }
            Ok((out, 1 + usize::from(second)))
        })
        .collect();
    let mut entries = Vec::new();
    let mut evaluations = 1;
    for column in columns {
        let (mut e, count) = column?;
        entries.append(&mut e);
        evaluations += count;
    }
    Ok((entries, evaluations))
}
