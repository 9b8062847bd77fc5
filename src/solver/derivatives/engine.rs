//! Finite-difference gradient and sparse Jacobian of an [`Nlp`] from its `eval` alone.
//!
//! Column j of the Jacobian and entry j of the gradient are estimated from evaluations at x
//! and at x + a·e_j (forward) or x + a·e_j, x + b·e_j (central; see [`super::interval`] for
//! the stencils and intervals). Columns of one [`ColumnGroups`] group are perturbed together:
//! no row depends on two of them, so each row's difference belongs to one column. The gradient
//! row takes part in the grouping only when the objective's dependence is declared sparse
//! ([`FiniteDifferences::with_objective_pattern`]); otherwise every column is its own group.
//!
//! Cost per call: 1 + g evaluations (forward) or 1 + 2g (central) for g groups. Groups are
//! evaluated in parallel with rayon; each entry comes from its own group's evaluations only and
//! is scattered in a fixed order, so the result is bit-identical for any number of threads.

use rayon::prelude::*;

use super::coloring::ColumnGroups;
use super::interval::{DifferenceScheme, FiniteDifferenceOptions, Stencil};
use crate::solver::{EvalError, Nlp};

/// Finite differences for one problem: its pattern, bounds and column groups, computed once.
#[derive(Debug, Clone)]
pub struct FiniteDifferences {
    m: usize,
    xl: Vec<f64>,
    xu: Vec<f64>,
    /// `col_ptr[j]..col_ptr[j+1]` indexes `entries` for column j.
    col_ptr: Vec<usize>,
    /// (position in the Jacobian value array, row); a duplicate (row, col) pair is listed once,
    /// its other positions are in `duplicates`.
    entries: Vec<(usize, usize)>,
    /// Positions of repeated (row, col) pairs: set to zero so that the sum is the derivative.
    duplicates: Vec<usize>,
    /// Whether the objective depends on x_j.
    objective: Vec<bool>,
    groups: ColumnGroups,
    options: FiniteDifferenceOptions,
}

/// Derivative entries computed from one group's evaluations.
struct GroupEntries {
    gradient: Vec<(usize, f64)>,
    jacobian: Vec<(usize, f64)>,
    evaluations: usize,
}

impl FiniteDifferences {
    /// Finite differences for `nlp`, whose objective is taken to depend on every variable (so
    /// the gradient needs one perturbation per variable).
    pub fn new(nlp: &dyn Nlp, options: FiniteDifferenceOptions) -> Self {
        let n = nlp.dims().n;
        Self::build(nlp, options, vec![true; n])
    }

    /// Finite differences for `nlp` whose objective depends only on the variables
    /// `objective_columns`, so that columns can share perturbations in the gradient too.
    pub fn with_objective_pattern(
        nlp: &dyn Nlp,
        options: FiniteDifferenceOptions,
        objective_columns: &[usize],
    ) -> Self {
        let mut objective = vec![false; nlp.dims().n];
        for &j in objective_columns {
            objective[j] = true;
        }
        Self::build(nlp, options, objective)
    }

    fn build(nlp: &dyn Nlp, options: FiniteDifferenceOptions, objective: Vec<bool>) -> Self {
        let dims = nlp.dims();
        let (n, m) = (dims.n, dims.m);
        let mut xl = vec![0.0; n];
        let mut xu = vec![0.0; n];
        let mut cl = vec![0.0; m];
        let mut cu = vec![0.0; m];
        nlp.bounds(&mut xl, &mut xu, &mut cl, &mut cu);
        let mut rows = vec![0; dims.jac_nnz];
        let mut cols = vec![0; dims.jac_nnz];
        nlp.jacobian_structure(&mut rows, &mut cols);

        // Entries sorted by (col, row, position); repeats of a (row, col) pair are duplicates.
        let mut order: Vec<usize> = (0..dims.jac_nnz).collect();
        order.sort_by_key(|&k| (cols[k], rows[k], k));
        let mut col_ptr = vec![0; n + 1];
        let mut entries = Vec::with_capacity(order.len());
        let mut duplicates = Vec::new();
        let mut previous = None;
        for &k in &order {
            if previous == Some((rows[k], cols[k])) {
                duplicates.push(k);
                continue;
            }
            previous = Some((rows[k], cols[k]));
            entries.push((k, rows[k]));
            col_ptr[cols[k] + 1] += 1;
        }
        for j in 0..n {
            col_ptr[j + 1] += col_ptr[j];
        }

        let dense_objective = objective.iter().all(|&o| o);
        let groups = if dense_objective {
            ColumnGroups::singletons(n)
        } else {
            let mut pattern: Vec<Vec<usize>> = vec![Vec::new(); m + 1];
            for (&r, &c) in rows.iter().zip(&cols) {
                pattern[r].push(c);
            }
            pattern[m] = (0..n).filter(|&j| objective[j]).collect();
            ColumnGroups::greedy(n, &pattern)
        };
        FiniteDifferences {
            m,
            xl,
            xu,
            col_ptr,
            entries,
            duplicates,
            objective,
            groups,
            options,
        }
    }

    /// The column groups (one perturbation each per difference).
    pub fn groups(&self) -> &ColumnGroups {
        &self.groups
    }

    /// The options in use.
    pub fn options(&self) -> &FiniteDifferenceOptions {
        &self.options
    }

    /// Estimates the gradient (length n) and Jacobian values (length `jac_nnz`, pattern order)
    /// of `nlp` at `x` with `scheme`. Returns the number of `eval` calls made. An evaluation
    /// error at a perturbed point is returned as is (the first one in group order).
    pub fn evaluate(
        &self,
        nlp: &dyn Nlp,
        x: &[f64],
        scheme: DifferenceScheme,
        grad: &mut [f64],
        jac: &mut [f64],
    ) -> Result<usize, EvalError> {
        let mut f0 = 0.0;
        let mut c0 = vec![0.0; self.m];
        nlp.eval(x, &mut f0, &mut c0)?;
        let results: Vec<Result<GroupEntries, EvalError>> = self
            .groups
            .groups()
            .par_iter()
            .map(|group| self.group_entries(nlp, x, f0, &c0, group, scheme))
            .collect();
        grad.fill(0.0);
        jac.fill(0.0);
        let mut evaluations = 1;
        for result in results {
            let entries = result?;
            evaluations += entries.evaluations;
            for (j, v) in entries.gradient {
                grad[j] = v;
            }
            for (k, v) in entries.jacobian {
                jac[k] = v;
            }
        }
        for &k in &self.duplicates {
            jac[k] = 0.0;
        }
        Ok(evaluations)
    }

    /// Evaluations and derivative entries for one group of columns.
    fn group_entries(
        &self,
        nlp: &dyn Nlp,
        x: &[f64],
        f0: f64,
        c0: &[f64],
        group: &[usize],
        scheme: DifferenceScheme,
    ) -> Result<GroupEntries, EvalError> {
        let stencils: Vec<Stencil> = group
            .iter()
            .map(|&j| {
                let h = self.options.interval(scheme, x[j]);
                Stencil::choose(scheme, x[j], self.xl[j], self.xu[j], h)
            })
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
        let mut fa = 0.0;
        let mut ca = vec![0.0; self.m];
        nlp.eval(&xa, &mut fa, &mut ca)?;
        let mut fb = f0;
        let mut cb = c0.to_vec();
        if second {
            nlp.eval(&xb, &mut fb, &mut cb)?;
        }
        let mut gradient = Vec::new();
        let mut jacobian = Vec::new();
        for (&j, s) in group.iter().zip(&stencils) {
            if self.objective[j] {
                gradient.push((j, s.derivative(f0, fa, fb)));
            }
            for &(k, r) in &self.entries[self.col_ptr[j]..self.col_ptr[j + 1]] {
                jacobian.push((k, s.derivative(c0[r], ca[r], cb[r])));
            }
        }
        Ok(GroupEntries {
            gradient,
            jacobian,
            evaluations: 1 + usize::from(second),
        })
    }
}
