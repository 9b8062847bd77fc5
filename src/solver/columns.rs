//! `y ← y + Σₖ aₖ·xₖ` over dense columns xₖ, entry by entry in the order of the terms:
//!
//! ```text
//!     yᵢ ← (…((yᵢ + a₀x₀ᵢ) + a₁x₁ᵢ) …) + aₘxₘᵢ
//! ```
//!
//! the numbers of one `y += aₖ·xₖ` pass per column (nalgebra's `axpy`, or the left-looking
//! Cholesky's column update `c −= Lⱼₖ·v` with aₖ = −Lⱼₖ: negation is exact), but four terms
//! per pass over y: each entry is loaded and stored once for four columns, where one pass per
//! column loads and stores it for every one. The definiteness test's Cholesky factorizations
//! and its row basis spend most of their instructions in such sums.

/// `y ← y + Σₖ aₖ·xₖ` for the terms `(aₖ, sₖ)` in order, xₖ the `y.len()` entries of
/// `source` from `sₖ` on (columns of one column-major matrix); see the module header.
pub(crate) fn add_scaled_columns(y: &mut [f64], source: &[f64], terms: &[(f64, usize)]) {
    let len = y.len();
    let column = |start: usize| &source[start..start + len];
    let mut groups = terms.chunks_exact(4);
    for group in &mut groups {
        let [(a0, s0), (a1, s1), (a2, s2), (a3, s3)] = *group else {
            unreachable!("chunks of four")
        };
        let (x0, x1, x2, x3) = (column(s0), column(s1), column(s2), column(s3));
        for ((((yi, &u0), &u1), &u2), &u3) in y.iter_mut().zip(x0).zip(x1).zip(x2).zip(x3) {
            *yi = (((*yi + a0 * u0) + a1 * u1) + a2 * u2) + a3 * u3;
        }
    }
    for &(a, start) in groups.remainder() {
        for (yi, &u) in y.iter_mut().zip(column(start)) {
            *yi += a * u;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_blocked_sum_is_one_axpy_per_column_to_the_bit() {
        // Lengths around the block, values of mixed signs and magnitudes, a zero coefficient
        // and signed zeros in y.
        for len in [0, 1, 7, 8, 9, 17, 113] {
            let columns: Vec<Vec<f64>> = (0..5)
                .map(|k| {
                    (0..len + 3)
                        .map(|i| ((i * 37 + k * 11) % 13) as f64 / 7.0 - 0.9)
                        .map(|v| v * 1.3e-2_f64.powi(((len + k) % 3) as i32))
                        .collect()
                })
                .collect();
            let coefficients = [0.7, -1.0 / 3.0, 0.0, 1e5, -2.5e-7];
            let start: Vec<f64> = (0..len)
                .map(|i| match i % 4 {
                    0 => 0.0,
                    1 => -0.0,
                    _ => (i as f64).sqrt() - 3.1,
                })
                .collect();
            let mut expected = start.clone();
            for (a, x) in coefficients.iter().zip(&columns) {
                for (e, xi) in expected.iter_mut().zip(x) {
                    *e += a * xi;
                }
            }
            // The columns one after the other in one slice, each starting at k·(len + 3).
            let source: Vec<f64> = columns.concat();
            let terms: Vec<(f64, usize)> = (coefficients.iter().copied())
                .zip((0..columns.len()).map(|k| k * (len + 3)))
                .collect();
            let mut blocked = start;
            add_scaled_columns(&mut blocked, &source, &terms);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&blocked), bits(&expected), "length {len}");
        }
    }
}
