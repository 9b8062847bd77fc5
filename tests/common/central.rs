//! Central finite differences for checking hand-written derivatives in tests:
//! `∂g/∂xⱼ ≈ (g(x + hⱼeⱼ) − g(x − hⱼeⱼ)) / 2hⱼ` with `hⱼ = 1e-6·max(1, |xⱼ|)`
//! (error O(h²) plus rounding O(ε/h), about 1e-9 relative for smooth functions).

#![allow(dead_code)]

/// Jacobian of `g: Rⁿ → Rᵐ` by central differences, as `jac[i][j] = ∂gᵢ/∂xⱼ`.
pub fn jacobian(g: impl Fn(&[f64]) -> Vec<f64>, x: &[f64]) -> Vec<Vec<f64>> {
    let m = g(x).len();
    let mut jac = vec![vec![0.0; x.len()]; m];
    let mut xp = x.to_vec();
    for j in 0..x.len() {
        let h = 1e-6 * x[j].abs().max(1.0);
        xp[j] = x[j] + h;
        let plus = g(&xp);
        xp[j] = x[j] - h;
        let minus = g(&xp);
        xp[j] = x[j];
        for i in 0..m {
            jac[i][j] = (plus[i] - minus[i]) / (2.0 * h);
        }
    }
    jac
}

/// Whether `a` and `b` agree to `rel` relative to `max(1, |a|, |b|)`.
pub fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()).max(1.0)
}
