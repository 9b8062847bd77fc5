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
//! Smoothing across λ = 0 (C∞, so the exact Hessian exists everywhere), with a blend width ε in
//! newtons:
//! ```text
//!     r(λ) = √(λ² + ε²)
//!     a(λ) = λ²/r                  smooth |λ|:   |λ| − a ≈ ε²/(2|λ|) for |λ| ≫ ε
//!     h(λ) = λ²/r^(3/2)            smooth √|λ|:  √|λ| − h ≈ ¾·ε²/|λ|^(3/2)
//!     s(λ) = ½·(1 + tanh(λ/ε))     blend weight: 0 in tension, 1 in compression
//!     m(λ, L) = (1 − s)·k_T·a·L + w·s·C(λ, L)
//!     C = k_C·h·L²  (Euler)    or    C = k_C·a·L  (linear, k_C = ρ/σ_C, k_T = ρ/σ_T)
//! ```
//! `w` is 1 for the physical mass; the objective "mass with a preference for tension" uses
//! `w > 1` (a penalty on compression members, seed §4.3.3). m(0, L) = 0 and m ≥ 0 everywhere.
//! a and h are increasing in |λ|, vanish at 0 and approach the exact branches with relative
//! errors of order (ε/λ)²; the blend tail (the other branch's share) decays like e^(−2|λ|/ε),
//! which matters because an Euler member is far heavier than a tie at small forces.
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
    /// Blend width ε, N (> 0).
    pub blend: f64,
    /// Weight w on the compression part (1 for the physical mass).
    pub compression_weight: f64,
}

/// Mass and its first and second partial derivatives in λ (N) and L (m).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MassDerivatives {
    /// m, kg.
    pub m: f64,
    /// ∂m/∂λ, kg/N.
    pub m_l: f64,
    /// ∂m/∂L, kg/m.
    pub m_len: f64,
    /// ∂²m/∂λ².
    pub m_ll: f64,
    /// ∂²m/∂λ∂L.
    pub m_l_len: f64,
    /// ∂²m/∂L².
    pub m_len_len: f64,
}

/// A smooth scalar function of λ with its first two derivatives.
#[derive(Debug, Clone, Copy)]
struct Smooth {
    v: f64,
    d: f64,
    dd: f64,
}

impl MassModel {
    /// The seed's steel model: k_T = 5e-6, Euler buckling with k_C = 5e-3.
    pub fn seed(blend: f64) -> Self {
        MassModel {
            k_t: 5e-6,
            compression: Compression::Euler { k_c: 5e-3 },
            blend,
            compression_weight: 1.0,
        }
    }

    /// The plastic-design model: `ρ·|λ|·L/σ` with σ_T in tension and σ_C in compression (Pa,
    /// kg/m³).
    pub fn linear(sigma_t: f64, sigma_c: f64, density: f64, blend: f64) -> Self {
        MassModel {
            k_t: density / sigma_t,
            compression: Compression::Linear {
                k_c: density / sigma_c,
            },
            blend,
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

    /// Mass of a beam with axial force `lambda` (N, + compression) and length `length` (m).
    pub fn mass(&self, lambda: f64, length: f64) -> f64 {
        self.derivatives(lambda, length).m
    }

    /// Mass and its first and second derivatives.
    pub fn derivatives(&self, lambda: f64, length: f64) -> MassDerivatives {
        let eps = self.blend;
        let r = (lambda * lambda + eps * eps).sqrt();
        let r3 = r * r * r;
        let (l2, e2) = (lambda * lambda, eps * eps);
        // Smooth |λ| = λ²/r.
        let a = Smooth {
            v: l2 / r,
            d: lambda * (l2 + 2.0 * e2) / r3,
            dd: e2 * (2.0 * e2 - l2) / (r3 * r * r),
        };
        // Blend weight (0 in tension, 1 in compression).
        let th = (lambda / eps).tanh();
        let sech2 = 1.0 - th * th;
        let s = Smooth {
            v: 0.5 * (1.0 + th),
            d: 0.5 * sech2 / eps,
            dd: -th * sech2 / (eps * eps),
        };
        let big_l = length;
        // Tension part T(λ)·L with T = (1 − s)·k_T·a.
        let kt = self.k_t;
        let t = Smooth {
            v: kt * (1.0 - s.v) * a.v,
            d: kt * (-s.d * a.v + (1.0 - s.v) * a.d),
            dd: kt * (-s.dd * a.v - 2.0 * s.d * a.d + (1.0 - s.v) * a.dd),
        };
        let w = self.compression_weight;
        // Compression part: C(λ)·L^p.
        let (c, power) = match self.compression {
            Compression::Euler { k_c } => {
                // Smooth √|λ| = λ²/r^(3/2).
                let r32 = r * r.sqrt();
                let r72 = r32 * r * r;
                let h = Smooth {
                    v: l2 / r32,
                    d: lambda * (0.5 * l2 + 2.0 * e2) / r72,
                    dd: (-0.25 * l2 * l2 - 3.5 * e2 * l2 + 2.0 * e2 * e2) / (r72 * r * r),
                };
                (product(s, h, w * k_c), 2)
            }
            Compression::Linear { k_c } => (product(s, a, w * k_c), 1),
        };
        let (lp, dlp, ddlp) = match power {
            2 => (big_l * big_l, 2.0 * big_l, 2.0),
            _ => (big_l, 1.0, 0.0),
        };
        MassDerivatives {
            m: t.v * big_l + c.v * lp,
            m_l: t.d * big_l + c.d * lp,
            m_len: t.v + c.v * dlp,
            m_ll: t.dd * big_l + c.dd * lp,
            m_l_len: t.d + c.d * dlp,
            m_len_len: c.v * ddlp,
        }
    }
}

/// k·f·g with derivatives.
fn product(f: Smooth, g: Smooth, k: f64) -> Smooth {
    Smooth {
        v: k * f.v * g.v,
        d: k * (f.d * g.v + f.v * g.d),
        dd: k * (f.dd * g.v + 2.0 * f.d * g.d + f.v * g.dd),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn models() -> Vec<MassModel> {
        vec![
            MassModel::seed(100.0),
            MassModel::seed(100.0).with_compression_weight(3.0),
            MassModel::linear(250e6, 150e6, 7850.0, 100.0),
        ]
    }

    #[test]
    fn derivatives_match_central_differences() {
        for model in models() {
            for &lambda in &[-1e5, -300.0, -20.0, 0.0, 15.0, 250.0, 4e5] {
                for &len in &[0.3, 2.0, 17.0] {
                    let d = model.derivatives(lambda, len);
                    let hl = 1e-4 * (lambda.abs() + model.blend);
                    // m is quadratic in L: a wide step is exact up to rounding.
                    let hx = 1e-3 * len;
                    let at = |l: f64, x: f64| model.derivatives(l, x);
                    // Fourth-order central differences.
                    let fd = |f: &dyn Fn(f64) -> f64, x: f64, h: f64| {
                        (8.0 * (f(x + h) - f(x - h)) - (f(x + 2.0 * h) - f(x - 2.0 * h)))
                            / (12.0 * h)
                    };
                    let close = |a: f64, b: f64, what: &str| {
                        assert!(
                            (a - b).abs() <= 1e-6 * (a.abs() + b.abs()) + 1e-12,
                            "{what}: analytic {a} vs fd {b} at λ={lambda}, L={len}, {model:?}"
                        );
                    };
                    close(d.m_l, fd(&|l| at(l, len).m, lambda, hl), "m_λ");
                    close(d.m_len, fd(&|x| at(lambda, x).m, len, hx), "m_L");
                    close(d.m_ll, fd(&|l| at(l, len).m_l, lambda, hl), "m_λλ");
                    close(d.m_l_len, fd(&|x| at(lambda, x).m_l, len, hx), "m_λL");
                    close(d.m_len_len, fd(&|x| at(lambda, x).m_len, len, hx), "m_LL");
                }
            }
        }
    }

    #[test]
    fn branches_are_recovered_away_from_zero() {
        let model = MassModel::seed(1.0);
        let (lambda, len) = (1e6, 5.0);
        // Relative errors of order (ε/λ)² = 1e-12, plus the blend tail.
        let tension = model.mass(-lambda, len);
        let exact_t = 5e-6 * lambda * len;
        assert!(
            (tension - exact_t).abs() / exact_t < 1e-9,
            "{tension} {exact_t}"
        );
        let compression = model.mass(lambda, len);
        let exact_c = 5e-3 * lambda.sqrt() * len * len;
        assert!(
            (compression - exact_c).abs() / exact_c < 1e-9,
            "{compression} {exact_c}"
        );
        // At λ = 10ε the blend still reproduces each branch to about 1%.
        let near = MassModel::seed(1e3);
        let t = near.mass(-1e4, 2.0);
        assert!((t - 5e-6 * 1e4 * 2.0).abs() / t < 0.02, "{t}");
        let linear = MassModel::linear(200e6, 100e6, 8000.0, 1.0);
        let lt = linear.mass(-lambda, len);
        let lc = linear.mass(lambda, len);
        assert!((lt - 8000.0 * lambda * len / 200e6).abs() / lt < 1e-9);
        assert!((lc - 8000.0 * lambda * len / 100e6).abs() / lc < 1e-9);
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
