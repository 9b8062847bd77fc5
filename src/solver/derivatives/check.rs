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
//! Stencils respect the variable bounds (see [`super::interval`]), except for fixed variables
//! (xl = xu) and at points outside the bounds, where they are centred freely.
//!
//! Two refinements serve models whose functions are hard to difference, both off by default:
//! - Richardson extrapolation (`richardson`): `D = (4·D(h/2) − D(h))/3` cancels the h² term of
//!   the central difference D(h). Stiff simulations (ground contact) make plain central
//!   differences truncation-limited before they reach round-off.
//! - Kink detection (`kink_threshold = t`): where the forward and backward differences of a
//!   function disagree by more than t (relative), the stencil straddles a kink of a C⁰/C¹
//!   function (the mixed-area rule of Meyer et al. switches at right angles, which grid-made
//!   meshes contain exactly), or the function curves too strongly over it for the central
//!   difference to be trusted to t. Such an entry is re-estimated with steps 10× and 100× smaller; if
//!   the finest stencil straddles the kink too, either one-sided difference is accepted. Every
//!   admissible estimate is compared and the closest one counts; the report says how many
//!   entries straddled a kink.
//!
//! `columns` restricts the check to listed variables (for meshes with many thousands of
//! variables, a spread sample: [`spread_columns`]), differenced one by one; [`jittered_start`]
//! moves the start point off exact symmetries first.

use std::collections::BTreeMap;
use std::fmt;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
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
    /// Only these variables are checked (one by one, entries outside the pattern included);
    /// default `None`, meaning all (grouped above `scan_limit`).
    pub columns: Option<Vec<usize>>,
    /// Richardson-extrapolate the central differences (see the module header); default false.
    pub richardson: bool,
    /// Relative forward/backward disagreement that marks a kink (see the module header);
    /// default `None`: no kink handling.
    pub kink_threshold: Option<f64>,
}

impl Default for CheckOptions {
    fn default() -> Self {
        CheckOptions {
            tolerance: 1e-5,
            differences: FiniteDifferenceOptions::default(),
            scan_limit: 2000,
            lambda: None,
            listed: 10,
            columns: None,
            richardson: false,
            kink_threshold: None,
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
    /// Variables checked.
    pub columns: usize,
    /// Entries whose stencil straddled a kink (only with `kink_threshold`).
    pub kinks: usize,
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
        if self.columns < self.n {
            writeln!(f, "  {} of {} variables checked", self.columns, self.n)?;
        }
        if self.kinks > 0 {
            writeln!(
                f,
                "  {} entries straddled a kink (judged by their best admissible estimate)",
                self.kinks
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

    /// The bounds stencils of variable j must respect at the value `xj`: its bounds, or none
    /// when it is fixed (xl = xu: its derivatives are part of the model even where the solver
    /// cannot move it) or `xj` lies outside them (the functions are evidently defined there).
    fn limits(&self, j: usize, xj: f64) -> (f64, f64) {
        let (lo, hi) = (self.xl[j], self.xu[j]);
        if lo == hi || xj < lo || xj > hi {
            (f64::NEG_INFINITY, f64::INFINITY)
        } else {
            (lo, hi)
        }
    }

    fn stencil(&self, options: &FiniteDifferenceOptions, x: &[f64], j: usize) -> Stencil {
        let h = options.interval(DifferenceScheme::Central, x[j]);
        let (lo, hi) = self.limits(j, x[j]);
        Stencil::choose(DifferenceScheme::Central, x[j], lo, hi, h)
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
/// Errors from the problem's functions at `x` or at a perturbed point are returned; a listed
/// column outside `0..n` is a [`EvalError::Fatal`].
pub fn check_derivatives(
    nlp: &dyn Nlp,
    x: &[f64],
    options: &CheckOptions,
) -> Result<DerivativeReport, EvalError> {
    let setup = Setup::new(nlp);
    let dims = nlp.dims();
    if let Some(&j) = options.columns.iter().flatten().find(|&&j| j >= setup.n) {
        return Err(EvalError::Fatal(format!(
            "derivative check: variable {j} listed, but n = {}",
            setup.n
        )));
    }
    let mut grad = vec![0.0; setup.n];
    let mut jac = vec![0.0; dims.jac_nnz];
    nlp.eval_derivatives(x, &mut grad, &mut jac)?;
    let analytic = setup.summed(&jac);

    let scan = options.columns.is_some() || setup.n <= options.scan_limit;
    let columns: Vec<usize> = match &options.columns {
        Some(list) => list.clone(),
        None => (0..setup.n).collect(),
    };
    let (entries, mut evaluations, mut kinks) = if scan {
        scan_columns(nlp, &setup, x, options, &grad, &analytic, &columns)?
    } else {
        let (entries, evaluations) = grouped_columns(nlp, &setup, x, options, &grad, &analytic)?;
        (entries, evaluations, 0)
    };
    evaluations += 1;
    let (gradient_entries, jacobian_entries): (Vec<_>, Vec<_>) = entries
        .into_iter()
        .partition(|e| e.block == Block::Gradient);

    let mut hessian_entries = Vec::new();
    let hessian = if dims.hess_nnz > 0 {
        let scanned = scan.then_some(columns.as_slice());
        let (entries, count, kinked) = hessian_entries_at(nlp, &setup, x, options, scanned)?;
        evaluations += count;
        kinks += kinked;
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
        columns: columns.len(),
        kinks,
    })
}

/// The NLP's start point moved by uniform random offsets of at most `amount` per variable
/// (units of x), seeded: a check point off the exact symmetries of generated starts.
pub fn jittered_start(nlp: &dyn Nlp, amount: f64, seed: u64) -> Vec<f64> {
    let mut x = vec![0.0; nlp.dims().n];
    nlp.start(&mut x);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for v in &mut x {
        *v += amount * (2.0 * rng.random::<f64>() - 1.0);
    }
    x
}

/// `count` variable indices spread evenly over `0..n` (all of them when `count ≥ n`).
pub fn spread_columns(n: usize, count: usize) -> Vec<usize> {
    if count >= n {
        return (0..n).collect();
    }
    let mut cols: Vec<usize> = (0..count).map(|i| i * n / count).collect();
    cols.dedup();
    cols
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

/// Compared entries, evaluations spent and entries at kinks (of one column, or gathered).
type ColumnEntries = (Vec<EntryCheck>, usize, usize);

/// Objective and constraints at x, as `[f, c…]`.
fn values_at(nlp: &dyn Nlp, m: usize, x: &[f64]) -> Result<Vec<f64>, EvalError> {
    let mut v = vec![0.0; m + 1];
    let (f, c) = v.split_at_mut(1);
    nlp.eval(x, &mut f[0], c)?;
    Ok(v)
}

/// Difference estimates of a vector function F along one variable, refined as the options ask
/// (see the module header).
struct ColumnDifferences {
    /// Estimate per component: central (Richardson-extrapolated if asked), or the
    /// bound-respecting stencil's.
    estimate: Vec<f64>,
    /// Further admissible estimates of the components whose stencil straddled a kink.
    alternatives: BTreeMap<usize, Vec<f64>>,
    /// Evaluations of F spent.
    evaluations: usize,
}

impl ColumnDifferences {
    /// The admissible estimate of component `i` closest to `analytic`.
    fn best(&self, i: usize, analytic: f64) -> f64 {
        let mut best = self.estimate[i];
        for &d in self.alternatives.get(&i).into_iter().flatten() {
            if relative_error(analytic, d) < relative_error(analytic, best) {
                best = d;
            }
        }
        best
    }
}

/// Differences of F (with F(x) = `f0`) along variable `j`.
fn column_differences<F>(
    eval: &F,
    setup: &Setup,
    x: &[f64],
    j: usize,
    f0: &[f64],
    options: &CheckOptions,
) -> Result<ColumnDifferences, EvalError>
where
    F: Fn(&[f64]) -> Result<Vec<f64>, EvalError>,
{
    let (lo, hi) = setup.limits(j, x[j]);
    let stencil = |h: f64| Stencil::choose(DifferenceScheme::Central, x[j], lo, hi, h);
    let moved = |offset: f64| {
        let mut p = x.to_vec();
        p[j] = x[j] + offset;
        eval(&p)
    };
    // F at the stencil's points (F(x) standing in for a missing second point).
    let sample = |s: Stencil| -> Result<(Vec<f64>, Vec<f64>, usize), EvalError> {
        let (a, b) = s.offsets();
        let fa = moved(a)?;
        match b {
            Some(b) => Ok((fa, moved(b)?, 2)),
            None => Ok((fa, f0.to_vec(), 1)),
        }
    };
    let derive = |s: Stencil, fa: &[f64], fb: &[f64]| -> Vec<f64> {
        (0..f0.len())
            .map(|i| s.derivative(f0[i], fa[i], fb[i]))
            .collect()
    };
    let h = options
        .differences
        .interval(DifferenceScheme::Central, x[j]);
    let s = stencil(h);
    let (fa, fb, mut evaluations) = sample(s)?;
    let mut estimate = derive(s, &fa, &fb);
    let mut alternatives = BTreeMap::new();
    let Stencil::Centered { a, b } = s else {
        return Ok(ColumnDifferences {
            estimate,
            alternatives,
            evaluations,
        });
    };
    if options.richardson
        && let half @ Stencil::Centered { .. } = stencil(h / 2.0)
    {
        let (ha, hb, count) = sample(half)?;
        evaluations += count;
        for (e, d) in estimate.iter_mut().zip(derive(half, &ha, &hb)) {
            *e = (4.0 * d - *e) / 3.0;
        }
    }
    if let Some(t) = options.kink_threshold {
        // Forward and backward differences of component i disagree: a kink inside the stencil.
        let straddles = |i: usize, fa: &[f64], fb: &[f64], a: f64, b: f64, central: f64| {
            let (forward, backward) = ((fa[i] - f0[i]) / a, (fb[i] - f0[i]) / b);
            (forward - backward).abs() / central.abs().max(1.0) > t
        };
        let kinked: Vec<usize> = (0..f0.len())
            .filter(|&i| straddles(i, &fa, &fb, a, b, estimate[i]))
            .collect();
        if !kinked.is_empty() {
            for shrink in [10.0, 100.0] {
                let fine = stencil(h / shrink);
                let (ga, gb, count) = sample(fine)?;
                evaluations += count;
                let fine_estimate = derive(fine, &ga, &gb);
                for &i in &kinked {
                    let admissible: &mut Vec<f64> = alternatives.entry(i).or_default();
                    admissible.push(fine_estimate[i]);
                    if let Stencil::Centered { a, b } = fine
                        && shrink == 100.0
                        && straddles(i, &ga, &gb, a, b, fine_estimate[i])
                    {
                        admissible.push((ga[i] - f0[i]) / a);
                        admissible.push((gb[i] - f0[i]) / b);
                    }
                }
            }
        }
    }
    Ok(ColumnDifferences {
        estimate,
        alternatives,
        evaluations,
    })
}

/// Column-by-column differences over `columns`: every pattern entry, plus failing entries
/// outside it. Returns the entries, the evaluations spent and the entries at kinks.
fn scan_columns(
    nlp: &dyn Nlp,
    setup: &Setup,
    x: &[f64],
    options: &CheckOptions,
    grad: &[f64],
    analytic: &BTreeMap<(usize, usize), f64>,
    columns: &[usize],
) -> Result<ColumnEntries, EvalError> {
    let m = setup.m;
    let f0 = values_at(nlp, m, x)?;
    let mut by_col: Vec<Vec<(usize, f64)>> = vec![Vec::new(); setup.n];
    for (&(r, c), &v) in analytic {
        by_col[c].push((r, v));
    }
    let eval = |p: &[f64]| values_at(nlp, m, p);
    let results: Vec<Result<ColumnEntries, EvalError>> = columns
        .par_iter()
        .map(|&j| {
            let d = column_differences(&eval, setup, x, j, &f0, options)?;
            let mut out = vec![entry(
                nlp,
                Block::Gradient,
                None,
                j,
                grad[j],
                d.best(0, grad[j]),
                true,
            )];
            compare_rows(
                nlp,
                Block::Jacobian,
                j,
                0..m,
                1,
                &by_col[j],
                &d,
                options,
                &mut out,
            );
            Ok((out, d.evaluations, d.alternatives.len()))
        })
        .collect();
    gather(results)
}

/// Compares column `j` of `block` over `rows`: every declared entry (`declared`, sorted by row),
/// and undeclared rows whose estimate exceeds the tolerance. Component `offset + r` of `d` is
/// row r's estimate.
#[allow(clippy::too_many_arguments)]
fn compare_rows(
    nlp: &dyn Nlp,
    block: Block,
    j: usize,
    rows: std::ops::Range<usize>,
    offset: usize,
    declared: &[(usize, f64)],
    d: &ColumnDifferences,
    options: &CheckOptions,
    out: &mut Vec<EntryCheck>,
) {
    let mut declared = declared.iter().peekable();
    for r in rows {
        match declared.peek() {
            Some(&&(row, v)) if row == r => {
                declared.next();
                out.push(entry(
                    nlp,
                    block,
                    Some(r),
                    j,
                    v,
                    d.best(offset + r, v),
                    true,
                ));
            }
            _ => {
                let estimate = d.best(offset + r, 0.0);
                if relative_error(0.0, estimate) > options.tolerance {
                    out.push(entry(nlp, block, Some(r), j, 0.0, estimate, false));
                }
            }
        }
    }
}

/// Concatenates per-column results: entries, evaluations (plus the one at x), kinks.
fn gather(results: Vec<Result<ColumnEntries, EvalError>>) -> Result<ColumnEntries, EvalError> {
    let mut entries = Vec::new();
    let (mut evaluations, mut kinks) = (1, 0);
    for result in results {
        let (mut e, count, kinked) = result?;
        entries.append(&mut e);
        evaluations += count;
        kinks += kinked;
    }
    Ok((entries, evaluations, kinks))
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

/// Lower-triangle Hessian entries against central differences of ∇L: column by column over
/// `scanned` (finding entries outside the pattern), or grouped by the symmetric pattern when
/// `None`. Returns the entries, the gradient evaluations spent and the entries at kinks.
fn hessian_entries_at(
    nlp: &dyn Nlp,
    setup: &Setup,
    x: &[f64],
    options: &CheckOptions,
    scanned: Option<&[usize]>,
) -> Result<ColumnEntries, EvalError> {
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
    let g0 = lagrangian_gradient(nlp, setup, x, &lambda)?;
    let Some(columns) = scanned else {
        return grouped_hessian(nlp, setup, x, options, &lambda, &analytic, &by_col, &g0);
    };
    let eval = |p: &[f64]| lagrangian_gradient(nlp, setup, p, &lambda);
    let results: Vec<Result<ColumnEntries, EvalError>> = columns
        .par_iter()
        .map(|&j| {
            let d = column_differences(&eval, setup, x, j, &g0, options)?;
            let mut out = Vec::new();
            compare_rows(
                nlp,
                Block::Hessian,
                j,
                j..setup.n,
                0,
                &by_col[j],
                &d,
                options,
                &mut out,
            );
            Ok((out, d.evaluations, d.alternatives.len()))
        })
        .collect();
    gather(results)
}

/// Hessian pattern entries from columns grouped so that no row of the symmetric pattern meets
/// two columns of a group (plain central differences).
#[allow(clippy::too_many_arguments)]
fn grouped_hessian(
    nlp: &dyn Nlp,
    setup: &Setup,
    x: &[f64],
    options: &CheckOptions,
    lambda: &[f64],
    analytic: &BTreeMap<(usize, usize), f64>,
    by_col: &[Vec<(usize, f64)>],
    g0: &[f64],
) -> Result<ColumnEntries, EvalError> {
    let mut pattern: Vec<Vec<usize>> = vec![Vec::new(); setup.n];
    for &(r, c) in analytic.keys() {
        pattern[r].push(c);
        if r != c {
            pattern[c].push(r);
        }
    }
    let groups = ColumnGroups::greedy(setup.n, &pattern);
    let results: Vec<Result<ColumnEntries, EvalError>> = groups
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
            let ga = lagrangian_gradient(nlp, setup, &xa, lambda)?;
            let gb = if second {
                lagrangian_gradient(nlp, setup, &xb, lambda)?
            } else {
                g0.to_vec()
            };
            let mut out = Vec::new();
            for (&j, s) in group.iter().zip(&stencils) {
                for &(r, v) in &by_col[j] {
                    let d = s.derivative(g0[r], ga[r], gb[r]);
                    out.push(entry(nlp, Block::Hessian, Some(r), j, v, d, true));
                }
            }
            Ok((out, 1 + usize::from(second), 0))
        })
        .collect();
    gather(results)
}
