//! Drawn-body validity: how far any link's drawn (and inertial) shape passes below the ground
//! over a motion, and how much of that the contact points do not account for.
//!
//! The contact law pushes only on the contact points (eq. 3.26–3.27), so a motion can meet
//! every task row while a part of a link's shape that carries no contact point sinks through
//! the floor (a lamp standing on the rim of its shade with the shade's rounded cap drawn 4 cm
//! below the ground). For each RK4 step `k` of the rollout and each link `i` with world-to-link
//! transform `(E, r)`, the lowest world height of its shape is, with `e_j = E` row `j` (link
//! axis `j` in world axes) and `y` the vertical component:
//! ```text
//!   box (centre c, half sides s)     c_y − Σ_j |e_j,y|·s_j
//!   sphere (centre c, radius ρ)      c_y − ρ
//!   capsule (ends a, b, radius ρ)    min(a_y, b_y) − ρ
//!   cone (apex a, base b, radius ρ)  min(a_y, b_y − ρ·√(1 − u_y²)),   u = (b − a)/|b − a|
//! ```
//! (world points `p_y = r_y + Σ_j e_j,y·p_j`). With `s_k = max_i (ground − lowest_i,k)` the
//! shapes' depth and `c_k = max(0, max_p (ground − p_y))` the contact points' depth at step `k`
//! (the contact spring lets them sink a few mm under load: 0.9–6.4 mm in the shipped files'
//! best motions, docs/notes/gait.md, "drawn-body validity"), a motion's
//! ```text
//!   depth  = max_k s_k            (m; negative when every shape stays above the ground)
//!   excess = max_k (s_k − c_k)    (m; how much deeper a shape goes than the contacts let it)
//! ```
//! A trial is a Success or Marginal only if its excess is at most [`DEPTH_TOLERANCE`] at the
//! file's step and at `dt/4` ([`judge`], from [`crate::gait::trials`]'s classification).

use serde::Serialize;

use super::character::Shape;
use super::sim::{SimError, Simulator};
use super::spatial::{Vec3, Xform};
use super::spec::Problem;
use super::spline::SplineControls;
use super::step_check::{REFINEMENT, refined};
use super::trials::TrialStatus;

/// How much deeper (m) than the contact points a drawn shape may pass below the ground in a
/// valid motion: about the contact law's own penetration (contact points sink 0.9–6.4 mm in
/// the shipped files' best motions), so a shape part without a contact that sinks further is
/// passing through the floor.
pub const DEPTH_TOLERANCE: f64 = 5e-3;

/// The deepest point of a motion's drawn shapes below the ground.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Depth {
    /// Depth below the ground (m): `s_k`, or `s_k − c_k` for the excess (module header).
    pub depth: f64,
    /// Time of the step (s).
    pub time: f64,
    /// Index of the link reaching it.
    pub link: usize,
}

impl Depth {
    fn deeper(self, other: Depth) -> Depth {
        if other.depth > self.depth {
            other
        } else {
            self
        }
    }
}

/// A motion's drawn-shape depth and its excess over the contact points' (module header).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Penetration {
    /// The shapes' deepest point below the ground.
    pub deepest: Depth,
    /// The largest depth of a shape beyond the contact points' at the same step.
    pub excess: Depth,
}

/// The lowest world height (m) of `shape` on a link with world-to-link transform `x` (module
/// header).
pub fn lowest(shape: &Shape, x: &Xform<f64>) -> f64 {
    let e = &x.e.0;
    let y = |p: &[f64; 3]| x.r.0[1] + (0..3).map(|j| e[j][1] * p[j]).sum::<f64>();
    match shape {
        Shape::Box { size, center } => {
            y(center) - (0..3).map(|j| e[j][1].abs() * 0.5 * size[j]).sum::<f64>()
        }
        Shape::Sphere { radius, center } => y(center) - radius,
        Shape::Capsule { radius, from, to } => y(from).min(y(to)) - radius,
        Shape::Cone { radius, apex, base } => {
            let d: [f64; 3] = std::array::from_fn(|k| base[k] - apex[k]);
            let len = d.iter().map(|v| v * v).sum::<f64>().sqrt();
            let uy = (0..3).map(|j| e[j][1] * d[j]).sum::<f64>() / len;
            y(apex).min(y(base) - radius * (1.0 - uy * uy).max(0.0).sqrt())
        }
    }
}

/// The drawn shapes' depth and excess (module header) over the rollout of motion `x` (spline
/// parameters, then the initial state when it is a variable) at the problem's own step, every
/// step inspected.
pub fn deepest(problem: &Problem, x: &[f64]) -> Result<Penetration, SimError> {
    let controls = SplineControls {
        grid: problem.knot_grid(),
        params: x.to_vec(),
    };
    let total = (problem.horizon / problem.dt).round() as usize;
    let steps: Vec<usize> = (0..=total).collect();
    let model = &problem.model;
    let ground = model.contact.ground;
    let mut sim = Simulator::<f64>::new(model);
    let mut state = problem.initial_of(x);
    let none = Depth {
        depth: f64::NEG_INFINITY,
        time: 0.0,
        link: 0,
    };
    let mut worst = Penetration {
        deepest: none,
        excess: none,
    };
    sim.rollout(&mut state, problem.dt, &steps, &controls, |k, _, sim| {
        let world = &sim.dynamics.world;
        let mut step = none;
        let mut contacts = 0.0f64;
        for (i, link) in model.links.iter().enumerate() {
            step = step.deeper(Depth {
                depth: ground - lowest(&link.shape, &world[i]),
                time: k as f64 * problem.dt,
                link: i,
            });
            for p in &link.contacts {
                let y = sim.dynamics.point_position(i, &Vec3(*p)).0[1];
                contacts = contacts.max(ground - y);
            }
        }
        worst.deepest = worst.deepest.deeper(step);
        worst.excess = worst.excess.deeper(Depth {
            depth: step.depth - contacts,
            ..step
        });
    })?;
    Ok(worst)
}

/// The drawn-shape depth of a trial's motion at the file's step and at `dt/`[`REFINEMENT`],
/// and its class after the depth test.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthCheck {
    /// The class: a Success or Marginal whose drawn body passes more than
    /// [`DEPTH_TOLERANCE`] deeper than its contact points at either step becomes a Failure.
    pub status: TrialStatus,
    /// The deepest point at `dt`; `None` if the rollout failed.
    pub coarse: Option<Penetration>,
    /// The deepest point at `dt/`[`REFINEMENT`]; `None` if the rollout failed.
    pub fine: Option<Penetration>,
    /// Why the class fell, when it did.
    pub downgrade: Option<String>,
}

/// Measures motion `x` of `problem` at `dt` and `dt/`[`REFINEMENT`] and judges class
/// `status` on it (module header).
pub fn judge(problem: &Problem, x: &[f64], status: TrialStatus) -> DepthCheck {
    let coarse = deepest(problem, x).ok();
    let fine = deepest(&refined(problem, REFINEMENT), x).ok();
    let worst = [coarse, fine]
        .into_iter()
        .flatten()
        .map(|p| p.excess)
        .max_by(|a, b| a.depth.total_cmp(&b.depth));
    let valid = matches!(status, TrialStatus::Success | TrialStatus::Marginal);
    let too_deep = worst.filter(|w| valid && w.depth > DEPTH_TOLERANCE);
    let downgrade = too_deep.map(|w| {
        format!(
            "{status:?} on its rows, but link `{}` passes {:.1} mm deeper below the ground than \
             the contact points at t = {:.4} s (more than {:.1} mm)",
            problem.model.links[w.link].name,
            1e3 * w.depth,
            w.time,
            1e3 * DEPTH_TOLERANCE
        )
    });
    DepthCheck {
        status: if too_deep.is_some() {
            TrialStatus::Failure
        } else {
            status
        },
        coarse,
        fine,
        downgrade,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gait::formulation::Formulation;
    use crate::gait::spatial::{Mat3, Vec3};
    use crate::spec::Source;

    /// A lamp shade standing upside down on its rim (axis pointing down, rim 8 cm across, its
    /// centre of mass over the rim) with a small actuated knob, held by zero forces for 0.2 s:
    /// the task's row (the shade's axis point `stand` m from its apex on the ground) is met.
    /// `shape` and `contacts` are the shade's; it starts with that point 2 mm up, about where
    /// the contact springs hold its weight.
    fn standing_shade(shape: &str, contacts: &str, stand: f64) -> Problem {
        let height = stand + 0.002;
        let text = format!(
            r#"
name = "shade_stand"
dt = 2e-4
gravity = [0.0, -9.81, 0.0]

[[link]]
name = "shade"
mass = 0.25
com = [0.07, 0.0, 0.0]
shape = {shape}
contacts = {contacts}
joint = {{ type = "planar", position = [0.0, {height}], angle = -1.5707963267948966 }}

[[link]]
name = "knob"
mass = 0.05
shape = {{ type = "sphere", radius = 0.01 }}
[link.joint]
type = "revolute"
parent = "shade"
axis = [0.0, 0.0, 1.0]
origin = [0.02, 0.0, 0.0]

[[actuator]]
name = "knob"
joint = "knob"
bounds = [-1.0, 1.0]

[controls]
knots = 3

[[task]]
time = 0.2
quantity = "point_position"
link = "shade"
point = [{stand}, 0.0, 0.0]
axis = "y"
min = -0.005
max = 0.005
"#
        );
        crate::gait::spec::load_source(&Source {
            path: "shade_stand.toml".into(),
            text,
        })
        .unwrap()
    }

    const CAPSULE: &str =
        r#"{ type = "capsule", radius = 0.04, from = [0.0, 0.0, 0.0], to = [0.14, 0.0, 0.0] }"#;
    const CONE: &str =
        r#"{ type = "cone", radius = 0.04, apex = [0.0, 0.0, 0.0], base = [0.14, 0.0, 0.0] }"#;
    const RIM: &str = "[[0.14, 0.04, 0.0], [0.14, -0.04, 0.0]]";
    const RIM_AND_TIP: &str = "[[0.14, 0.04, 0.0], [0.14, -0.04, 0.0], [0.18, 0.0, 0.0]]";

    /// The judged class and depth (m, at dt and dt/4) of the held motion, which meets its row.
    fn judged(p: &Problem) -> (TrialStatus, f64, f64) {
        let f = Formulation::new(p);
        let x = vec![0.0; f.reduced().parameters()];
        let rows = crate::gait::trials::assess(&f, &x).unwrap();
        assert!(rows.max() <= 1e-3, "the rim stays on the ground: {rows:?}");
        let check = judge(p, &x, TrialStatus::Success);
        let (coarse, fine) = (check.coarse.unwrap(), check.fine.unwrap());
        // Held still, the contacts sink less than a millimetre: the depth is the excess.
        for p in [coarse, fine] {
            assert!(p.deepest.depth - p.excess.depth < 1e-3, "{p:?}");
        }
        (check.status, coarse.excess.depth, fine.excess.depth)
    }

    /// Standing on the rim of a capsule-drawn shade puts its round cap ~4 cm through the
    /// floor: not a Success, though its row is met. With a contact at the cap's tip the shade
    /// stands on the tip instead, and a cone (which ends at its rim) stands on the rim: no
    /// shape deeper than the contacts.
    #[test]
    fn a_shade_standing_through_the_floor_is_not_a_success() {
        let (status, coarse, fine) = judged(&standing_shade(CAPSULE, RIM, 0.14));
        assert_eq!(status, TrialStatus::Failure);
        assert!((0.035..0.045).contains(&coarse), "{coarse}");
        assert!((coarse - fine).abs() < 1e-4, "{coarse} {fine}");
        for (shape, contacts, stand) in [(CAPSULE, RIM_AND_TIP, 0.18), (CONE, RIM, 0.14)] {
            let (status, coarse, fine) = judged(&standing_shade(shape, contacts, stand));
            assert_eq!(status, TrialStatus::Success, "{shape} {contacts}");
            assert!(coarse.max(fine) <= 0.0, "{coarse} {fine}");
        }
        // Only a Success or Marginal is judged.
        let p = standing_shade(CAPSULE, RIM, 0.14);
        let x = vec![0.0; Formulation::new(&p).reduced().parameters()];
        assert_eq!(judge(&p, &x, TrialStatus::Failure).downgrade, None);
    }

    /// The transform of a link turned by `angle` (rad) about z with its origin at `r` (m).
    fn turned(angle: f64, r: [f64; 3]) -> Xform<f64> {
        let (s, c) = angle.sin_cos();
        // Rows are the link axes in world coordinates.
        Xform {
            e: Mat3([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]),
            r: Vec3(r),
        }
    }

    #[test]
    fn lowest_points_of_turned_shapes_match_their_geometry() {
        let down = turned(-std::f64::consts::FRAC_PI_2, [0.0, 1.0, 0.0]);
        // The link's x axis points down: a capsule along x reaches 0.18 m down with its cap.
        let capsule = Shape::Capsule {
            radius: 0.04,
            from: [0.0; 3],
            to: [0.14, 0.0, 0.0],
        };
        assert!((lowest(&capsule, &down) - (1.0 - 0.18)).abs() < 1e-12);
        // A cone pointing its base down stands on its base rim, 0.14 below the apex.
        let cone = Shape::Cone {
            radius: 0.04,
            apex: [0.0; 3],
            base: [0.14, 0.0, 0.0],
        };
        assert!((lowest(&cone, &down) - (1.0 - 0.14)).abs() < 1e-12);
        // Lying flat (axis horizontal), its rim reaches a radius below the axis.
        let flat = turned(0.0, [0.0, 1.0, 0.0]);
        assert!((lowest(&cone, &flat) - (1.0 - 0.04)).abs() < 1e-12);
        // Apex down: the apex is lowest.
        let up = turned(std::f64::consts::FRAC_PI_2, [0.0, 1.0, 0.0]);
        assert!((lowest(&cone, &up) - 1.0).abs() < 1e-12);
        // Turned by 45°, a 0.2 × 0.1 box reaches (0.2 + 0.1)/2 · sin 45° below its centre.
        let tilted = turned(std::f64::consts::FRAC_PI_4, [0.0, 1.0, 0.0]);
        let b = Shape::Box {
            size: [0.2, 0.1, 0.3],
            center: [0.0; 3],
        };
        let expect = 1.0 - 0.15 * std::f64::consts::FRAC_1_SQRT_2;
        assert!((lowest(&b, &tilted) - expect).abs() < 1e-12);
        let ball = Shape::Sphere {
            radius: 0.05,
            center: [0.1, 0.0, 0.0],
        };
        assert!((lowest(&ball, &down) - (1.0 - 0.1 - 0.05)).abs() < 1e-12);
    }
}
