//! Pose constraints: simulated quantities read off the motion at key times and bounded,
//! `lower ≤ value(x(t)) ≤ upper` (an equality when the bounds coincide). Seed §3.5.1: pose
//! constraints are "evaluated by simply checking the appropriate physical quantity at the
//! indicated times".
//!
//! Quantities (world frame, SI units, y up): a link point's position (m) or velocity (m/s)
//! component, a scalar joint's coordinate (rad or m) or rate (rad/s or m/s), the centre of
//! mass's position or velocity component, and a contact point's height above the ground (m; the
//! "airborne" task expands to one such row per contact point).

use super::aba::Dynamics;
use super::character::Model;
use super::sim::State;
use super::spatial::{Real, Vec3};

/// What a pose constraint measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Quantity {
    /// Component `axis` (0 = x, 1 = y, 2 = z) of a link point's world position (m).
    PointPosition {
        /// Link index.
        link: usize,
        /// The point in link coordinates (m).
        point: [f64; 3],
        /// World axis.
        axis: usize,
    },
    /// Component `axis` of a link point's world velocity (m/s).
    PointVelocity {
        /// Link index.
        link: usize,
        /// The point in link coordinates (m).
        point: [f64; 3],
        /// World axis.
        axis: usize,
    },
    /// A scalar joint's coordinate (rad or m), by its index in `q`.
    JointPosition {
        /// Index into `q`.
        q_index: usize,
    },
    /// A scalar joint's rate (rad/s or m/s), by its index in `v`.
    JointVelocity {
        /// Index into `v`.
        v_index: usize,
    },
    /// Component `axis` of the centre of mass position (m).
    ComPosition {
        /// World axis.
        axis: usize,
    },
    /// Component `axis` of the centre of mass velocity (m/s).
    ComVelocity {
        /// World axis.
        axis: usize,
    },
    /// Height of a link point above the ground plane (m).
    Height {
        /// Link index.
        link: usize,
        /// The point in link coordinates (m).
        point: [f64; 3],
    },
}

impl Quantity {
    /// The quantity's value at state `x`, whose kinematics `dynamics` holds.
    pub fn value<T: Real>(&self, model: &Model, x: &State<T>, dynamics: &Dynamics<T>) -> T {
        match *self {
            Quantity::PointPosition { link, point, axis } => {
                dynamics.point_position(link, &Vec3::from_f64(point)).0[axis]
            }
            Quantity::PointVelocity { link, point, axis } => {
                dynamics.point_velocity(link, &Vec3::from_f64(point)).0[axis]
            }
            Quantity::JointPosition { q_index } => x.q[q_index],
            Quantity::JointVelocity { v_index } => x.v[v_index],
            Quantity::ComPosition { axis } => dynamics.center_of_mass(model).0.0[axis],
            Quantity::ComVelocity { axis } => dynamics.center_of_mass(model).1.0[axis],
            Quantity::Height { link, point } => {
                dynamics.point_position(link, &Vec3::from_f64(point)).0[1] - model.contact.ground
            }
        }
    }
}

/// One pose-constraint row: `lower ≤ quantity(t) ≤ upper`.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseConstraint {
    /// A readable name for logs, e.g. `"t=1.000 head.y ≥ 0.5"`.
    pub name: String,
    /// Key time (s).
    pub time: f64,
    /// RK4 steps from the start to `time`.
    pub step: usize,
    /// What is measured.
    pub quantity: Quantity,
    /// Lower bound (−∞ for none).
    pub lower: f64,
    /// Upper bound (+∞ for none).
    pub upper: f64,
}
