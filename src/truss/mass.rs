//! Beam mass as a smooth function of axial force and length (seed §4.3.1, eqs. 4.4 and 4.7).
//!
//! Sign convention (seed): the axial force λ is positive in compression, negative in tension;
//! newtons. Lengths in metres, masses in kilograms.
//!
//! Exact branches:
//! - tension: `m_T = k_T·|λ|·L` (eq. 4.4; seed `k_T = 5e-6` kg/(N·m) for steel);
//! - compression, Euler buckling: `m_C = k_C·√λ·L²` (eq. 4.7; seed `k_C = 5e-3`);
//! - `linear` option (plastic design): `m = ρ·|λ|·L/σ_T` in tension, `ρ·|λ|·L/σ_C` in
//!   compression.
//!
//! Split forces. The optimizer never sees |λ|: each force is split into a tension part t ≥ 0
//! and a compression part c ≥ 0 (both in newtons), λ = c − t, and the mass is
//! ```text
//!     m(t, c, L) = k_T·t·L + w·C(c, L)
//!     C = k_C·c·L                (linear: k_C = ρ/σ_C, k_T = ρ/σ_T; exactly the plastic LP)
//!     C = k_C·G(c)·L²,  G(c) = c/√(c + δ)   (Euler)
//! ```
//! Linear mass is exact and smooth (bilinear in force and length). For Euler buckling the
//! square root, whose slope is infinite at c = 0, is replaced below a width δ (newtons) by the
//! quartic that matches √c to third order at c = δ:
//! ```text
//!     G(c) = √c                                          c ≥ δ
//!     G(c) = √δ·(35u − 35u² + 21u³ − 5u⁴)/16,  u = c/δ     c < δ
//! ```
//! G is C³, G(0) = 0, increasing and concave, with G′(0) = 35/(16√δ) and G″(0) = −35/(8δ^{3/2}):
//! the exact Euler mass for every member carrying at least δ, slightly less below it (at most
//! 0.122·√δ·k_C·L² per member, at c ≈ 0.07δ). The default δ is 5% of the largest load
//! (`blend_force`): wide enough that central differences with steps of 1e-4 of the largest load
//! resolve the curvature, and only members carrying less than δ, whose mass is small, differ
//! from the seed's model; [`MassModel::exact_mass`] gives the seed's mass so the difference of a
//! design can be reported. [`MassModel::mass`] gives the model mass of a force λ
//! (t = max(−λ, 0), c = max(λ, 0)). At an optimum t·c = 0 for every beam: carrying both costs
//! mass and does not change λ.
//!
//! `w` is 1 for the physical mass; the objective "mass with a preference for tension" uses
//! `w > 1` (a penalty on compression members, seed §4.3.3).
//!
//! Joint mass (lumping, seed §4.3): each beam's mass is split equally between its two joints;
//! external loads enter the force balance directly as forces (a load given as a mass `M` is the
//! force `M·g`). Gravity is `g = (0, −9.81, 0)` m/s² (y up).

use nalgebra::Vector3;

/// Standard gravity, m/s².
pub const STANDARD_GRAVITY: f64 = 9.81;

/// The gravity vector (y up), m/s².
pub fn gravity() -> Vector3<f64> {
    Vector3::new(0.0, -STANDARD_GRAVITY, 0.0)
}

/// How a compression member's mass grows with force and length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Compression {
    /// Euler buckling: `k_C·√λ·L²`, `k_C` in kg/(√N·m²).
    Euler {
        /// Scale factor k_C.
        k_c: f64,
    },
    /// Stress-limited: `k_C·λ·L`, `k_C = ρ/σ_C` in kg/(N·m).
    Linear {
        /// Scale factor k_C.
        k_c: f64,
    },
}

/// A beam mass model (see the module header).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassModel {
    /// Tension factor k_T in kg/(N·m).
    pub k_t: f64,
    /// Compression law.
    pub compression: Compression,
    /// Smoothing width δ of the Euler square root, N (> 0; unused by the linear law).
    pub blend: f64,
    /// Weight w on the compression part (1 for the physical mass).
    pub compression_weight: f64,
}

/// Mass of a beam with tension part t, compression part c (N) and length L (m), with its
/// nonzero first and second partial derivatives (∂²/∂t², ∂²/∂t∂c vanish).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MassDerivatives {
    /// m, kg.
    pub m: f64,
    /// ∂m/∂t, kg/N.
    pub m_t: f64,
    /// ∂m/∂c, kg/N.
    pub m_c: f64,
    /// ∂m/∂L, kg/m.
    pub m_len: f64,
    /// ∂²m/∂c².
    pub m_cc: f64,
    /// ∂²m/∂t∂L.
    pub m_t_len: f64,
    /// ∂²m/∂c∂L.
    pub m_c_len: f64,
    /// ∂²m/∂L².
    pub m_len_len: f64,
}

impl MassModel {
    /// The seed's steel model: k_T = 5e-6, Euler buckling with k_C = 5e-3; `blend` = δ in N.
    pub fn seed(blend: f64) -> Self {
        MassModel {
            k_t: 5e-6,
            compression: Compression::Euler { k_c: 5e-3 },
            blend,
            compression_weight: 1.0,
        }
    }

    /// The plastic-design model: `ρ·|λ|·L/σ` with σ_T in tension and σ_C in compression (Pa,
    /// kg/m³). Exact: no smoothing.
    pub fn linear(sigma_t: f64, sigma_c: f64, density: f64) -> Self {
        MassModel {
            k_t: density / sigma_t,
            compression: Compression::Linear {
                k_c: density / sigma_c,
            },
            blend: 0.0,
            compression_weight: 1.0,
        }
    }

    /// The same model with the compression part weighted by `w`.
    pub fn with_compression_weight(self, w: f64) -> Self {
        MassModel {
            compression_weight: w,
            ..self
        }
    }

    /// Model mass of a beam with axial force `lambda` (N, + compression) and length `length`
    /// (m): the split t = max(−λ, 0), c = max(λ, 0).
    pub fn mass(&self, lambda: f64, length: f64) -> f64 {
        self.derivatives((-lambda).max(0.0), lambda.max(0.0), length)
            .m
    }

    /// Unsmoothed mass (seed eqs. 4.4 and 4.7, or the linear law) of force λ and length L.
    pub fn exact_mass(&self, lambda: f64, length: f64) -> f64 {
        let w = self.compression_weight;
        if lambda <= 0.0 {
            self.k_t * -lambda * length
        } else {
            match self.compression {
                Compression::Euler { k_c } => w * k_c * lambda.sqrt() * length * length,
                Compression::Linear { k_c } => w * k_c * lambda * length,
            }
        }
    }

    /// Mass and its derivatives at tension part `t`, compression part `c` (N) and length (m).
    pub fn derivatives(&self, t: f64, c: f64, length: f64) -> MassDerivatives {
        let w = self.compression_weight;
        let big_l = length;
        // Compression part w·k_C·G(c)·L^p.
        let (k, g, dg, ddg, p) = match self.compression {
            Compression::Euler { k_c } => {
                let (g, dg, ddg) = smooth_root(c, self.blend);
                (w * k_c, g, dg, ddg, 2)
            }
            Compression::Linear { k_c } => (w * k_c, c, 1.0, 0.0, 1),
        };
        let (lp, dlp, ddlp) = match p {
            2 => (big_l * big_l, 2.0 * big_l, 2.0),
            _ => (big_l, 1.0, 0.0),
        };
        let kt = self.k_t;
        MassDerivatives {
            m: kt * t * big_l + k * g * lp,
            m_t: kt * big_l,
            m_c: k * dg * lp,
            m_len: kt * t + k * g * dlp,
            m_cc: k * ddg * lp,
            m_t_len: kt,
            m_c_len: k * dg * dlp,
            m_len_len: k * g * ddlp,
        }
    }
}

/// G(c), G′(c), G″(c) of the module header: √c above δ, the matching quartic below.
fn smooth_root(c: f64, delta: f64) -> (f64, f64, f64) {
    if c >= delta {
        let r = c.sqrt();
        return (r, 0.5 / r, -0.25 / (r * c));
    }
    let sd = delta.sqrt();
    let u = c / delta;
    let q = u * (35.0 + u * (-35.0 + u * (21.0 - 5.0 * u))) / 16.0;
    let dq = (35.0 + u * (-70.0 + u * (63.0 - 20.0 * u))) / 16.0;
    let ddq = (-70.0 + u * (126.0 - 60.0 * u)) / 16.0;
    (sd * q, dq / sd, ddq / (sd * delta))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn models() -> Vec<MassModel> {
        vec![
            MassModel::seed(100.0),
            MassModel::seed(100.0).with_compression_weight(3.0),
            MassModel::linear(250e6, 150e6, 7850.0),
        ]
    }

    #[test]
    fn derivatives_match_central_differences() {
        for model in models() {
            for &t in &[0.0, 20.0, 4e5] {
                for &c in &[0.0, 15.0, 60.0, 250.0, 4e5] {
                    for &len in &[0.3, 2.0, 17.0] {
                        let d = model.derivatives(t, c, len);
                        let hf = 1e-4 * (c + 100.0);
                        let ht = 1e-4 * (t + 100.0);
                        let hx = 1e-3 * len;
                        let at = |t: f64, c: f64, x: f64| model.derivatives(t, c, x);
                        // Fourth-order central differences.
                        let fd = |f: &dyn Fn(f64) -> f64, x: f64, h: f64| {
                            (8.0 * (f(x + h) - f(x - h)) - (f(x + 2.0 * h) - f(x - 2.0 * h)))
                                / (12.0 * h)
                        };
                        let close = |a: f64, b: f64, what: &str| {
                            assert!(
                                (a - b).abs() <= 1e-6 * (a.abs() + b.abs()) + 1e-12,
                                "{what}: analytic {a} vs fd {b} at t={t}, c={c}, L={len}"
                            );
                        };
                        close(d.m_t, fd(&|v| at(v, c, len).m, t, ht), "m_t");
                        close(d.m_c, fd(&|v| at(t, v, len).m, c, hf), "m_c");
                        close(d.m_len, fd(&|x| at(t, c, x).m, len, hx), "m_L");
                        close(d.m_cc, fd(&|v| at(t, v, len).m_c, c, hf), "m_cc");
                        close(0.0, fd(&|v| at(v, c, len).m_t, t, ht), "m_tt");
                        close(0.0, fd(&|v| at(t, v, len).m_t, c, hf), "m_tc");
                        close(d.m_t_len, fd(&|x| at(t, c, x).m_t, len, hx), "m_tL");
                        close(d.m_c_len, fd(&|x| at(t, c, x).m_c, len, hx), "m_cL");
                        close(d.m_len_len, fd(&|x| at(t, c, x).m_len, len, hx), "m_LL");
                    }
                }
            }
        }
    }

    #[test]
    fn smoothed_mass_is_within_the_documented_error_of_the_exact_mass() {
        let delta = 1e3;
        let model = MassModel::seed(delta);
        for &c in &[5e4, 1e5, 1e6] {
            let exact = model.exact_mass(c, 4.0);
            let smooth = model.mass(c, 4.0);
            let rel = (exact - smooth) / exact;
            // Exact at and above δ.
            assert!(rel.abs() < 1e-14, "{rel} at c = {c}");
        }
        // Below δ: lighter than the seed's model, by at most 0.122·√δ·k_C·L².
        for i in 1..1000 {
            let c = delta * f64::from(i) / 1000.0;
            let gap = model.exact_mass(c, 4.0) - model.mass(c, 4.0);
            assert!(
                gap >= 0.0 && gap <= 0.1218 * delta.sqrt() * 5e-3 * 16.0,
                "{gap} at {c}"
            );
        }
        // G is C³ at δ: one-sided third differences of m_cc agree.
        let h = 1e-5 * delta;
        let below = (model.derivatives(0.0, delta, 4.0).m_cc
            - model.derivatives(0.0, delta - h, 4.0).m_cc)
            / h;
        let above = (model.derivatives(0.0, delta + h, 4.0).m_cc
            - model.derivatives(0.0, delta, 4.0).m_cc)
            / h;
        assert!(
            (below - above).abs() < 1e-3 * above.abs(),
            "{below} {above}"
        );
        // Tension and the linear law are exact.
        assert_eq!(model.mass(-2e5, 3.0), model.exact_mass(-2e5, 3.0));
        assert!((model.mass(-2e5, 3.0) - 5e-6 * 2e5 * 3.0).abs() < 1e-12);
        let linear = MassModel::linear(200e6, 100e6, 8000.0);
        assert!((linear.mass(-1e6, 5.0) - 8000.0 * 1e6 * 5.0 / 200e6).abs() < 1e-9);
        assert!((linear.mass(1e6, 5.0) - 8000.0 * 1e6 * 5.0 / 100e6).abs() < 1e-9);
    }

    #[test]
    fn mass_is_zero_at_zero_force_and_never_negative() {
        for model in models() {
            assert_eq!(model.mass(0.0, 3.0), 0.0);
            for i in -200..=200 {
                let lambda = f64::from(i) * 7.3;
                assert!(model.mass(lambda, 2.5) >= 0.0);
            }
        }
    }
}
