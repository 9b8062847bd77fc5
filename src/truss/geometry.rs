//! Geometric kernels with exact first and second derivatives: beam length, the beam direction
//! projected on a vector, and the squared distance from a point to a segment.
//!
//! Lengths in metres. For a beam vector `d = p_b − p_a` with `L = |d|`, `e = d/L`:
//! ```text
//!     ∇L = e,   ∇²L = (I − e eᵀ)/L
//!     φ(d) = y·e:  ∇φ = (y − (y·e) e)/L,
//!                  ∇²φ = −[y eᵀ + e yᵀ + (y·e)(I − 3 e eᵀ)]/L²
//! ```
//! Segment–point squared distance (seed §4.3.3 uses the distance with finite-difference
//! gradients; here it is exact). With `w = a − c`, `u = b − a`, `t* = clamp(−w·u/u·u, 0, 1)`:
//! - `t* = 0`: `D = |a − c|²`; `t* = 1`: `D = |b − c|²`;
//! - interior: `D = w·w − p²/q` with `p = w·u`, `q = u·u`, whose derivatives in z = (a, b) are
//!   `∇D = 2Wᵀw − (2p/q)∇p + (p²/q²)∇q` and
//!   `∇²D = 2WᵀW − (2/q)∇p∇pᵀ − (2p/q)∇²p + (2p/q²)(∇p∇qᵀ + ∇q∇pᵀ) − (2p²/q³)∇q∇qᵀ + (p²/q²)∇²q`
//!   with `W = [I 0]`, `∇p = (u − w, w)`, `∇q = (−2u, 2u)`, `∇²p = [[−2I, I], [I, 0]]`,
//!   `∇²q = 2[[I, −I], [−I, I]]`.
//!
//! D is C¹ in (a, b) for a ≠ b (Danskin: the minimizer t* is unique); its Hessian jumps where t*
//! reaches 0 or 1.

use nalgebra::{Matrix3, SMatrix, SVector};

use super::model::Vec3;

/// 6×6 matrix over the two end points (a, b).
pub type Mat6 = SMatrix<f64, 6, 6>;
/// 6-vector over the two end points (a, b).
pub type Vec6 = SVector<f64, 6>;

/// Hessian of |d| with respect to d.
pub fn length_hessian(e: &Vec3, length: f64) -> Matrix3<f64> {
    (Matrix3::identity() - e * e.transpose()) / length
}

/// Gradient of y·(d/|d|) with respect to d.
pub fn projection_gradient(y: &Vec3, e: &Vec3, length: f64) -> Vec3 {
    (y - y.dot(e) * e) / length
}

/// Hessian of y·(d/|d|) with respect to d.
pub fn projection_hessian(y: &Vec3, e: &Vec3, length: f64) -> Matrix3<f64> {
    let ye = y.dot(e);
    -(y * e.transpose() + e * y.transpose() + ye * (Matrix3::identity() - 3.0 * e * e.transpose()))
        / (length * length)
}

/// Distance from `c` to the segment `a`–`b` and the parameter t ∈ [0, 1] of the closest point.
pub fn segment_point_distance(a: &Vec3, b: &Vec3, c: &Vec3) -> (f64, f64) {
    let u = b - a;
    let q = u.norm_squared();
    let t = if q > 0.0 {
        (-(a - c).dot(&u) / q).clamp(0.0, 1.0)
    } else {
        0.0
    };
    ((a + t * u - c).norm(), t)
}

/// Squared segment–point distance with its gradient and Hessian over (a, b).
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentDistance {
    /// D = squared distance, m².
    pub value: f64,
    /// ∂D/∂(a, b).
    pub gradient: Vec6,
    /// ∂²D/∂(a, b)².
    pub hessian: Mat6,
}

/// Squared distance from `c` to the segment `a`–`b`, with exact derivatives (module header).
pub fn segment_distance_squared(a: &Vec3, b: &Vec3, c: &Vec3) -> SegmentDistance {
    let w = a - c;
    let u = b - a;
    let q = u.norm_squared();
    let p = w.dot(&u);
    let mut gradient = Vec6::zeros();
    let mut hessian = Mat6::zeros();
    let i3 = Matrix3::<f64>::identity();
    if q <= 0.0 || p >= 0.0 {
        // Closest point is a.
        gradient.fixed_rows_mut::<3>(0).copy_from(&(2.0 * w));
        hessian.fixed_view_mut::<3, 3>(0, 0).copy_from(&(2.0 * i3));
        return SegmentDistance {
            value: w.norm_squared(),
            gradient,
            hessian,
        };
    }
    if -p >= q {
        // Closest point is b.
        let v = b - c;
        gradient.fixed_rows_mut::<3>(3).copy_from(&(2.0 * v));
        hessian.fixed_view_mut::<3, 3>(3, 3).copy_from(&(2.0 * i3));
        return SegmentDistance {
            value: v.norm_squared(),
            gradient,
            hessian,
        };
    }
    let mut gp = Vec6::zeros();
    gp.fixed_rows_mut::<3>(0).copy_from(&(u - w));
    gp.fixed_rows_mut::<3>(3).copy_from(&w);
    let mut gq = Vec6::zeros();
    gq.fixed_rows_mut::<3>(0).copy_from(&(-2.0 * u));
    gq.fixed_rows_mut::<3>(3).copy_from(&(2.0 * u));
    let mut hp = Mat6::zeros();
    hp.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-2.0 * i3));
    hp.fixed_view_mut::<3, 3>(0, 3).copy_from(&i3);
    hp.fixed_view_mut::<3, 3>(3, 0).copy_from(&i3);
    let mut hq = Mat6::zeros();
    hq.fixed_view_mut::<3, 3>(0, 0).copy_from(&(2.0 * i3));
    hq.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-2.0 * i3));
    hq.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-2.0 * i3));
    hq.fixed_view_mut::<3, 3>(3, 3).copy_from(&(2.0 * i3));
    let mut ww = Mat6::zeros();
    ww.fixed_view_mut::<3, 3>(0, 0).copy_from(&(2.0 * i3));
    let mut gw = Vec6::zeros();
    gw.fixed_rows_mut::<3>(0).copy_from(&(2.0 * w));

    let value = w.norm_squared() - p * p / q;
    gradient = gw - (2.0 * p / q) * gp + (p * p / (q * q)) * gq;
    hessian = ww - (2.0 / q) * gp * gp.transpose() - (2.0 * p / q) * hp
        + (2.0 * p / (q * q)) * (gp * gq.transpose() + gq * gp.transpose())
        - (2.0 * p * p / (q * q * q)) * gq * gq.transpose()
        + (p * p / (q * q)) * hq;
    SegmentDistance {
        value: value.max(0.0),
        gradient,
        hessian,
    }
}

/// Closest distance between segments `p1`–`q1` and `p2`–`q2`, with the parameters (s, t) ∈ [0, 1]²
/// of the closest points (Ericson, Real-Time Collision Detection, §5.1.9).
pub fn segment_segment_distance(p1: &Vec3, q1: &Vec3, p2: &Vec3, q2: &Vec3) -> (f64, f64, f64) {
    let d1 = q1 - p1;
    let d2 = q2 - p2;
    let r = p1 - p2;
    let a = d1.norm_squared();
    let e = d2.norm_squared();
    let f = d2.dot(&r);
    let (s, t) = if a <= 0.0 && e <= 0.0 {
        (0.0, 0.0)
    } else if a <= 0.0 {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(&r);
        if e <= 0.0 {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(&d2);
            let denom = a * e - b * b;
            let mut s = if denom > 0.0 {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    ((p1 + s * d1 - (p2 + t * d2)).norm(), s, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn split(z: &Vec6) -> (Vec3, Vec3) {
        (Vec3::new(z[0], z[1], z[2]), Vec3::new(z[3], z[4], z[5]))
    }

    fn check_at(a: Vec3, b: Vec3, c: Vec3) {
        let mut z = Vec6::zeros();
        z.fixed_rows_mut::<3>(0).copy_from(&a);
        z.fixed_rows_mut::<3>(3).copy_from(&b);
        let d = segment_distance_squared(&a, &b, &c);
        let h = 1e-6;
        for k in 0..6 {
            let (mut zp, mut zm) = (z, z);
            zp[k] += h;
            zm[k] -= h;
            let (ap, bp) = split(&zp);
            let (am, bm) = split(&zm);
            let fp = segment_distance_squared(&ap, &bp, &c);
            let fm = segment_distance_squared(&am, &bm, &c);
            let g = (fp.value - fm.value) / (2.0 * h);
            assert!(
                (g - d.gradient[k]).abs() <= 1e-6 * (1.0 + g.abs()),
                "grad[{k}] {g} vs {}",
                d.gradient[k]
            );
            for l in 0..6 {
                let hk = (fp.gradient[l] - fm.gradient[l]) / (2.0 * h);
                assert!(
                    (hk - d.hessian[(l, k)]).abs() <= 1e-5 * (1.0 + hk.abs()),
                    "hess[{l},{k}] {hk} vs {}",
                    d.hessian[(l, k)]
                );
            }
        }
    }

    #[test]
    fn derivatives_match_central_differences_in_every_regime() {
        let c = Vec3::new(0.3, -0.2, 0.1);
        // Interior closest point.
        check_at(Vec3::new(-2.0, 1.0, 0.5), Vec3::new(3.0, 1.5, -0.7), c);
        // Closest point at a, then at b.
        check_at(Vec3::new(1.0, 0.5, 0.2), Vec3::new(4.0, 2.0, 1.0), c);
        check_at(Vec3::new(4.0, 2.0, 1.0), Vec3::new(1.0, 0.5, 0.2), c);
        // Nearly degenerate: a short segment passing close to the centre.
        check_at(Vec3::new(0.29, -0.15, 0.1), Vec3::new(0.32, -0.16, 0.11), c);
    }

    #[test]
    fn distance_matches_brute_force_sampling() {
        let cases = [
            (
                Vec3::new(-2.0, 1.0, 0.5),
                Vec3::new(3.0, 1.5, -0.7),
                Vec3::new(0.0, 0.0, 0.0),
            ),
            (
                Vec3::new(1.0, 1.0, 1.0),
                Vec3::new(2.0, 3.0, 4.0),
                Vec3::new(-1.0, 0.0, 0.0),
            ),
            (
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(0.0, 0.0, 5.0),
                Vec3::new(0.0, 1.0, 7.0),
            ),
        ];
        for (a, b, c) in cases {
            let n = 200_000;
            let brute = (0..=n)
                .map(|i| {
                    let t = f64::from(i) / f64::from(n);
                    (a + t * (b - a) - c).norm()
                })
                .fold(f64::INFINITY, f64::min);
            let exact = segment_distance_squared(&a, &b, &c).value.sqrt();
            // Sampling overestimates by at most half a step squared over the distance.
            assert!(exact <= brute + 1e-12, "{exact} > {brute}");
            assert!(brute - exact < 1e-8, "{exact} vs {brute}");
            assert!((segment_point_distance(&a, &b, &c).0 - exact).abs() < 1e-12);
        }
    }

    #[test]
    fn projection_and_length_hessians_match_differences() {
        let y = Vec3::new(0.7, -1.3, 0.4);
        let d = Vec3::new(1.2, 0.3, -2.0);
        let h = 1e-6;
        let phi_grad = |d: &Vec3| projection_gradient(&y, &d.normalize(), d.norm());
        let len_grad = |d: &Vec3| d.normalize();
        let hp = projection_hessian(&y, &d.normalize(), d.norm());
        let hl = length_hessian(&d.normalize(), d.norm());
        for k in 0..3 {
            let mut dp = d;
            let mut dm = d;
            dp[k] += h;
            dm[k] -= h;
            let g = (y.dot(&dp.normalize()) - y.dot(&dm.normalize())) / (2.0 * h);
            assert!((g - phi_grad(&d)[k]).abs() < 1e-8);
            let col = (phi_grad(&dp) - phi_grad(&dm)) / (2.0 * h);
            let lcol = (len_grad(&dp) - len_grad(&dm)) / (2.0 * h);
            for l in 0..3 {
                assert!(
                    (col[l] - hp[(l, k)]).abs() < 1e-7,
                    "{} {}",
                    col[l],
                    hp[(l, k)]
                );
                assert!((lcol[l] - hl[(l, k)]).abs() < 1e-7);
            }
        }
    }

    #[test]
    fn segment_segment_distance_matches_sampling() {
        let cases = [
            // Crossing diagonals of a square.
            (
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
            ),
            // Skew lines.
            (
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(1.0, -1.0, 0.5),
                Vec3::new(1.3, 1.0, 0.5),
            ),
            // Parallel, offset.
            (
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(2.0, 1.0, 0.0),
                Vec3::new(3.0, 1.0, 0.0),
            ),
        ];
        for (p1, q1, p2, q2) in cases {
            let n = 400;
            let mut brute = f64::INFINITY;
            for i in 0..=n {
                for k in 0..=n {
                    let a = p1 + (q1 - p1) * (f64::from(i) / f64::from(n));
                    let b = p2 + (q2 - p2) * (f64::from(k) / f64::from(n));
                    brute = brute.min((a - b).norm());
                }
            }
            let (d, _, _) = segment_segment_distance(&p1, &q1, &p2, &q2);
            assert!(d <= brute + 1e-12 && brute - d < 1e-4, "{d} vs {brute}");
        }
    }
}
