//! Difference schemes and the choice of the difference interval.
//!
//! The interval balances truncation error against the error in the computed function values
//! (seed §3.6, eq. 3.31; Gill, Murray & Wright, *Practical Optimization*, §8.6). With ε_R the
//! relative accuracy of the function ("function precision"), ε_A = ε_R·(1 + |f|) its absolute
//! accuracy and s_j the scale over which f changes along x_j, the error bounds
//!
//! ```text
//!     forward:  |err| ≤ h·|f''|/2 + 2·ε_A/h      minimized at h = 2·√(ε_A / |f''|)
//!     central:  |err| ≤ h²·|f'''|/6 + ε_A/h      minimized at h = (3·ε_A / |f'''|)^(1/3)
//! ```
//! become, with the curvature model |f''| ≈ (1 + |f|)/s_j² and |f'''| ≈ (1 + |f|)/s_j³,
//!
//! ```text
//!     forward:  h_j = 2·√ε_R · s_j          central:  h_j = (3·ε_R)^(1/3) · s_j
//! ```
//! so that forward differences are accurate to about √ε_R and central ones to about ε_R^(2/3)
//! (relative). The scale defaults to s_j = 1 + |x_j| (as in SNOPT); a problem that knows its
//! characteristic scale (the seed's f̃ = 0.1 m for poses) sets it. ε_R defaults to
//! ε_mach^0.8 ≈ 3·10⁻¹³ (SNOPT's default function precision); a simulation with fractional
//! accuracy 10⁻⁶ (seed §3.6) should say so.
//!
//! Bounds: a perturbation never leaves [xl, xu]. Forward differences step backward at an upper
//! bound; central differences at a bound become the one-sided second-order formula
//! f'(0) ≈ (4·F(h) − F(2h) − 3·F(0)) / (2h), stepping inward, with h shrunk to fit the room.

/// Which difference formula to use for derivatives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DifferenceScheme {
    /// One extra evaluation per column group, first-order accurate: cheap, for use far from a
    /// solution.
    #[default]
    Forward,
    /// Two extra evaluations per column group, second-order accurate: for use near a solution
    /// and for derivative checks.
    Central,
}

/// How finite differences are taken. `Default` gives the documented defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FiniteDifferenceOptions {
    /// Difference formula; default [`DifferenceScheme::Forward`].
    pub scheme: DifferenceScheme,
    /// Relative accuracy ε_R of the computed functions (dimensionless); default ε_mach^0.8.
    pub function_precision: f64,
    /// Scale s over which the functions change along every variable (units of x); default
    /// `None`, meaning s_j = 1 + |x_j|.
    pub characteristic_scale: Option<f64>,
}

impl Default for FiniteDifferenceOptions {
    fn default() -> Self {
        FiniteDifferenceOptions {
            scheme: DifferenceScheme::Forward,
            function_precision: f64::EPSILON.powf(0.8),
            characteristic_scale: None,
        }
    }
}

impl FiniteDifferenceOptions {
    /// The difference interval h_j for a variable at value `xj` (units of x).
    pub fn interval(&self, scheme: DifferenceScheme, xj: f64) -> f64 {
        let s = self.characteristic_scale.unwrap_or(1.0 + xj.abs());
        let eps = self.function_precision;
        match scheme {
            DifferenceScheme::Forward => 2.0 * eps.sqrt() * s,
            DifferenceScheme::Central => (3.0 * eps).cbrt() * s,
        }
    }
}

/// The offsets from x_j at which one column is evaluated, already rounded so that
/// `x_j + offset` is exactly the perturbed value used.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Stencil {
    /// The variable cannot move (its bounds coincide): derivatives are reported as zero.
    Fixed,
    /// (F(a) − F(0)) / a.
    OneSided { a: f64 },
    /// (F(a) − F(b)) / (a − b) with b ≈ −a.
    Centered { a: f64, b: f64 },
    /// Quadratic through 0, a, b (same sign): second-order one-sided.
    ThreePoint { a: f64, b: f64 },
}

/// The offset actually realized in floating point when moving `x` by `step`, clamped to bounds.
fn realized(x: f64, step: f64, xl: f64, xu: f64) -> f64 {
    (x + step).clamp(xl, xu) - x
}

impl Stencil {
    /// Chooses the stencil for a variable at `x` with bounds `[xl, xu]` and interval `h > 0`.
    pub(crate) fn choose(scheme: DifferenceScheme, x: f64, xl: f64, xu: f64, h: f64) -> Stencil {
        // Room to move inside the bounds; a point outside its bounds has no room on that side.
        let up = (xu - x).max(0.0);
        let down = (x - xl).max(0.0);
        if up <= 0.0 && down <= 0.0 {
            return Stencil::Fixed;
        }
        // Step toward the side with more room when one side is too narrow.
        let sign = if up >= down { 1.0 } else { -1.0 };
        let room = up.max(down);
        match scheme {
            DifferenceScheme::Forward => {
                let step = if up >= h {
                    h
                } else if down >= h {
                    -h
                } else {
                    sign * room
                };
                Stencil::OneSided {
                    a: realized(x, step, xl, xu),
                }
            }
            DifferenceScheme::Central => {
                if up >= h && down >= h {
                    return Stencil::Centered {
                        a: realized(x, h, xl, xu),
                        b: realized(x, -h, xl, xu),
                    };
                }
                let h = h.min(room / 2.0);
                let a = realized(x, sign * h, xl, xu);
                let b = realized(x, 2.0 * sign * h, xl, xu);
                if a == 0.0 || a == b {
                    // Room too small to hold two distinct points: fall back to one side.
                    Stencil::OneSided {
                        a: realized(x, sign * room, xl, xu),
                    }
                } else {
                    Stencil::ThreePoint { a, b }
                }
            }
        }
    }

    /// The perturbed offsets (first and, for two-point stencils, second).
    pub(crate) fn offsets(self) -> (f64, Option<f64>) {
        match self {
            Stencil::Fixed => (0.0, None),
            Stencil::OneSided { a } => (a, None),
            Stencil::Centered { a, b } | Stencil::ThreePoint { a, b } => (a, Some(b)),
        }
    }

    /// The derivative estimate from function values at 0, a and (if used) b.
    pub(crate) fn derivative(self, f0: f64, fa: f64, fb: f64) -> f64 {
        match self {
            Stencil::Fixed => 0.0,
            Stencil::OneSided { a } => (fa - f0) / a,
            Stencil::Centered { a, b } => (fa - fb) / (a - b),
            Stencil::ThreePoint { a, b } => {
                (fa * b * b - fb * a * a - f0 * (b * b - a * a)) / (a * b * (b - a))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn intervals_follow_the_error_balance() {
        let o = FiniteDifferenceOptions {
            function_precision: 1e-12,
            ..Default::default()
        };
        assert!((o.interval(DifferenceScheme::Forward, 0.0) - 2e-6).abs() < 1e-18);
        assert!((o.interval(DifferenceScheme::Forward, 3.0) - 8e-6).abs() < 1e-18);
        let central = (3e-12f64).cbrt();
        assert!((o.interval(DifferenceScheme::Central, -1.0) - 2.0 * central).abs() < 1e-15);
        // The seed's setting: ε_f = 1e-6 and a curvature scale of 0.1 give h ≈ 1e-4.
        let seed = FiniteDifferenceOptions {
            function_precision: 1e-6,
            characteristic_scale: Some(0.1),
            ..Default::default()
        };
        assert!((seed.interval(DifferenceScheme::Forward, 5.0) - 2e-4).abs() < 1e-15);
    }

    #[test]
    fn stencils_stay_inside_the_bounds() {
        let h = 1e-3;
        let inside = |s: Stencil, x: f64| {
            let (a, b) = s.offsets();
            for o in std::iter::once(a).chain(b) {
                assert!(
                    (0.0..=1.0).contains(&(x + o)),
                    "{s:?} leaves [0, 1] from {x}"
                );
            }
        };
        for scheme in [DifferenceScheme::Forward, DifferenceScheme::Central] {
            for x in [0.0, 1e-4, 0.5, 1.0 - 1e-4, 1.0] {
                inside(Stencil::choose(scheme, x, 0.0, 1.0, h), x);
            }
        }
        assert!(matches!(
            Stencil::choose(DifferenceScheme::Forward, 1.0, 0.0, 1.0, h),
            Stencil::OneSided { a } if a < 0.0
        ));
        assert!(matches!(
            Stencil::choose(DifferenceScheme::Central, 0.0, 0.0, 1.0, h),
            Stencil::ThreePoint { a, b } if a > 0.0 && b > a
        ));
        assert_eq!(
            Stencil::choose(DifferenceScheme::Central, 2.0, 2.0, 2.0, h),
            Stencil::Fixed
        );
    }

    #[test]
    fn three_point_formula_is_exact_for_quadratics() {
        let q = |t: f64| 3.0 - 2.0 * t + 5.0 * t * t;
        let s = Stencil::ThreePoint { a: -0.25, b: -0.5 };
        let d = s.derivative(q(0.0), q(-0.25), q(-0.5));
        assert!((d + 2.0).abs() < 1e-12, "{d}");
    }
}
