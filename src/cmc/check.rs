//! Derivative check: an [`Nlp`]'s gradient and Jacobian against central differences.
//!
//! For each checked column j: `(F(x + h e_j) − F(x − h e_j)) / 2h` for the objective and every
//! constraint, compared with the analytic values; the error of an entry is
//! `|analytic − difference| / max(1, |difference|)` (the NLP is scaled to order one). Points are
//! moved randomly first by a tiny amount, because the mixed-area rule (Meyer et al. 2002) has a
//! kink at right angles, which grid-made start meshes contain exactly. An entry whose forward
//! and backward differences disagree by more than [`KINK`] (relative) straddles such a kink:
//! it is counted in [`DerivativeCheck::kinks`], and agreement with the nearer one-sided difference
//! to [`KINK`] accuracy is accepted too.

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
    let mut f0 = 0.0;
    let mut c0 = vec![0.0; dims.m];
    nlp.eval(x, &mut f0, &mut c0)?;
    let (mut cp, mut cm) = (vec![0.0; dims.m], vec![0.0; dims.m]);
    let mut xp = x.to_vec();
    for &j in columns {
        let (mut fp, mut fm) = (0.0, 0.0);
        xp[j] = x[j] + step;
        nlp.eval(&xp, &mut fp, &mut cp)?;
        xp[j] = x[j] - step;
        nlp.eval(&xp, &mut fm, &mut cm)?;
        xp[j] = x[j];
        let mut analytic = vec![0.0; dims.m];
        for &k in &by_column[j] {
            analytic[rows[k]] += jac[k];
        }
        let mut compare = |exact: f64, (plus, base, minus): (f64, f64, f64), what: String| {
            let fd = (plus - minus) / (2.0 * step);
            let (forward, backward) = ((plus - base) / step, (base - minus) / step);
            let scale = fd.abs().max(1.0);
            let mut e = (exact - fd).abs() / scale;
            if (forward - backward).abs() / scale > KINK {
                report.kinks += 1;
                let one_sided = (exact - forward).abs().min((exact - backward).abs()) / scale;
                // A smooth but strongly curved function also separates the one-sided
                // differences; there the central difference is still the right reference.
                e = e.min(if one_sided < KINK { 0.0 } else { one_sided });
            }
            report.entries += 1;
            if e > report.max_error || !e.is_finite() {
                report.max_error = if e.is_finite() { e } else { f64::INFINITY };
                report.worst = what;
            }
        };
        compare(grad[j], (fp, f0, fm), format!("∂f/∂x[{j}]"));
        for r in 0..dims.m {
            compare(
                analytic[r],
                (cp[r], c0[r], cm[r]),
                format!("∂c[{r}]/∂x[{j}] ({})", nlp.constraint_name(r)),
            );
        }
    }
    Ok(report)
}
