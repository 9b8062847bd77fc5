//! Estimating the rounding noise of a computed function along a line (after Moré & Wild,
//! "Estimating computational noise", SIAM J. Sci. Comput. 33(3), 2011).
//!
//! Values `f_k = f(x + k·τ·d)`, k = 0..K, sampled so densely that the smooth part of f is a
//! low-degree polynomial over the samples, carry noise ε_k of standard deviation σ. The j-th
//! forward difference `Δʲf_k` then annihilates the smooth part, and for independent noise
//! `E[(Δʲε)²] = σ² (2j)!/(j!)²`, so
//! ```text
//!     σ_j = sqrt( γ_j · mean_k (Δʲf_k)² ),   γ_j = (j!)² / (2j)!
//! ```
//! estimates σ at every order j high enough for the smooth part to vanish. The estimate here
//! is the median of σ_j over the orders [`ORDERS`] (Moré & Wild pick the order where
//! consecutive σ_j agree; the median of a few orders is a simpler guard against one order
//! that is still dominated by curvature or happens to be small).
//!
//! The SQP uses it when a line search fails while the predicted merit decrease is at the
//! rounding level of the merit function: a sum of many terms (50,000 in the large test problem)
//! is computed with an error far above `ε_mach·|f|`, which makes a plain Armijo test reject every
//! step near the solution.

/// Number of samples `f(x + kτd)`, k = 0..SAMPLES−1.
pub const SAMPLES: usize = 13;

/// Difference orders whose noise estimates are combined.
const ORDERS: std::ops::RangeInclusive<usize> = 3..=6;

/// Standard deviation of the noise in equally spaced samples of a smooth function (see the
/// module header); `None` with fewer than `SAMPLES` values or a non-finite one.
pub fn noise_level(samples: &[f64]) -> Option<f64> {
    if samples.len() < SAMPLES || samples.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let mut diff = samples.to_vec();
    let mut estimates = Vec::new();
    let mut gamma = 1.0;
    for order in 1..=*ORDERS.end() {
        for k in 0..diff.len() - 1 {
            diff[k] = diff[k + 1] - diff[k];
        }
        diff.pop();
        // γ_j = (j!)²/(2j)! from γ_{j−1}: multiply by j² / ((2j−1)·2j).
        let j = order as f64;
        gamma *= j * j / ((2.0 * j - 1.0) * (2.0 * j));
        if ORDERS.contains(&order) {
            let mean = diff.iter().map(|v| v * v).sum::<f64>() / diff.len() as f64;
            estimates.push((gamma * mean).sqrt());
        }
    }
    estimates.sort_by(f64::total_cmp);
    let mid = estimates.len() / 2;
    Some(if estimates.len() % 2 == 0 {
        0.5 * (estimates[mid - 1] + estimates[mid])
    } else {
        estimates[mid]
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn smooth_samples_have_no_noise() {
        // A cubic is annihilated by third and higher differences.
        let samples: Vec<f64> = (0..SAMPLES)
            .map(|k| {
                let t = k as f64 * 0.25;
                1.0 + 2.0 * t - t * t + 0.5 * t * t * t
            })
            .collect();
        assert!(noise_level(&samples).unwrap() < 1e-13);
    }

    #[test]
    fn uniform_noise_is_estimated_without_bias() {
        // Noise uniform on [−a, a] has σ = a/√3; a smooth quadratic trend underneath. Single
        // estimates from 13 samples scatter; their median over many lines is close to σ.
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let a = 1e-6;
        let exact = a / 3f64.sqrt();
        let mut ratios: Vec<f64> = (0..51)
            .map(|_| {
                let samples: Vec<f64> = (0..SAMPLES)
                    .map(|k| {
                        let t = k as f64 * 1e-3;
                        3.0 + t - 2.0 * t * t + rng.random_range(-a..a)
                    })
                    .collect();
                noise_level(&samples).unwrap() / exact
            })
            .collect();
        ratios.sort_by(f64::total_cmp);
        assert!(ratios[0] > 0.1 && ratios[50] < 3.0, "{ratios:?}");
        assert!(
            (0.7..1.3).contains(&ratios[25]),
            "median ratio {}",
            ratios[25]
        );
    }

    #[test]
    fn too_few_or_non_finite_samples_give_none() {
        assert!(noise_level(&[1.0; SAMPLES - 1]).is_none());
        let mut samples = vec![1.0; SAMPLES];
        samples[4] = f64::NAN;
        assert!(noise_level(&samples).is_none());
    }
}
