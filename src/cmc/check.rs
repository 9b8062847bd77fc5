//! Derivative check: an [`Nlp`]'s gradient and Jacobian against central differences.
//!
//! For each checked column j: `(F(x + h e_j) − F(x − h e_j)) / 2h` for the objective and every
//! constraint, compared with the analytic values; the error of an entry is
//! `|analytic − difference| / max(1, |difference|)` (the NLP is scaled to order one). Points are
//! moved randomly first by a tiny amount, because the mixed-area rule (Meyer et al. 2002) has a
//! kink at right angles, which grid-made start meshes contain exactly. An entry whose forward
//! and backward differences disagree by more than [`KINK`] (relative) straddles such a kink:
//! it is counted in [`DerivativeCheck::kinks`] and re-checked with a step 100× smaller; if that
//! one straddles the kink too, agreement with the nearer one-sided difference to [`KINK`]
//! accuracy is accepted.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::solver::{EvalError, Nlp};

/// The outcome of a derivative check.
#[derive(Debug, Clone, PartialEq)]
pub struct DerivativeCheck {
    /// Largest entry error (see the module header).
    pub max_error: f64,
    /// Where it occurred, e.g. "∂c[12]/∂x[40]".
    pub worst: String,
    /// Columns checked.
    pub columns: usize,
    /// Entries compared.
    pub entries: usize,
    /// Entries that straddled a kink (compared with one-sided differences).
    pub kinks: usize,
}

/// Relative disagreement of one-sided differences that marks a kink, and the accuracy then
/// required of the analytic derivative against the nearer one-sided difference.
pub const KINK: f64 = 1e-4;

/// The NLP's start point moved by uniform random offsets of at most `amount` per variable.
pub fn jittered_start(nlp: &dyn Nlp, amount: f64, seed: u64) -> Vec<f64> {
    let mut x = vec![0.0; nlp.dims().n];
    nlp.start(&mut x);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for v in &mut x {
        *v += amount * (2.0 * rng.random::<f64>() - 1.0);
    }
    x
}

/// `count` column indices spread evenly over `0..n` (all of them when `count ≥ n`).
pub fn spread_columns(n: usize, count: usize) -> Vec<usize> {
    if count >= n {
        return (0..n).collect();
    }
    let mut cols: Vec<usize> = (0..count).map(|i| i * n / count).collect();
    cols.dedup();
    cols
}

/// Compares derivatives at `x` on the given columns with central differences of step `step`.
pub fn check_derivatives(
    nlp: &dyn Nlp,
    x: &[f64],
    columns: &[usize],
    step: f64,
) -> Result<DerivativeCheck, EvalError> {
    let dims = nlp.dims();
    let mut grad = vec![0.0; dims.n];
    let mut jac = vec![0.0; dims.jac_nnz];
    nlp.eval_derivatives(x, &mut grad, &mut jac)?;
    let mut rows = vec![0; dims.jac_nnz];
    let mut cols = vec![0; dims.jac_nnz];
    nlp.jacobian_structure(&mut rows, &mut cols);
    let mut by_column: Vec<Vec<usize>> = vec![Vec::new(); dims.n];
    for (k, &c) in cols.iter().enumerate() {
        by_column[c].push(k);
    }
    let mut report = DerivativeCheck {
        max_error: 0.0,
        worst: String::new(),
        columns: columns.len(),
        entries: 0,
        kinks: 0,
    };
    let mut base = vec![0.0; dims.m + 1];
    {
        let (f, c) = base.split_at_mut(1);
        nlp.eval(x, &mut f[0], c)?;
    }
    let mut xp = x.to_vec();
    // Objective and constraints at x ± h along column j, as [f, c…].
    let mut side = |j: usize, h: f64| -> Result<(Vec<f64>, Vec<f64>), EvalError> {
        let mut out = [vec![0.0; dims.m + 1], vec![0.0; dims.m + 1]];
        for (values, delta) in out.iter_mut().zip([h, -h]) {
            xp[j] = x[j] + delta;
            let (f, c) = values.split_at_mut(1);
            nlp.eval(&xp, &mut f[0], c)?;
        }
        xp[j] = x[j];
        let [plus, minus] = out;
        Ok((plus, minus))
    };
    for &j in columns {
        let mut analytic = vec![0.0; dims.m + 1];
        analytic[0] = grad[j];
        for &k in &by_column[j] {
            analytic[rows[k] + 1] += jac[k];
        }
        let (plus, minus) = side(j, step)?;
        let mut fine: Option<(Vec<f64>, Vec<f64>)> = None;
        for i in 0..=dims.m {
            let exact = analytic[i];
            let judge = |plus: f64, minus: f64, h: f64| {
                let central = (plus - minus) / (2.0 * h);
                let (forward, backward) = ((plus - base[i]) / h, (base[i] - minus) / h);
                let scale = central.abs().max(1.0);
                let error = (exact - central).abs() / scale;
                let kink = (forward - backward).abs() / scale > KINK;
                let one_sided = (exact - forward).abs().min((exact - backward).abs()) / scale;
                (error, kink, one_sided)
            };
            let (mut e, kink, _) = judge(plus[i], minus[i], step);
            if kink {
                // Retry with a step 100× smaller, which rarely straddles the same kink.
                report.kinks += 1;
                if fine.is_none() {
                    fine = Some(side(j, step / 100.0)?);
                }
                let (fp, fm) = fine.as_ref().map_or((0.0, 0.0), |(p, m)| (p[i], m[i]));
                let (e_fine, still_kink, one_sided) = judge(fp, fm, step / 100.0);
                e = e.min(e_fine);
                if still_kink && one_sided < KINK {
                    e = 0.0;
                }
            }
            report.entries += 1;
            if e > report.max_error || !e.is_finite() {
                report.max_error = if e.is_finite() { e } else { f64::INFINITY };
                report.worst = if i == 0 {
                    format!("∂f/∂x[{j}]")
                } else {
                    format!("∂c[{}]/∂x[{j}] ({})", i - 1, nlp.constraint_name(i - 1))
                };
            }
        }
    }
    Ok(report)
}
