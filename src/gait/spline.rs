//! Actuator force trajectories as cubic Hermite splines (seed §3.7: 6–8 knots per actuator), and
//! the objective `∫₀ᵀ Σₐ Fₐ(t)² dt` (seed eq. 3.1) in closed form.
//!
//! `K` knots `t_k = k·T/(K − 1)`; each actuator has knot values `y_k` (N·m or N) and slopes `s_k`
//! (N·m/s or N/s). On segment `[t_k, t_{k+1}]` of length `h`, with `u = (t − t_k)/h`:
//! ```text
//!   F(t) = h₀₀(u)·y_k + h·h₁₀(u)·s_k + h₀₁(u)·y_{k+1} + h·h₁₁(u)·s_{k+1}
//!   h₀₀ = 2u³ − 3u² + 1,  h₁₀ = u³ − 2u² + u,  h₀₁ = −2u³ + 3u²,  h₁₁ = u³ − u²
//! ```
//! Knot `k`'s parameters affect `F` only on `(t_{k−1}, t_{k+1})`.
//! The segment's contribution to `∫F²dt` is `h·cᵀGc` with `c = (y_k, h·s_k, y_{k+1}, h·s_{k+1})`
//! and the Gram matrix of the Hermite basis on [0, 1],
//! `G = [[13/35, 11/210, 9/70, −13/420], [11/210, 1/105, 13/420, −1/140], [9/70, 13/420, 13/35,
//! −11/210], [−13/420, −1/140, −11/210, 1/105]]`; its gradient is `2h·G·c` chained through
//! `c`'s slope scaling.
//!
//! Parameter layout: actuator-major; actuator `a` owns `2K` entries, first its `K` values then
//! its `K` slopes.

use super::sim::Controls;
use super::spatial::Real;

/// Gram matrix of the Hermite basis (h₀₀, h₁₀, h₀₁, h₁₁) on [0, 1].
const GRAM: [[f64; 4]; 4] = [
    [13.0 / 35.0, 11.0 / 210.0, 9.0 / 70.0, -13.0 / 420.0],
    [11.0 / 210.0, 1.0 / 105.0, 13.0 / 420.0, -1.0 / 140.0],
    [9.0 / 70.0, 13.0 / 420.0, 13.0 / 35.0, -11.0 / 210.0],
    [-13.0 / 420.0, -1.0 / 140.0, -11.0 / 210.0, 1.0 / 105.0],
];

/// The knot grid shared by all actuators.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KnotGrid {
    /// Number of knots `K ≥ 2`.
    pub knots: usize,
    /// Horizon `T` (s).
    pub horizon: f64,
}

impl KnotGrid {
    /// Segment length `h = T/(K − 1)` (s).
    pub fn spacing(&self) -> f64 {
        self.horizon / (self.knots - 1) as f64
    }

    /// Time of knot `k` (s).
    pub fn time(&self, k: usize) -> f64 {
        k as f64 * self.spacing()
    }

    /// Parameters per actuator (`2K`).
    pub fn per_actuator(&self) -> usize {
        2 * self.knots
    }

    /// Knot of parameter `j` within an actuator's block.
    pub fn knot_of(&self, j: usize) -> usize {
        j % self.knots
    }

    /// The segment containing `t` (clamped to the horizon) and the local coordinate `u ∈ [0, 1]`.
    fn locate(&self, t: f64) -> (usize, f64) {
        let h = self.spacing();
        let x = (t / h).clamp(0.0, (self.knots - 1) as f64);
        let k = (x.floor() as usize).min(self.knots - 2);
        (k, x - k as f64)
    }

    /// Basis weights at time `t`: `F(t) = Σ w_i·p[idx_i]` over an actuator's block `p`.
    pub fn weights(&self, t: f64) -> ([usize; 4], [f64; 4]) {
        let (k, u) = self.locate(t);
        let h = self.spacing();
        let (u2, u3) = (u * u, u * u * u);
        let w = [
            2.0 * u3 - 3.0 * u2 + 1.0,
            h * (u3 - 2.0 * u2 + u),
            -2.0 * u3 + 3.0 * u2,
            h * (u3 - u2),
        ];
        let n = self.knots;
        ([k, n + k, k + 1, n + k + 1], w)
    }

    /// `∫₀ᵀ F² dt` of one actuator block `p` (N²·s), and its gradient added into `grad`.
    pub fn integral_of_square(&self, p: &[f64], grad: Option<&mut [f64]>) -> f64 {
        let (h, n) = (self.spacing(), self.knots);
        let mut total = 0.0;
        let mut g = vec![0.0; 2 * n];
        for k in 0..n - 1 {
            let idx = [k, n + k, k + 1, n + k + 1];
            let scale = [1.0, h, 1.0, h];
            let c: [f64; 4] = std::array::from_fn(|i| p[idx[i]] * scale[i]);
            for i in 0..4 {
                let gc: f64 = (0..4).map(|j| GRAM[i][j] * c[j]).sum();
                total += h * c[i] * gc;
                g[idx[i]] += 2.0 * h * gc * scale[i];
            }
        }
        if let Some(out) = grad {
            for (o, x) in out.iter_mut().zip(&g) {
                *o += x;
            }
        }
        total
    }
}

/// Spline controls for all actuators with parameters of scalar type `T`.
#[derive(Debug, Clone)]
pub struct SplineControls<T> {
    /// The knot grid.
    pub grid: KnotGrid,
    /// Parameters, `2K` per actuator (layout in the module header).
    pub params: Vec<T>,
}

impl<T: Real> Controls<T> for SplineControls<T> {
    fn forces(&self, t: f64, out: &mut [T]) {
        let (idx, w) = self.grid.weights(t);
        let block = self.grid.per_actuator();
        for (a, o) in out.iter_mut().enumerate() {
            let p = &self.params[a * block..(a + 1) * block];
            *o = p[idx[0]] * w[0] + p[idx[1]] * w[1] + p[idx[2]] * w[2] + p[idx[3]] * w[3];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eval(grid: &KnotGrid, p: &[f64], t: f64) -> f64 {
        let mut out = [0.0];
        SplineControls {
            grid: *grid,
            params: p.to_vec(),
        }
        .forces(t, &mut out);
        out[0]
    }

    #[test]
    fn interpolates_values_and_slopes() {
        let grid = KnotGrid {
            knots: 5,
            horizon: 1.0,
        };
        let p = [1.0, -2.0, 0.5, 3.0, 0.0, 4.0, -1.0, 2.0, 0.0, 7.0];
        for k in 0..5 {
            let t = grid.time(k);
            assert!((eval(&grid, &p, t) - p[k]).abs() < 1e-12);
            let e = 1e-7;
            let (a, b) = ((t - e).max(0.0), (t + e).min(1.0));
            let slope = (eval(&grid, &p, b) - eval(&grid, &p, a)) / (b - a);
            assert!((slope - p[5 + k]).abs() < 1e-4, "knot {k}: {slope}");
        }
        // A cubic is reproduced exactly: F(t) = t³ − t with K = 3.
        let grid = KnotGrid {
            knots: 3,
            horizon: 1.0,
        };
        let f = |t: f64| t * t * t - t;
        let df = |t: f64| 3.0 * t * t - 1.0;
        let p = [f(0.0), f(0.5), f(1.0), df(0.0), df(0.5), df(1.0)];
        for i in 0..=20 {
            let t = i as f64 / 20.0;
            assert!((eval(&grid, &p, t) - f(t)).abs() < 1e-14);
        }
    }

    #[test]
    fn integral_and_gradient_are_exact() {
        let grid = KnotGrid {
            knots: 4,
            horizon: 0.9,
        };
        let p = [1.0, -2.0, 0.5, 3.0, 10.0, 4.0, -1.0, 2.0];
        // Composite Gauss–Legendre (5 points per segment) integrates the degree-6 integrand exactly.
        let r = (10.0f64 / 7.0).sqrt();
        let (a, b) = ((5.0 - 2.0 * r).sqrt() / 3.0, (5.0 + 2.0 * r).sqrt() / 3.0);
        let s70 = 70.0f64.sqrt();
        let (wa, wb) = ((322.0 + 13.0 * s70) / 900.0, (322.0 - 13.0 * s70) / 900.0);
        let nodes = [0.0, -a, a, -b, b];
        let weights = [128.0 / 225.0, wa, wa, wb, wb];
        let h = grid.spacing();
        let mut quad = 0.0;
        for k in 0..3 {
            for (x, w) in nodes.iter().zip(&weights) {
                let t = h * (k as f64 + 0.5 * (x + 1.0));
                quad += 0.5 * h * w * eval(&grid, &p, t).powi(2);
            }
        }
        let mut grad = vec![0.0; 8];
        let closed = grid.integral_of_square(&p, Some(&mut grad));
        assert!((closed - quad).abs() < 1e-12 * quad, "{closed} vs {quad}");
        for j in 0..8 {
            let e = 1e-6;
            let (mut a, mut b) = (p, p);
            a[j] += e;
            b[j] -= e;
            let fd =
                (grid.integral_of_square(&a, None) - grid.integral_of_square(&b, None)) / (2.0 * e);
            assert!(
                (fd - grad[j]).abs() < 1e-7 * grad[j].abs().max(1.0),
                "{j}: {fd} vs {}",
                grad[j]
            );
        }
    }
}
