//! Physical validity of a collocation solution, judged independently of the constraints the
//! optimizer saw.
//!
//! - Newtonian residual: `max |m·r̈(t) − F(t) − m·g|` (N) on a fine time grid
//!   ([`SAMPLES_PER_SEGMENT`] per knot segment), with r̈ from the position splines and F the
//!   piecewise-linear force; collocation only imposed it at the knots.
//! - Re-simulation: the point mass `m·r̈ = F(t) + m·g` integrated by RK4 from the start state
//!   under the solution's force (fixed step, a divisor of every segment); the largest distance
//!   between the simulated and the spline positions (m).
//! - Impulse balance per contact: `∫F dt` against `m·Δv − m·g·Δt` (N·s) across the phase.
//! - Ground: the lowest flight height (m) and the deepest compression in contact (m) on the
//!   simulated motion; the least vertical force and the worst friction ratio `|F_x|/F_y`.
//! - Wall clearance: on the simulated motion, the height where the ball crosses the wall's x,
//!   minus the wall's height (m); negative means the ball hits the wall.

use super::nlp::Layout;
use super::spec::Problem;

/// Fine samples per knot segment for the residual and the re-simulation.
pub const SAMPLES_PER_SEGMENT: usize = 64;

/// What [`validate`] measured.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Validity {
    /// Largest `|m·r̈ − F − m·g|` on the fine grid (N).
    pub newton_residual: f64,
    /// Largest distance between RK4 re-simulation and the spline positions (m).
    pub resimulation_gap: f64,
    /// Largest `|∫F dt − (m·Δv − m·g·Δt)|` over the contact phases (N·s).
    pub impulse_gap: f64,
    /// Lowest height of the simulated ball in flight (m; ≥ 0 above the floor).
    pub lowest_flight: f64,
    /// Deepest compression of the simulated ball in contact (m, ≥ 0).
    pub deepest_compression: f64,
    /// Least vertical ground force (N; must be ≥ 0).
    pub least_normal_force: f64,
    /// Largest `|F_x| / F_y` where `F_y > 0` (compare with the friction coefficient).
    pub friction_ratio: f64,
    /// Height above the wall where the simulated ball crosses it (m); `None` without a wall or
    /// if the ball never crosses.
    pub wall_clearance: Option<f64>,
}

/// The sampled re-simulated motion: times (s), positions and velocities.
#[derive(Debug, Clone, Default)]
pub struct Motion {
    /// s.
    pub t: Vec<f64>,
    /// m.
    pub r: Vec<[f64; 2]>,
    /// m/s.
    pub v: Vec<[f64; 2]>,
}

/// RK4 integration of `m·r̈ = F(t) + m·g` from the start state with [`SAMPLES_PER_SEGMENT`]
/// steps per knot segment (the force is continuous and linear on a segment, so its kinks fall
/// on step boundaries and RK4 integrates it exactly up to round-off).
pub fn resimulate(p: &Problem, l: &Layout, x: &[f64]) -> Motion {
    let g = [0.0, p.gravity];
    let acc = |t: f64| [0, 1].map(|a| l.force_at(x, a, t) / p.mass + g[a]);
    let (mut r, mut v) = p.start;
    let mut m = Motion::default();
    m.t.push(0.0);
    m.r.push(r);
    m.v.push(v);
    for s in 0..l.segments() {
        let (t0, t1) = (l.times[s], l.times[s + 1]);
        let h = (t1 - t0) / SAMPLES_PER_SEGMENT as f64;
        for k in 0..SAMPLES_PER_SEGMENT {
            let t = t0 + k as f64 * h;
            let (a1, a2, a4) = (acc(t), acc(t + 0.5 * h), acc(t + h));
            let k1 = (v, a1);
            let v2 = [0, 1].map(|i| v[i] + 0.5 * h * k1.1[i]);
            let k2 = (v2, a2);
            let v3 = [0, 1].map(|i| v[i] + 0.5 * h * k2.1[i]);
            let k3 = (v3, a2);
            let v4 = [0, 1].map(|i| v[i] + h * k3.1[i]);
            let k4 = (v4, a4);
            for i in 0..2 {
                r[i] += h / 6.0 * (k1.0[i] + 2.0 * k2.0[i] + 2.0 * k3.0[i] + k4.0[i]);
                v[i] += h / 6.0 * (k1.1[i] + 2.0 * k2.1[i] + 2.0 * k3.1[i] + k4.1[i]);
            }
            m.t.push(if k + 1 == SAMPLES_PER_SEGMENT {
                t1
            } else {
                t + h
            });
            m.r.push(r);
            m.v.push(v);
        }
    }
    m
}

/// Measures the solution `x` (see the module header).
pub fn validate(p: &Problem, l: &Layout, x: &[f64]) -> Validity {
    let g = [0.0, p.gravity];
    let motion = resimulate(p, l, x);
    let mut out = Validity {
        newton_residual: 0.0,
        resimulation_gap: 0.0,
        impulse_gap: 0.0,
        lowest_flight: f64::INFINITY,
        deepest_compression: 0.0,
        least_normal_force: f64::INFINITY,
        friction_ratio: 0.0,
        wall_clearance: None,
    };
    let in_contact = |t: f64| p.contacts.iter().any(|&(a, b)| t > a && t < b);
    for (k, &t) in motion.t.iter().enumerate() {
        // Inside each segment: residual of the spline's own acceleration.
        let (s, tau) = l.locate(t);
        let b = l.basis(s, tau, 2);
        for (a, ga) in g.iter().enumerate() {
            let v = l.segment_vars(s, a);
            let acc: f64 = (0..4).map(|i| b[i] * x[v[i]]).sum();
            let f = l.force_at(x, a, t);
            out.newton_residual = out
                .newton_residual
                .max((p.mass * acc - f - p.mass * ga).abs());
            let spline = l.eval(x, a, 0, t);
            out.resimulation_gap = out.resimulation_gap.max((spline - motion.r[k][a]).abs());
        }
        let y = motion.r[k][1];
        if in_contact(t) {
            out.deepest_compression = out.deepest_compression.max(-y);
            let (fx, fy) = (l.force_at(x, 0, t), l.force_at(x, 1, t));
            out.least_normal_force = out.least_normal_force.min(fy);
            if fy > 0.0 {
                out.friction_ratio = out.friction_ratio.max(fx.abs() / fy);
            }
        } else {
            out.lowest_flight = out.lowest_flight.min(y);
        }
    }
    if out.least_normal_force == f64::INFINITY {
        out.least_normal_force = 0.0;
    }
    for &(a, b) in &p.contacts {
        let (ia, ib) = (
            l.times.iter().position(|&t| t == a),
            l.times.iter().position(|&t| t == b),
        );
        let (Some(ia), Some(ib)) = (ia, ib) else {
            continue;
        };
        for axis in 0..2 {
            let mut impulse = 0.0;
            for s in ia..ib {
                let h = l.times[s + 1] - l.times[s];
                impulse += 0.5
                    * h
                    * (l.force_at(x, axis, l.times[s]) + l.force_at(x, axis, l.times[s + 1]));
            }
            let dv = x[l.var(ib, axis, true)] - x[l.var(ia, axis, true)];
            let expected = p.mass * dv - p.mass * g[axis] * (b - a);
            out.impulse_gap = out.impulse_gap.max((impulse - expected).abs());
        }
    }
    if let Some(w) = p.wall {
        for k in 1..motion.t.len() {
            let (x0, x1) = (motion.r[k - 1][0] - w.x, motion.r[k][0] - w.x);
            if x0 * x1 <= 0.0 && x0 != x1 {
                let u = x0 / (x0 - x1);
                let y = motion.r[k - 1][1] + u * (motion.r[k][1] - motion.r[k - 1][1]);
                let c = y - w.height;
                out.wall_clearance = Some(out.wall_clearance.map_or(c, |o: f64| o.min(c)));
            }
        }
    }
    out
}
