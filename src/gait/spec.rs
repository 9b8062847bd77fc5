//! The gait problem file: a character (links, joints, actuators, contact points), the contact
//! law, the integration step, the initial state, the actuator controls and the tasks. Parsed
//! with `deny_unknown_fields` and validated with errors positioned at the offending key.
//!
//! All quantities are SI: m, kg, s, rad, N, N·m; y is up. Layout (every key is documented on
//! its field below; the files in `problems/gait/` are complete, commented examples):
//! ```toml
//! name = "pogo_jump"
//! dt = 1e-4                     # s, RK4 step
//! gravity = [0.0, -9.81, 0.0]   # m/s²
//! [[link]]                      # parents before children; the first link is the root
//! name = "foot"
//! mass = 0.5                    # kg
//! shape = { type = "sphere", radius = 0.02, center = [0, 0, 0] }
//! contacts = [[0.0, 0.0, 0.0]]  # m, link coordinates
//! joint = { type = "planar", position = [0.0, 0.004] }
//! [[actuator]]
//! name = "leg"
//! joint = "head"                # the link whose joint it drives
//! bounds = [-200.0, 200.0]      # N or N·m
//! [controls]
//! knots = 6
//! [[task]]
//! time = 1.0
//! quantity = "point_position"
//! link = "head"
//! axis = "y"
//! min = 0.5
//! ```

use std::collections::HashMap;

use serde::Deserialize;

use super::aba::Dynamics;
use super::character::{
    Actuator, ContactParams, JointKind, Limits, Link, Model, Servo, Shape, Spring, shape_center,
    shape_inertia,
};
use super::sim::State;
use super::spatial::{Mat3, RigidInertia, Vec3};
use super::spline::KnotGrid;
use super::task::{PoseConstraint, Quantity};
use crate::error::InputError;
use crate::solver::{Interrupt, Options};
use crate::spec::{Key, Source, validate_solver};

/// The whole file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FileSpec {
    /// Problem name; defaults to the file stem.
    pub name: Option<String>,
    /// What the task is, for people.
    pub description: Option<String>,
    /// RK4 step (s).
    pub dt: f64,
    /// Gravity acceleration (m/s²); default `[0, −9.81, 0]`.
    #[serde(
        default = "default_gravity",
        deserialize_with = "crate::spec::arrays::exact"
    )]
    pub gravity: [f64; 3],
    /// Links, parents first.
    pub link: Vec<LinkSpec>,
    /// Actuators.
    #[serde(default)]
    pub actuator: Vec<ActuatorSpec>,
    /// Contact law constants (seed defaults).
    #[serde(default)]
    pub contact: ContactSpec,
    /// Control parametrization.
    #[serde(default)]
    pub controls: ControlsSpec,
    /// Pose constraints.
    #[serde(default)]
    pub task: Vec<TaskSpec>,
    /// Trials (several starts) and their success test.
    #[serde(default)]
    pub trials: TrialsSpec,
    /// The trials' low-knowledge starts.
    #[serde(default)]
    pub start: StartSpec,
    /// The derivative-free global phase before each trial's solves (none without the table).
    pub global: Option<GlobalPhaseSpec>,
    /// Solver options.
    #[serde(default)]
    pub solver: Options,
}

/// The `[trials]` table: how many starts are solved, how random starts are drawn, how force
/// splines are kept within the actuator bounds, and when a trial counts as a success.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrialsSpec {
    /// Number of trials; trial 1 starts from the hand-made profile (`[[actuator]] start`), the
    /// others from seeded random perturbations of it. Default 8 (seed: 8).
    pub count: Option<usize>,
    /// Pose-constraint tolerance in each constraint's unit (m, rad, m/s, rad/s); default 1e-3.
    pub tolerance: Option<f64>,
    /// Random knot perturbations are uniform in ±`spread`·(half the actuator's force range);
    /// default 0.3, in [0, 1].
    pub spread: Option<f64>,
    /// Fraction of half the force range reserved for the spline's excursion between knots;
    /// default 0.2, in (0, 1).
    pub slope_margin: Option<f64>,
    /// Unproductive re-solves (not halving the violation sum) of a trial that stopped short
    /// of success (not by a budget); default 1.
    pub restarts: Option<usize>,
    /// Run the Levenberg–Marquardt feasibility phase ([`crate::gait::feasibility`]) before
    /// each SQP solve; default false.
    pub feasibility_first: Option<bool>,
    /// Key-time continuation stages before the feasibility phase
    /// ([`crate::gait::continuation`]); default 0 (none), at most 50.
    pub continuation_stages: Option<usize>,
    /// Steps per shaping stage ([`crate::gait::shaping`]): with N ≥ 1 the shaping rows are
    /// met in stages of growing horizon, each stage's rows approached in N steps of their
    /// bounds, without the effort; default 0 (one shaped solve with the effort).
    pub shaping_stages: Option<usize>,
}

/// What a trial's start is built from (`[start] kind`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StartKind {
    /// The hand-made knot forces `[[actuator]] start` (zeros where an actuator has none).
    #[default]
    Given,
    /// Zero force on every actuator.
    Zero,
    /// Knot values drawn uniformly in ±`amplitude`·(half the force range), for every trial.
    Random,
}

/// The `[start]` table: the low-knowledge starts the trials (and their global phase) begin
/// from.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartSpec {
    /// "given" (default), "zero" or "random".
    pub kind: Option<StartKind>,
    /// `kind = "random"`: fraction of half the force range; default 0.3, in [0, 1].
    pub amplitude: Option<f64>,
}

/// Validated `[start]` settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StartSettings {
    /// What trial starts are built from.
    pub kind: StartKind,
    /// Random knot amplitude, a fraction of half the force range (`kind = "random"`).
    pub amplitude: f64,
}

/// The `[global]` table: a CMA-ES phase over rollouts before each trial's solves
/// ([`crate::gait::global`]).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GlobalPhaseSpec {
    /// Most generations per trial; default 300, in 1..=100000.
    pub generations: Option<usize>,
    /// Most rollouts per trial; default 3000, in 1..=10000000.
    pub evaluations: Option<usize>,
    /// Candidates per generation (λ); default `4 + ⌊3 ln n⌋`, in 2..=10000.
    pub population: Option<usize>,
    /// Initial step size, a fraction of half the force range; default 0.3, in (0, 2].
    pub sigma: Option<f64>,
    /// Whether the fitness ranks the shaping stages lexicographically; default false.
    pub staged: Option<bool>,
    /// Whether the phase runs only when the solves from the trial's own start fall short of
    /// Success (true), instead of before them (false, the default).
    pub fallback: Option<bool>,
    /// The phase's rollouts take RK4 steps of `coarsening·dt`; default 1, in 1..=64, and every
    /// task and shaping time a multiple of that step.
    pub coarsening: Option<usize>,
}

/// Validated `[global]` settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlobalSettings {
    /// Most generations per trial.
    pub generations: usize,
    /// Most rollouts per trial.
    pub evaluations: usize,
    /// Candidates per generation (`None`: CMA-ES's default).
    pub population: Option<usize>,
    /// Initial step size (fraction of half the force range).
    pub sigma: f64,
    /// Fitness by stages: the first shaping stage with a row unmet decides the rank
    /// ([`crate::gait::global`]).
    pub staged: bool,
    /// The phase runs only when the solves from the trial's start fall short of Success
    /// ([`crate::gait::trials`]); otherwise it leads every trial's solves.
    pub fallback: bool,
    /// The phase's rollout step as a multiple of the file's `dt` (≥ 1).
    pub coarsening: usize,
}

/// Validated `[trials]` settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrialSettings {
    /// Number of trials (≥ 1).
    pub count: usize,
    /// Pose-constraint tolerance (constraint units).
    pub tolerance: f64,
    /// Random perturbation amplitude, a fraction of the half force range.
    pub spread: f64,
    /// Fraction of the half force range kept free for between-knot excursions.
    pub slope_margin: f64,
    /// Re-solves from the end point of a trial that stopped short of success, counting only
    /// those that do not halve the violation sum.
    pub restarts: usize,
    /// Levenberg–Marquardt feasibility phase before the SQP solve.
    pub feasibility_first: bool,
    /// Key-time continuation stages run by the feasibility phase (0: none).
    pub continuation_stages: usize,
    /// Steps per shaping stage (0: one shaped solve with the effort;
    /// [`crate::gait::shaping`]).
    pub shaping_stages: usize,
}

fn default_gravity() -> [f64; 3] {
    [0.0, -9.81, 0.0]
}

/// One rigid link and its joint.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkSpec {
    /// Unique name.
    pub name: String,
    /// Mass (kg), positive.
    pub mass: f64,
    /// Centre of mass in link coordinates (m); default the shape's centre.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt")]
    pub com: Option<[f64; 3]>,
    /// Principal moments about the centre of mass along link axes `[Ixx, Iyy, Izz]` (kg·m²);
    /// default: the uniform solid `shape` of this mass.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt")]
    pub inertia: Option<[f64; 3]>,
    /// Products of inertia `[Ixy, Ixz, Iyz]` (kg·m²); default zero.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt")]
    pub inertia_products: Option<[f64; 3]>,
    /// Display shape (link coordinates, m).
    #[serde(deserialize_with = "crate::spec::tagged::deserialize")]
    pub shape: ShapeSpec,
    /// Contact points in link coordinates (m).
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_vec")]
    pub contacts: Vec<[f64; 3]>,
    /// The joint attaching this link to its parent (the root's: to the world).
    pub joint: JointSpec,
}

/// Display shape.
///
/// Read from a table whose `type` key names the variant ([`crate::spec::tagged`]).
#[derive(Debug, Clone, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum ShapeSpec {
    /// A box of full side lengths `size` (m) centred at `center` (m).
    Box {
        /// Side lengths (m).
        #[serde(deserialize_with = "crate::spec::arrays::exact")]
        size: [f64; 3],
        /// Centre (m); default origin.
        #[serde(default, deserialize_with = "crate::spec::arrays::exact")]
        center: [f64; 3],
    },
    /// A capsule of `radius` (m) from `from` to `to` (m).
    Capsule {
        /// Radius (m).
        radius: f64,
        /// First end (m).
        #[serde(deserialize_with = "crate::spec::arrays::exact")]
        from: [f64; 3],
        /// Second end (m).
        #[serde(deserialize_with = "crate::spec::arrays::exact")]
        to: [f64; 3],
    },
    /// A sphere of `radius` (m) centred at `center`.
    Sphere {
        /// Radius (m).
        radius: f64,
        /// Centre (m); default origin.
        #[serde(default, deserialize_with = "crate::spec::arrays::exact")]
        center: [f64; 3],
    },
    /// A solid right circular cone of base `radius` (m) from its `apex` to its `base` centre (m).
    Cone {
        /// Base radius (m).
        radius: f64,
        /// Apex (m).
        #[serde(deserialize_with = "crate::spec::arrays::exact")]
        apex: [f64; 3],
        /// Centre of the base (m).
        #[serde(deserialize_with = "crate::spec::arrays::exact")]
        base: [f64; 3],
    },
}

/// Joint type.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JointType {
    /// Rotation about `axis` (rad).
    Revolute,
    /// Translation along `axis` (m).
    Prismatic,
    /// Root only: x, y translation and rotation about z (2-D characters).
    Planar,
    /// Root only: six degrees of freedom (3-D characters).
    Floating,
}

/// A number or a list of numbers.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum Numbers {
    /// One number.
    One(f64),
    /// Several.
    Many(Vec<f64>),
}

impl Numbers {
    fn as_slice(&self) -> &[f64] {
        match self {
            Numbers::One(x) => std::slice::from_ref(x),
            Numbers::Many(v) => v,
        }
    }
}

/// A joint and its initial state.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointSpec {
    /// Joint type.
    #[serde(rename = "type")]
    pub kind: JointType,
    /// Parent link's name; omitted for the root (attached to the world).
    pub parent: Option<String>,
    /// Joint frame origin in the parent's frame (m); default origin.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact")]
    pub origin: [f64; 3],
    /// Axis of a revolute or prismatic joint (parent frame; normalized); default `[0, 0, 1]`.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt")]
    pub axis: Option<[f64; 3]>,
    /// Coordinate limits `[lower, upper]` (rad or m) of a scalar joint.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt")]
    pub limits: Option<[f64; 2]>,
    /// Stiffness of the limit springs (N·m/rad or N/m); default 100.
    pub limit_stiffness: Option<f64>,
    /// Smoothing width of the limit springs (rad or m); default 0.005.
    pub limit_width: Option<f64>,
    /// Passive spring stiffness (N·m/rad or N/m); default 0.
    #[serde(default)]
    pub stiffness: f64,
    /// Passive spring rest coordinate (rad or m); default 0.
    #[serde(default)]
    pub rest: f64,
    /// Passive damping (N·m·s/rad or N·s/m); default 0.
    #[serde(default)]
    pub damping: f64,
    /// Initial coordinate: scalar joints a number (rad or m); planar `[x, y]`, floating
    /// `[x, y, z]` (m, world position of the link frame).
    pub position: Option<Numbers>,
    /// Planar root: initial rotation about z (rad).
    pub angle: Option<f64>,
    /// Floating root: initial orientation as a quaternion `[w, x, y, z]` (normalized).
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt")]
    pub orientation: Option<[f64; 4]>,
    /// Initial rate: scalar joints a number (rad/s or m/s); planar `[vx, vy]`, floating
    /// `[vx, vy, vz]` (m/s, world velocity of the link frame's origin).
    pub velocity: Option<Numbers>,
    /// Root: initial angular velocity, planar a number (rad/s about z), floating `[ωx, ωy, ωz]`
    /// (world axes).
    pub angular_velocity: Option<Numbers>,
}

/// An actuator.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActuatorSpec {
    /// Unique name.
    pub name: String,
    /// The link whose (scalar) joint it drives.
    pub joint: String,
    /// Force bounds `[lower, upper]` (N·m for revolute, N for prismatic joints).
    #[serde(deserialize_with = "crate::spec::arrays::exact")]
    pub bounds: [f64; 2],
    /// Starting guess: control at each knot (force, N·m or N; for a servo the set-point offset,
    /// rad or m); default zeros.
    pub start: Option<Vec<f64>>,
    /// A position servo (`{ stiffness = kp, damping = kd }`, N·m/rad and N·m·s/rad, or N/m
    /// and N·s/m): the actuator's controls are then set-point offsets from the joint's initial
    /// coordinate, boxed by the joint's limits (required), and its force is the saturated servo
    /// law of [`crate::gait::character::Servo`]. Default: none (the controls are the forces).
    pub servo: Option<ServoSpec>,
}

/// A position servo's gains.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ServoSpec {
    /// Proportional gain kp > 0 (N·m/rad or N/m).
    pub stiffness: f64,
    /// Rate gain kd ≥ 0 (N·m·s/rad or N·s/m).
    pub damping: f64,
}

/// Contact law constants; see [`crate::gait::contact`]. All optional, seed values by default.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    /// a (N), seed 0.5336.
    pub spring_force: Option<f64>,
    /// b (1/m), seed 700.
    pub spring_rate: Option<f64>,
    /// y₀ (m), seed 0.0035423.
    pub spring_offset: Option<f64>,
    /// d (N·s/m), seed 1000.
    pub damping: Option<f64>,
    /// r (1/m), seed 200.
    pub damping_rate: Option<f64>,
    /// k (dimensionless), seed 10.
    pub damping_factor: Option<f64>,
    /// g₀ (m), seed 0.005.
    pub damping_offset: Option<f64>,
    /// Coulomb friction coefficient μ; default 0.8.
    pub friction: Option<f64>,
    /// Friction regularization speed (m/s); default 0.01.
    pub slip_speed: Option<f64>,
    /// Ground height (m); default 0.
    pub ground: Option<f64>,
}

/// Control parametrization.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControlsSpec {
    /// Hermite knots per actuator, evenly spaced over `[0, horizon]`; default 6 (seed: 6–8).
    pub knots: Option<usize>,
    /// Control horizon (s); default the last task time.
    pub horizon: Option<f64>,
    /// Multiple-shooting segments over `[0, last task time]`, of equal length; default 1
    /// (single shooting). Excludes `shooting_times`.
    pub shooting_segments: Option<usize>,
    /// Multiple shooting split at these times (s, ascending, multiples of `dt` strictly between
    /// 0 and the last task time). Excludes `shooting_segments`.
    pub shooting_times: Option<Vec<f64>>,
    /// The initial state as variables, within the given half-widths of the file's initial state.
    pub initial_state: Option<InitialStateSpec>,
}

/// Half-widths of the initial-state variables' box around the file's initial state: one number
/// for every coordinate, or one per coordinate (`nq` positions, `nv` velocities, in the model's
/// coordinate order: root first). Zero fixes a coordinate.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialStateSpec {
    /// Position half-widths (m or rad).
    pub position: Numbers,
    /// Velocity half-widths (m/s or rad/s).
    pub velocity: Numbers,
}

/// Simulated quantity a task constrains.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum QuantitySpec {
    /// A link point's world position component (m).
    PointPosition,
    /// A link point's world velocity component (m/s).
    PointVelocity,
    /// A scalar joint's coordinate (rad or m).
    JointPosition,
    /// A scalar joint's rate (rad/s or m/s).
    JointVelocity,
    /// The centre of mass position component (m).
    ComPosition,
    /// The centre of mass velocity component (m/s).
    ComVelocity,
    /// Every contact point at least `min` above the ground (m).
    Airborne,
}

/// World axis name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Axis {
    /// x (forward).
    X,
    /// y (up).
    Y,
    /// z.
    Z,
}

/// A pose constraint.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskSpec {
    /// Key time (s), a multiple of `dt` within the horizon.
    pub time: f64,
    /// What is constrained.
    pub quantity: QuantitySpec,
    /// Link (point and airborne-free quantities) or joint (the link whose joint) name.
    pub link: Option<String>,
    /// Point on the link (m, link coordinates); default the link origin.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt")]
    pub point: Option<[f64; 3]>,
    /// World axis of a vector quantity.
    pub axis: Option<Axis>,
    /// Lower bound (quantity's unit).
    pub min: Option<f64>,
    /// Upper bound (quantity's unit).
    pub max: Option<f64>,
    /// Equality target (quantity's unit); excludes `min` and `max`.
    pub value: Option<f64>,
    /// A shaping row: part of each trial's first solve only, a guide towards the kind of
    /// motion the task implies (e.g. "land flat"), not part of the task or its success test.
    #[serde(default)]
    pub shaping: bool,
}

/// A box of states `(lower, upper)`, each `q` then `v` (the model's units).
pub type StateBox = (Vec<f64>, Vec<f64>);

/// A validated gait problem.
#[derive(Debug, Clone)]
pub struct Problem {
    /// Name.
    pub name: String,
    /// The character.
    pub model: Model,
    /// Initial state.
    pub initial: State<f64>,
    /// RK4 step (s).
    pub dt: f64,
    /// Knots per actuator.
    pub knots: usize,
    /// Control horizon (s).
    pub horizon: f64,
    /// Multiple-shooting segments (1 = single shooting; `crate::gait::reduced`); with
    /// `shooting_steps` non-empty, its length + 1.
    pub segments: usize,
    /// Interior segment boundaries in RK4 steps (`[controls] shooting_times`), ascending; empty
    /// for `segments` equal segments.
    pub shooting_steps: Vec<usize>,
    /// The initial state's variable box `(lower, upper)` (`q` then `v`), when the initial state
    /// is a variable (`[controls] initial_state`).
    pub initial_box: Option<StateBox>,
    /// Starting knot forces per actuator (N·m or N).
    pub start: Vec<Vec<f64>>,
    /// Pose constraints, ordered by time.
    pub constraints: Vec<PoseConstraint>,
    /// Shaping rows (`[[task]] shaping = true`), ordered by time: added to the constraints in
    /// each trial's first solve only ([`Problem::shaped`]).
    pub shaping: Vec<PoseConstraint>,
    /// Trial settings.
    pub trials: TrialSettings,
    /// What the trials start from.
    pub starts: StartSettings,
    /// The global phase, when the file asks for one.
    pub global: Option<GlobalSettings>,
    /// Solver options table.
    pub solver: Options,
    /// The run's interrupt flag, polled by every rollout of this problem's NLPs (a run sets it
    /// from its options; a loaded problem has a fresh, lowered one).
    pub interrupt: Interrupt,
}

impl Problem {
    /// The problem whose constraints are the task's and the shaping rows together (ordered by
    /// time), without shaping rows of its own.
    pub fn shaped(&self) -> Problem {
        self.shaped_until(f64::INFINITY)
    }

    /// The problem whose constraints are the task's and the shaping rows at times up to
    /// `time` (s), ordered by time, without shaping rows of its own; it is simulated only to
    /// its last row's time.
    pub fn shaped_until(&self, time: f64) -> Problem {
        let mut p = self.clone();
        p.constraints.append(&mut p.shaping);
        p.constraints.retain(|c| c.time <= time);
        p.constraints.sort_by(|a, b| a.time.total_cmp(&b.time));
        p
    }

    /// The horizons (s) of the shaping stages before the last (`[trials] shaping_stages`): the
    /// distinct times of the shaping rows before the task's last row, ascending; empty
    /// without the setting.
    pub fn shaping_horizons(&self) -> Vec<f64> {
        let last = self.constraints.last().map_or(0.0, |c| c.time);
        let mut times: Vec<f64> = if self.trials.shaping_stages > 0 {
            self.shaping
                .iter()
                .map(|c| c.time)
                .filter(|&t| t < last)
                .collect()
        } else {
            Vec::new()
        };
        times.sort_by(f64::total_cmp);
        times.dedup();
        times
    }

    /// The control splines' knot grid: `knots` knots spread evenly over the horizon (s).
    pub fn knot_grid(&self) -> KnotGrid {
        KnotGrid {
            knots: self.knots,
            horizon: self.horizon,
        }
    }

    /// Number of spline parameters (values and slopes of every actuator's knots); the motion's
    /// variables start with them.
    pub fn spline_parameters(&self) -> usize {
        self.model.actuators.len() * 2 * self.knots
    }

    /// Number of motion parameters: the spline parameters, then the initial state `(q, v)` when
    /// it is a variable. One rollout of these from t = 0 is the motion.
    pub fn motion_parameters(&self) -> usize {
        self.spline_parameters()
            + self
                .initial_box
                .as_ref()
                .map_or(0, |_| self.model.nq + self.model.nv)
    }

    /// The initial state of the motion with parameters `x` (spline parameters, then the initial
    /// state when it is a variable): the file's when it is not a variable or `x` stops short.
    pub fn initial_of(&self, x: &[f64]) -> State<f64> {
        let (n0, nq) = (self.spline_parameters(), self.model.nq);
        let n1 = n0 + nq + self.model.nv;
        if self.initial_box.is_some() && x.len() >= n1 {
            State {
                q: x[n0..n0 + nq].to_vec(),
                v: x[n0 + nq..n1].to_vec(),
            }
        } else {
            self.initial.clone()
        }
    }
}

/// Parses and validates a problem file's text.
pub fn load_source(source: &Source) -> Result<Problem, InputError> {
    let file: FileSpec = source.parse()?;
    build(source, file)
}

type Path<'a> = Vec<Key<'a>>;

fn path<'a>(keys: &[Key<'a>]) -> Path<'a> {
    keys.to_vec()
}

fn finite_all(xs: &[f64]) -> bool {
    xs.iter().all(|x| x.is_finite())
}

fn unit(v: [f64; 3]) -> Option<[f64; 3]> {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    (n > 1e-12 && n.is_finite()).then(|| v.map(|x| x / n))
}

fn build(source: &Source, file: FileSpec) -> Result<Problem, InputError> {
    let err = |p: Path<'_>, msg: String| source.error_at(&p, msg);
    validate_solver(&file.solver, source, &[Key::Name("solver")])?;
    if !(file.dt > 0.0 && file.dt <= 0.01) {
        return Err(err(
            path(&["dt".into()]),
            format!("`dt` must be in (0, 0.01] s, got {}", file.dt),
        ));
    }
    source.finite_vector(&[Key::Name("gravity")], &file.gravity)?;
    if file.link.is_empty() {
        return Err(err(path(&[]), "at least one [[link]] is required".into()));
    }
    let (links, index) = build_links(source, &file.link)?;
    let contact = build_contact(source, &file.contact)?;
    let actuators = build_actuators(source, &file.actuator, &index, &links)?;
    let mut model = Model::new(links, actuators, file.gravity, contact);
    let initial = build_initial(source, &file, &model)?;
    set_servo_rests(&mut model, &initial);
    check_contacts_above_ground(source, &model, &initial)?;

    let knots = file.controls.knots.unwrap_or(6);
    if !(2..=100).contains(&knots) {
        return Err(err(
            path(&["controls".into(), "knots".into()]),
            format!("`knots` must be in 2..=100, got {knots}"),
        ));
    }
    let start = build_knot_starts(source, &file.actuator, knots)?;
    let (constraints, shaping) = build_tasks(source, &file, &model, &index)?;
    let last = constraints
        .iter()
        .chain(&shaping)
        .map(|c| c.time)
        .fold(0.0, f64::max);
    let horizon = file.controls.horizon.unwrap_or(last);
    let hat = path(&["controls".into(), "horizon".into()]);
    if !(horizon > 0.0 && horizon.is_finite()) {
        return Err(err(
            hat,
            "`horizon` must be positive seconds (or give at least one task)".into(),
        ));
    }
    source.within_limit(
        &hat,
        horizon / file.dt,
        MAX_STEPS as f64,
        "RK4 steps of `dt`",
    )?;
    if last > horizon + 1e-12 {
        return Err(err(
            hat,
            format!("`horizon` {horizon} s ends before the last task time {last} s"),
        ));
    }
    let name = file.name.clone().unwrap_or_else(|| {
        source
            .path
            .file_stem()
            .map_or("gait".into(), |s| s.to_string_lossy().into_owned())
    });
    let segments = file.controls.shooting_segments.unwrap_or(1);
    let last_step = constraints.last().map_or(0, |c| c.step);
    if segments == 0 || (segments > 1 && segments > last_step) {
        return Err(err(
            path(&["controls".into(), "shooting_segments".into()]),
            format!(
                "`shooting_segments` must be in 1..={} (one RK4 step per segment at least), got {segments}",
                last_step.max(1)
            ),
        ));
    }
    let shooting_steps = build_shooting_times(source, &file, dt_steps(file.dt), last_step)?;
    let segments = if shooting_steps.is_empty() {
        segments
    } else {
        shooting_steps.len() + 1
    };
    let initial_box = build_initial_box(source, &file, &model, &initial)?;
    let trials = build_trials(source, &file.trials)?;
    let starts = build_start(source, &file.start)?;
    let global = file
        .global
        .as_ref()
        .map(|g| build_global(source, g))
        .transpose()?;
    if let Some(g) = &global
        && let Some(c) = constraints
            .iter()
            .chain(&shaping)
            .find(|c| !c.step.is_multiple_of(g.coarsening))
    {
        return Err(source.error_at(
            &[Key::Name("global"), Key::Name("coarsening")],
            format!(
                "every task time must be a multiple of `coarsening`·dt = {} s, got {} s",
                g.coarsening as f64 * file.dt,
                c.time
            ),
        ));
    }
    Ok(Problem {
        name,
        model,
        initial,
        dt: file.dt,
        knots,
        horizon,
        segments,
        shooting_steps,
        initial_box,
        start,
        constraints,
        shaping,
        trials,
        starts,
        global,
        solver: file.solver,
        interrupt: Interrupt::new(),
    })
}

/// The key path `link[i].joint.<key>`.
fn joint_key(i: usize, key: &str) -> Vec<Key<'_>> {
    vec![
        Key::Name("link"),
        Key::Index(i),
        Key::Name("joint"),
        Key::Name(key),
    ]
}

/// The links in file order with their joints, and each link's index by name (a parent must be
/// listed before its children).
fn build_links<'a>(
    source: &Source,
    specs: &'a [LinkSpec],
) -> Result<(Vec<Link>, HashMap<&'a str, usize>), InputError> {
    let mut index: HashMap<&str, usize> = HashMap::new();
    let mut links = Vec::new();
    for (i, l) in specs.iter().enumerate() {
        if index.insert(l.name.as_str(), i).is_some() {
            return Err(source.error_at(
                &[Key::Name("link"), Key::Index(i), Key::Name("name")],
                format!("link name `{}` is used twice", l.name),
            ));
        }
        links.push(build_link(source, i, l, &index)?);
    }
    Ok((links, index))
}

/// Link `i`: its mass properties (from `shape` unless given), contacts and joint.
fn build_link(
    source: &Source,
    i: usize,
    l: &LinkSpec,
    index: &HashMap<&str, usize>,
) -> Result<Link, InputError> {
    let at = |key: &'static str| vec![Key::Name("link"), Key::Index(i), Key::Name(key)];
    source.positive_quantity(&at("mass"), l.mass, "kg")?;
    let shape = build_shape(&l.shape).map_err(|m| source.error_at(&at("shape"), m))?;
    let com = l.com.unwrap_or_else(|| shape_center(&shape));
    source.finite_vector(&at("com"), &com)?;
    let mut inertia = shape_inertia(&shape, l.mass);
    if let Some(d) = l.inertia {
        inertia = [[d[0], 0.0, 0.0], [0.0, d[1], 0.0], [0.0, 0.0, d[2]]];
    }
    if let Some([xy, xz, yz]) = l.inertia_products {
        inertia[0][1] = xy;
        inertia[1][0] = xy;
        inertia[0][2] = xz;
        inertia[2][0] = xz;
        inertia[1][2] = yz;
        inertia[2][1] = yz;
    }
    let key = if l.inertia.is_some() || l.inertia_products.is_some() {
        "inertia"
    } else {
        "shape"
    };
    source.ensure(&at(key), positive_definite(&inertia), || {
        "the rotational inertia must be positive definite (check moments, products and the triangle inequality)".into()
    })?;
    for c in &l.contacts {
        source.ensure(&at("contacts"), finite_all(c), || {
            "contact points must be finite".into()
        })?;
    }
    let (parent, joint) = build_joint_kind(source, i, l, index)?;
    let j = &l.joint;
    let jat = |key: &'static str| joint_key(i, key);
    source.finite_vector(&jat("origin"), &j.origin)?;
    let scalar = joint.is_scalar();
    for (key, present) in [
        ("axis", j.axis.is_some()),
        ("limits", j.limits.is_some()),
        ("limit_stiffness", j.limit_stiffness.is_some()),
        ("limit_width", j.limit_width.is_some()),
    ] {
        source.ensure(&jat(key), !present || scalar, || {
            format!("`{key}` applies to revolute and prismatic joints only")
        })?;
    }
    source.ensure(
        &jat("stiffness"),
        scalar || (j.stiffness == 0.0 && j.damping == 0.0 && j.rest == 0.0),
        || "passive springs apply to revolute and prismatic joints only".into(),
    )?;
    Ok(Link {
        name: l.name.clone(),
        parent,
        joint,
        origin: j.origin,
        inertia: RigidInertia {
            mass: l.mass,
            com: Vec3(com),
            inertia_com: Mat3(inertia),
        },
        spring: build_spring(source, &jat("stiffness"), j)?,
        limits: build_limits(source, &jat, j)?,
        shape,
        contacts: l.contacts.clone(),
        q_index: 0,
        v_index: 0,
    })
}

/// Link `i`'s parent (none for the root, the first link) and its joint's kind.
fn build_joint_kind(
    source: &Source,
    i: usize,
    l: &LinkSpec,
    index: &HashMap<&str, usize>,
) -> Result<(Option<usize>, JointKind), InputError> {
    let err = |key: &'static str, msg: String| source.error_at(&joint_key(i, key), msg);
    let j = &l.joint;
    let parent = match &j.parent {
        None if i == 0 => None,
        None => {
            return Err(err(
                "type",
                format!(
                    "link `{}` needs a `parent` (only the first link is the root)",
                    l.name
                ),
            ));
        }
        Some(_) if i == 0 => {
            return Err(err(
                "parent",
                "the first link is the root and is attached to the world: remove `parent`".into(),
            ));
        }
        Some(p) => match index.get(p.as_str()) {
            Some(&k) if k < i => Some(k),
            _ => {
                return Err(err(
                    "parent",
                    format!("parent `{p}` is not a link listed before `{}`", l.name),
                ));
            }
        },
    };
    let kind = match j.kind {
        JointType::Revolute | JointType::Prismatic => {
            let axis = unit(j.axis.unwrap_or([0.0, 0.0, 1.0]))
                .ok_or_else(|| err("axis", "`axis` must be a non-zero finite vector".into()))?;
            if j.kind == JointType::Revolute {
                JointKind::Revolute { axis }
            } else {
                JointKind::Prismatic { axis }
            }
        }
        JointType::Planar | JointType::Floating if i > 0 => {
            return Err(err(
                "type",
                "planar and floating joints attach the root (first link) to the world".into(),
            ));
        }
        JointType::Planar => JointKind::Planar,
        JointType::Floating => JointKind::Floating,
    };
    Ok((parent, kind))
}

/// The joint's passive spring-damper, if it has a stiffness or a damping.
fn build_spring(
    source: &Source,
    at: &[Key<'_>],
    j: &JointSpec,
) -> Result<Option<Spring>, InputError> {
    if j.stiffness == 0.0 && j.damping == 0.0 {
        return Ok(None);
    }
    source.ensure(
        at,
        j.stiffness >= 0.0
            && j.damping >= 0.0
            && j.stiffness.is_finite()
            && j.damping.is_finite()
            && j.rest.is_finite(),
        || "`stiffness` and `damping` must be finite and non-negative".into(),
    )?;
    Ok(Some(Spring {
        stiffness: j.stiffness,
        rest: j.rest,
        damping: j.damping,
    }))
}

/// The joint's range with its soft-limit stiffness and width, if `limits` is given.
fn build_limits<'k>(
    source: &Source,
    jat: &impl Fn(&'static str) -> Vec<Key<'k>>,
    j: &JointSpec,
) -> Result<Option<Limits>, InputError> {
    let Some([lo, hi]) = j.limits else {
        return Ok(None);
    };
    source.ordered_pair(&jat("limits"), [lo, hi])?;
    let stiffness = j.limit_stiffness.unwrap_or(100.0);
    let width = j.limit_width.unwrap_or(0.005);
    source.ensure(
        &jat("limit_stiffness"),
        stiffness > 0.0 && stiffness.is_finite(),
        || "`limit_stiffness` must be positive".into(),
    )?;
    source.ensure(&jat("limit_width"), width > 0.0 && width < hi - lo, || {
        "`limit_width` must be positive and smaller than the range".into()
    })?;
    Ok(Some(Limits {
        lower: lo,
        upper: hi,
        stiffness,
        width,
    }))
}

/// The actuators, each driving one revolute or prismatic joint (at most one per joint).
fn build_actuators(
    source: &Source,
    specs: &[ActuatorSpec],
    index: &HashMap<&str, usize>,
    links: &[Link],
) -> Result<Vec<Actuator>, InputError> {
    let mut actuators: Vec<Actuator> = Vec::new();
    let mut names = HashMap::new();
    for (a, spec) in specs.iter().enumerate() {
        let at = |key: &'static str| vec![Key::Name("actuator"), Key::Index(a), Key::Name(key)];
        source.ensure(
            &at("name"),
            names.insert(spec.name.as_str(), a).is_none(),
            || format!("actuator name `{}` is used twice", spec.name),
        )?;
        let link = *index.get(spec.joint.as_str()).ok_or_else(|| {
            source.error_at(&at("joint"), format!("no link named `{}`", spec.joint))
        })?;
        source.ensure(&at("joint"), links[link].joint.is_scalar(), || {
            "actuators drive revolute or prismatic joints only".into()
        })?;
        source.ensure(
            &at("joint"),
            !actuators.iter().any(|x| x.link == link),
            || format!("joint `{}` already has an actuator", spec.joint),
        )?;
        source.ordered_pair(&at("bounds"), spec.bounds)?;
        let servo = match &spec.servo {
            None => None,
            Some(sv) => {
                let mut key = at("servo");
                key.push(Key::Name("stiffness"));
                source.positive(&key, sv.stiffness)?;
                key.pop();
                key.push(Key::Name("damping"));
                source.non_negative(&key, sv.damping)?;
                let limits = links[link].limits.ok_or_else(|| {
                    source.error_at(
                        &at("servo"),
                        format!("a servo needs limits on joint `{}`", spec.joint),
                    )
                })?;
                // The rest and offsets are set from the initial state ([`set_servo_rests`]).
                Some(Servo {
                    stiffness: sv.stiffness,
                    damping: sv.damping,
                    rest: 0.0,
                    offsets: [limits.lower, limits.upper],
                })
            }
        };
        actuators.push(Actuator {
            name: spec.name.clone(),
            link,
            bounds: spec.bounds,
            servo,
        });
    }
    Ok(actuators)
}

/// Each servo's set point at zero control is its joint's initial coordinate; its control range
/// is the joint's limits less that.
fn set_servo_rests(model: &mut Model, initial: &State<f64>) {
    for a in &mut model.actuators {
        if let Some(s) = &mut a.servo {
            let rest = initial.q[model.links[a.link].q_index];
            s.rest = rest;
            s.offsets = [s.offsets[0] - rest, s.offsets[1] - rest];
        }
    }
}

/// Each actuator's start forces, one per knot (zero unless given).
fn build_knot_starts(
    source: &Source,
    specs: &[ActuatorSpec],
    knots: usize,
) -> Result<Vec<Vec<f64>>, InputError> {
    let mut start = Vec::new();
    for (a, spec) in specs.iter().enumerate() {
        let at = [Key::Name("actuator"), Key::Index(a), Key::Name("start")];
        let s = spec.start.clone().unwrap_or_else(|| vec![0.0; knots]);
        source.ensure(&at, s.len() == knots, || {
            format!(
                "`start` needs one force per knot ({knots}), got {}",
                s.len()
            )
        })?;
        source.finite_vector(&at, &s)?;
        start.push(s);
    }
    Ok(start)
}

/// Most RK4 steps one rollout may take (task times and the horizon over `dt`): ten times the
/// longest shipped motion, so that a `--check` or a solve never starts an hour-long rollout.
pub const MAX_STEPS: usize = 50_000;

/// How far, m, a contact point may start below the ground: the contact spring pushes
/// exponentially harder with depth (e^{700·depth}), so a deeper start blows the simulation up.
pub const MAX_START_PENETRATION: f64 = 0.01;

/// Every contact point starts above the ground, or at most [`MAX_START_PENETRATION`] into it;
/// the error points at the contact point and names its depth.
fn check_contacts_above_ground(
    source: &Source,
    model: &Model,
    initial: &State<f64>,
) -> Result<(), InputError> {
    let mut dynamics = Dynamics::<f64>::new(model);
    dynamics.kinematics(model, &initial.q, &initial.v);
    for (i, link) in model.links.iter().enumerate() {
        for (c, point) in link.contacts.iter().enumerate() {
            let y = dynamics.point_position(i, &Vec3::from_f64(*point)).0[1];
            let depth = model.contact.ground - y;
            if depth > MAX_START_PENETRATION || !depth.is_finite() {
                return Err(source.error_at(
                    &[
                        Key::Name("link"),
                        Key::Index(i),
                        Key::Name("contacts"),
                        Key::Index(c),
                    ],
                    format!(
                        "contact point {} of link `{}` starts {depth:.3} m below the ground \
                         (y = {} m) in the initial state; at most {MAX_START_PENETRATION} m \
                         is allowed",
                        c + 1,
                        link.name,
                        model.contact.ground
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Converts times (s) to RK4 steps of `dt`, `None` when not within 1e-9 of a step.
fn dt_steps(dt: f64) -> impl Fn(f64) -> Option<usize> {
    move |t: f64| {
        let n = (t / dt).round();
        ((t / dt - n).abs() <= 1e-9 * n.max(1.0)).then_some(n as usize)
    }
}

/// `[controls] shooting_times` as interior RK4 steps (empty when absent).
fn build_shooting_times(
    source: &Source,
    file: &FileSpec,
    step_of: impl Fn(f64) -> Option<usize>,
    last_step: usize,
) -> Result<Vec<usize>, InputError> {
    let Some(times) = &file.controls.shooting_times else {
        return Ok(Vec::new());
    };
    let at = path(&["controls".into(), "shooting_times".into()]);
    if file.controls.shooting_segments.is_some() {
        return Err(source.error_at(
            &at,
            "give `shooting_times` or `shooting_segments`, not both".to_string(),
        ));
    }
    let mut steps = Vec::with_capacity(times.len());
    for &t in times {
        match step_of(t) {
            Some(n) if t.is_finite() && n > steps.last().copied().unwrap_or(0) && n < last_step => {
                steps.push(n)
            }
            _ => {
                return Err(source.error_at(
                    &at,
                    format!(
                        "`shooting_times` must be ascending multiples of `dt` strictly between 0 and the last task time, got {t}"
                    ),
                ));
            }
        }
    }
    Ok(steps)
}

/// `[controls] initial_state` as the variable box around `initial` (`q` then `v`).
fn build_initial_box(
    source: &Source,
    file: &FileSpec,
    model: &Model,
    initial: &State<f64>,
) -> Result<Option<StateBox>, InputError> {
    let Some(spec) = &file.controls.initial_state else {
        return Ok(None);
    };
    let at = |key: &'static str| {
        vec![
            Key::Name("controls"),
            Key::Name("initial_state"),
            Key::Name(key),
        ]
    };
    if model
        .links
        .iter()
        .any(|l| matches!(l.joint, JointKind::Floating))
    {
        return Err(source.error_at(
            &at("position"),
            "`initial_state` needs a model without a floating root (its quaternion would leave the unit sphere)".to_string(),
        ));
    }
    let (mut lo, mut hi) = (Vec::new(), Vec::new());
    for (key, nums, values) in [
        ("position", &spec.position, &initial.q),
        ("velocity", &spec.velocity, &initial.v),
    ] {
        let w = nums.as_slice();
        let n = values.len();
        let ok = finite_all(w)
            && w.iter().all(|&x| x >= 0.0)
            && (matches!(nums, Numbers::One(_)) || w.len() == n);
        if !ok {
            return Err(source.error_at(
                &at(key),
                format!("`{key}` must be a half-width ≥ 0 or a list of {n} of them"),
            ));
        }
        for (i, &x) in values.iter().enumerate() {
            let wi = if w.len() == 1 { w[0] } else { w[i] };
            lo.push(x - wi);
            hi.push(x + wi);
        }
    }
    Ok(Some((lo, hi)))
}

fn build_trials(source: &Source, t: &TrialsSpec) -> Result<TrialSettings, InputError> {
    let at = |key: &'static str, msg: String| {
        source.error_at(&[Key::Name("trials"), Key::Name(key)], msg)
    };
    let count = t.count.unwrap_or(8);
    if !(1..=1000).contains(&count) {
        return Err(at(
            "count",
            format!("`count` must be in 1..=1000, got {count}"),
        ));
    }
    let tolerance = t.tolerance.unwrap_or(1e-3);
    if !(tolerance > 0.0 && tolerance.is_finite()) {
        return Err(at(
            "tolerance",
            format!("`tolerance` must be positive, got {tolerance}"),
        ));
    }
    let spread = t.spread.unwrap_or(0.3);
    if !(0.0..=1.0).contains(&spread) {
        return Err(at(
            "spread",
            format!("`spread` must be in [0, 1], got {spread}"),
        ));
    }
    let slope_margin = t.slope_margin.unwrap_or(0.2);
    if !(slope_margin > 0.0 && slope_margin < 1.0) {
        return Err(at(
            "slope_margin",
            format!("`slope_margin` must be in (0, 1), got {slope_margin}"),
        ));
    }
    let restarts = t.restarts.unwrap_or(1);
    if restarts > 10 {
        return Err(at(
            "restarts",
            format!("`restarts` must be in 0..=10, got {restarts}"),
        ));
    }
    let continuation_stages = t.continuation_stages.unwrap_or(0);
    if continuation_stages > 50 {
        return Err(at(
            "continuation_stages",
            format!("`continuation_stages` must be in 0..=50, got {continuation_stages}"),
        ));
    }
    let shaping_stages = t.shaping_stages.unwrap_or(0);
    if shaping_stages > 20 {
        return Err(at(
            "shaping_stages",
            format!("`shaping_stages` must be in 0..=20, got {shaping_stages}"),
        ));
    }
    Ok(TrialSettings {
        count,
        tolerance,
        spread,
        slope_margin,
        restarts,
        feasibility_first: t.feasibility_first.unwrap_or(false),
        continuation_stages,
        shaping_stages,
    })
}

fn build_start(source: &Source, s: &StartSpec) -> Result<StartSettings, InputError> {
    let kind = s.kind.unwrap_or_default();
    if s.amplitude.is_some() && kind != StartKind::Random {
        return Err(source.error_at(
            &[Key::Name("start"), Key::Name("amplitude")],
            "`amplitude` applies to `kind = \"random\"` only".to_string(),
        ));
    }
    let amplitude = s.amplitude.unwrap_or(0.3);
    if !(0.0..=1.0).contains(&amplitude) {
        return Err(source.error_at(
            &[Key::Name("start"), Key::Name("amplitude")],
            format!("`amplitude` must be in [0, 1], got {amplitude}"),
        ));
    }
    Ok(StartSettings { kind, amplitude })
}

fn build_global(source: &Source, g: &GlobalPhaseSpec) -> Result<GlobalSettings, InputError> {
    let at = |key: &'static str, msg: String| {
        source.error_at(&[Key::Name("global"), Key::Name(key)], msg)
    };
    let generations = g.generations.unwrap_or(300);
    if !(1..=100_000).contains(&generations) {
        return Err(at(
            "generations",
            format!("`generations` must be in 1..=100000, got {generations}"),
        ));
    }
    let evaluations = g.evaluations.unwrap_or(3000);
    if !(1..=10_000_000).contains(&evaluations) {
        return Err(at(
            "evaluations",
            format!("`evaluations` must be in 1..=10000000, got {evaluations}"),
        ));
    }
    if let Some(p) = g.population
        && !(2..=10_000).contains(&p)
    {
        return Err(at(
            "population",
            format!("`population` must be in 2..=10000, got {p}"),
        ));
    }
    let sigma = g.sigma.unwrap_or(0.3);
    if !(sigma > 0.0 && sigma <= 2.0) {
        return Err(at(
            "sigma",
            format!("`sigma` must be in (0, 2], got {sigma}"),
        ));
    }
    let coarsening = g.coarsening.unwrap_or(1);
    if !(1..=64).contains(&coarsening) {
        return Err(at(
            "coarsening",
            format!("`coarsening` must be in 1..=64, got {coarsening}"),
        ));
    }
    Ok(GlobalSettings {
        generations,
        evaluations,
        population: g.population,
        sigma,
        staged: g.staged.unwrap_or(false),
        fallback: g.fallback.unwrap_or(false),
        coarsening,
    })
}

fn build_shape(s: &ShapeSpec) -> Result<Shape, String> {
    let shape = match *s {
        ShapeSpec::Box { size, center } => Shape::Box { size, center },
        ShapeSpec::Capsule { radius, from, to } => Shape::Capsule { radius, from, to },
        ShapeSpec::Sphere { radius, center } => Shape::Sphere { radius, center },
        ShapeSpec::Cone { radius, apex, base } => Shape::Cone { radius, apex, base },
    };
    let ok = match shape {
        Shape::Box { size, center } => {
            size.iter().all(|&x| x > 0.0) && finite_all(&size) && finite_all(&center)
        }
        Shape::Capsule { radius, from, to } => {
            radius > 0.0 && radius.is_finite() && finite_all(&from) && finite_all(&to)
        }
        Shape::Sphere { radius, center } => {
            radius > 0.0 && radius.is_finite() && finite_all(&center)
        }
        Shape::Cone { radius, apex, base } => {
            radius > 0.0
                && radius.is_finite()
                && finite_all(&apex)
                && finite_all(&base)
                && apex != base
        }
    };
    if ok {
        Ok(shape)
    } else {
        Err("shape sizes must be positive, coordinates finite and a cone's apex apart from its base".into())
    }
}

/// Sylvester's criterion on a symmetric 3×3 matrix.
fn positive_definite(m: &[[f64; 3]; 3]) -> bool {
    let d1 = m[0][0];
    let d2 = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    let d3 = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    d1 > 0.0 && d2 > 0.0 && d3 > 0.0 && m.iter().flatten().all(|x| x.is_finite())
}

fn build_contact(source: &Source, c: &ContactSpec) -> Result<ContactParams, InputError> {
    let mut p = ContactParams::default();
    let fields: [(&'static str, Option<f64>, &mut f64, bool); 10] = [
        ("spring_force", c.spring_force, &mut p.spring_force, true),
        ("spring_rate", c.spring_rate, &mut p.spring_rate, true),
        (
            "spring_offset",
            c.spring_offset,
            &mut p.spring_offset,
            false,
        ),
        ("damping", c.damping, &mut p.damping, false),
        ("damping_rate", c.damping_rate, &mut p.damping_rate, true),
        (
            "damping_factor",
            c.damping_factor,
            &mut p.damping_factor,
            true,
        ),
        (
            "damping_offset",
            c.damping_offset,
            &mut p.damping_offset,
            false,
        ),
        ("friction", c.friction, &mut p.friction, false),
        ("slip_speed", c.slip_speed, &mut p.slip_speed, true),
        ("ground", c.ground, &mut p.ground, false),
    ];
    for (key, value, slot, positive) in fields {
        if let Some(v) = value {
            let ok = v.is_finite()
                && if positive {
                    v > 0.0
                } else {
                    key == "ground" || key == "spring_offset" || key == "damping_offset" || v >= 0.0
                };
            if !ok {
                let need = if positive {
                    "positive"
                } else {
                    "finite and non-negative"
                };
                return Err(source.error_at(
                    &[Key::Name("contact"), Key::Name(key)],
                    format!("`{key}` must be {need}, got {v}"),
                ));
            }
            *slot = v;
        }
    }
    Ok(p)
}

fn build_initial(
    source: &Source,
    file: &FileSpec,
    model: &Model,
) -> Result<State<f64>, InputError> {
    let mut q = model.neutral();
    let mut v = vec![0.0; model.nv];
    for (i, (l, spec)) in model.links.iter().zip(&file.link).enumerate() {
        let j = &spec.joint;
        let jat = |key: &'static str| joint_key(i, key);
        let get = |key: &'static str,
                   x: &Option<Numbers>,
                   n: usize|
         -> Result<Option<Vec<f64>>, InputError> {
            match x {
                None => Ok(None),
                Some(nums) => {
                    let s = nums.as_slice();
                    let ok = s.len() == n
                        && finite_all(s)
                        && (n == 1 || matches!(nums, Numbers::Many(_)));
                    if ok {
                        Ok(Some(s.to_vec()))
                    } else {
                        let what = if n == 1 {
                            "a number".to_string()
                        } else {
                            format!("a list of {n} numbers")
                        };
                        Err(source
                            .error_at(&jat(key), format!("`{key}` must be {what} for this joint")))
                    }
                }
            }
        };
        let (qa, va) = (l.q_index, l.v_index);
        let root_only = |key: &'static str, present: bool| {
            if present {
                Err(source.error_at(
                    &jat(key),
                    format!("`{key}` applies to a planar or floating root only"),
                ))
            } else {
                Ok(())
            }
        };
        match l.joint {
            JointKind::Revolute { .. } | JointKind::Prismatic { .. } => {
                root_only("angle", j.angle.is_some())?;
                root_only("orientation", j.orientation.is_some())?;
                root_only("angular_velocity", j.angular_velocity.is_some())?;
                if let Some(p) = get("position", &j.position, 1)? {
                    q[qa] = p[0];
                }
                if let Some(p) = get("velocity", &j.velocity, 1)? {
                    v[va] = p[0];
                }
            }
            JointKind::Planar => {
                root_only("orientation", j.orientation.is_some())?;
                if let Some(p) = get("position", &j.position, 2)? {
                    q[qa] = p[0];
                    q[qa + 1] = p[1];
                }
                let theta = j.angle.unwrap_or(0.0);
                if !theta.is_finite() {
                    return Err(source.error_at(&jat("angle"), "`angle` must be finite"));
                }
                q[qa + 2] = theta;
                let w = get("angular_velocity", &j.angular_velocity, 1)?.map_or(0.0, |x| x[0]);
                let vw = get("velocity", &j.velocity, 2)?.unwrap_or(vec![0.0, 0.0]);
                // World origin velocity to link coordinates: v_b = Rᵀ·v_w.
                let (s, c) = theta.sin_cos();
                v[va] = w;
                v[va + 1] = c * vw[0] + s * vw[1];
                v[va + 2] = -s * vw[0] + c * vw[1];
            }
            JointKind::Floating => {
                root_only("angle", j.angle.is_some())?;
                if let Some(p) = get("position", &j.position, 3)? {
                    q[qa..qa + 3].copy_from_slice(&p);
                }
                let quat = j.orientation.unwrap_or([1.0, 0.0, 0.0, 0.0]);
                let n = quat.iter().map(|x| x * x).sum::<f64>().sqrt();
                if !(n > 1e-9 && n.is_finite()) {
                    return Err(source.error_at(
                        &jat("orientation"),
                        "`orientation` must be a non-zero quaternion [w, x, y, z]",
                    ));
                }
                for k in 0..4 {
                    q[qa + 3 + k] = quat[k] / n;
                }
                let r = Mat3::<f64>::from_quaternion([q[qa + 3], q[qa + 4], q[qa + 5], q[qa + 6]]);
                let w = get("angular_velocity", &j.angular_velocity, 3)?.unwrap_or(vec![0.0; 3]);
                let vw = get("velocity", &j.velocity, 3)?.unwrap_or(vec![0.0; 3]);
                let wb = r.tr_mul_vec(&Vec3([w[0], w[1], w[2]]));
                let vb = r.tr_mul_vec(&Vec3([vw[0], vw[1], vw[2]]));
                v[va..va + 3].copy_from_slice(&wb.0);
                v[va + 3..va + 6].copy_from_slice(&vb.0);
            }
        }
    }
    Ok(State { q, v })
}

/// The task rows and the shaping rows of `[[task]]` (each sorted by time), in file order
/// within a time.
fn build_tasks(
    source: &Source,
    file: &FileSpec,
    model: &Model,
    index: &HashMap<&str, usize>,
) -> Result<(Vec<PoseConstraint>, Vec<PoseConstraint>), InputError> {
    let (mut tasks, mut shaping) = (Vec::new(), Vec::new());
    for (k, t) in file.task.iter().enumerate() {
        let at = |key: &'static str| [Key::Name("task"), Key::Index(k), Key::Name(key)];
        let step = task_step(source, file.dt, t, &at)?;
        let (lower, upper) = task_bounds(source, t, &at)?;
        let quantities = task_quantities(source, model, index, t, &at)?;
        let out = if t.shaping { &mut shaping } else { &mut tasks };
        out.extend(
            quantities
                .into_iter()
                .map(|(quantity, what)| PoseConstraint {
                    name: task_name(t.time, &what, lower, upper),
                    time: t.time,
                    step,
                    quantity,
                    lower,
                    upper,
                }),
        );
    }
    tasks.sort_by(|a, b| a.time.total_cmp(&b.time));
    shaping.sort_by(|a, b| a.time.total_cmp(&b.time));
    Ok((tasks, shaping))
}

/// The key path `task[k].<key>` of the task being read.
type TaskKey<'a> = dyn Fn(&'static str) -> [Key<'static>; 3] + 'a;

/// The RK4 step of a task's `time` (s): a positive multiple of `dt` (s), within `MAX_STEPS`.
fn task_step(
    source: &Source,
    dt: f64,
    t: &TaskSpec,
    at: &TaskKey<'_>,
) -> Result<usize, InputError> {
    let steps = t.time / dt;
    if !(t.time > 0.0 && t.time.is_finite())
        || (steps - steps.round()).abs() > 1e-6 * steps.max(1.0)
    {
        return Err(source.error_at(
            &at("time"),
            format!(
                "`time` must be a positive multiple of dt = {} s, got {}",
                dt, t.time
            ),
        ));
    }
    source.within_limit(&at("time"), steps, MAX_STEPS as f64, "RK4 steps of `dt`")?;
    Ok(steps.round() as usize)
}

/// A task's `(lower, upper)` bounds, in its quantity's unit: `value` for both, or `min`/`max`
/// (an absent one infinite).
fn task_bounds(source: &Source, t: &TaskSpec, at: &TaskKey<'_>) -> Result<(f64, f64), InputError> {
    let (lower, upper) = match (t.value, t.min, t.max) {
        (Some(v), None, None) => (v, v),
        (None, lo, hi) if lo.is_some() || hi.is_some() => {
            (lo.unwrap_or(f64::NEG_INFINITY), hi.unwrap_or(f64::INFINITY))
        }
        (Some(_), _, _) => {
            return Err(
                source.error_at(&at("value"), "give either `value` or `min`/`max`, not both")
            );
        }
        _ => {
            return Err(source.error_at(&at("quantity"), "a task needs `value`, `min` or `max`"));
        }
    };
    if lower.is_nan() || upper.is_nan() || lower > upper {
        return Err(source.error_at(&at("min"), "bounds must satisfy min ≤ max"));
    }
    Ok((lower, upper))
}

/// A pose row's name: `t=<time> <what> <bounds>`, time in s to the ms.
fn task_name(time: f64, what: &str, lower: f64, upper: f64) -> String {
    let b = match (lower == upper, lower.is_finite(), upper.is_finite()) {
        (true, _, _) => format!("= {lower}"),
        (false, true, true) => format!("in [{lower}, {upper}]"),
        (false, true, false) => format!("≥ {lower}"),
        _ => format!("≤ {upper}"),
    };
    format!("t={time:.3} {what} {b}")
}

/// The quantities a task bounds, each with the name of what it reads (`foot.x`, `com.vy`,
/// `knee.q`, …): one, or one per contact point for `airborne`.
fn task_quantities(
    source: &Source,
    model: &Model,
    index: &HashMap<&str, usize>,
    t: &TaskSpec,
    at: &TaskKey<'_>,
) -> Result<Vec<(Quantity, String)>, InputError> {
    let link = match &t.link {
        None => None,
        Some(name) => Some(
            *index
                .get(name.as_str())
                .ok_or_else(|| source.error_at(&at("link"), format!("no link named `{name}`")))?,
        ),
    };
    let need_link =
        || link.ok_or_else(|| source.error_at(&at("quantity"), "this quantity needs `link`"));
    let need_axis = || {
        t.axis.map(|a| a as usize).ok_or_else(|| {
            source.error_at(
                &at("quantity"),
                "this quantity needs `axis` (\"x\", \"y\" or \"z\")",
            )
        })
    };
    let point = t.point.unwrap_or([0.0; 3]);
    if !finite_all(&point) {
        return Err(source.error_at(&at("point"), "`point` must be finite"));
    }
    let scalar_joint = |l: usize| {
        if model.links[l].joint.is_scalar() {
            Ok(l)
        } else {
            Err(source.error_at(
                &at("link"),
                "joint quantities apply to revolute and prismatic joints",
            ))
        }
    };
    let axis_name = |a: usize| ["x", "y", "z"][a];
    let one = match t.quantity {
        QuantitySpec::PointPosition | QuantitySpec::PointVelocity => {
            let (l, a) = (need_link()?, need_axis()?);
            let lname = &model.links[l].name;
            if t.quantity == QuantitySpec::PointPosition {
                (
                    Quantity::PointPosition {
                        link: l,
                        point,
                        axis: a,
                    },
                    format!("{lname}.{}", axis_name(a)),
                )
            } else {
                (
                    Quantity::PointVelocity {
                        link: l,
                        point,
                        axis: a,
                    },
                    format!("{lname}.v{}", axis_name(a)),
                )
            }
        }
        QuantitySpec::JointPosition => {
            let l = scalar_joint(need_link()?)?;
            (
                Quantity::JointPosition {
                    q_index: model.links[l].q_index,
                },
                format!("{}.q", model.links[l].name),
            )
        }
        QuantitySpec::JointVelocity => {
            let l = scalar_joint(need_link()?)?;
            (
                Quantity::JointVelocity {
                    v_index: model.links[l].v_index,
                },
                format!("{}.qdot", model.links[l].name),
            )
        }
        QuantitySpec::ComPosition => {
            let a = need_axis()?;
            (
                Quantity::ComPosition { axis: a },
                format!("com.{}", axis_name(a)),
            )
        }
        QuantitySpec::ComVelocity => {
            let a = need_axis()?;
            (
                Quantity::ComVelocity { axis: a },
                format!("com.v{}", axis_name(a)),
            )
        }
        QuantitySpec::Airborne => return airborne_quantities(source, model, t, at),
    };
    Ok(vec![one])
}

/// `airborne`: the height (m) of every contact point of the character; the task takes only
/// `time` and `min`.
fn airborne_quantities(
    source: &Source,
    model: &Model,
    t: &TaskSpec,
    at: &TaskKey<'_>,
) -> Result<Vec<(Quantity, String)>, InputError> {
    if t.max.is_some()
        || t.value.is_some()
        || t.link.is_some()
        || t.axis.is_some()
        || t.point.is_some()
    {
        return Err(source.error_at(
            &at("quantity"),
            "`airborne` takes only `time` and `min` (m above the ground)",
        ));
    }
    let mut out = Vec::new();
    for (li, l) in model.links.iter().enumerate() {
        for (ci, c) in l.contacts.iter().enumerate() {
            out.push((
                Quantity::Height {
                    link: li,
                    point: *c,
                },
                format!("{}.contact{ci}.height", l.name),
            ));
        }
    }
    if out.is_empty() {
        return Err(source.error_at(
            &at("quantity"),
            "`airborne` needs contact points on the character",
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn load(text: &str) -> Result<Problem, InputError> {
        load_source(&Source {
            path: PathBuf::from("p.toml"),
            text: text.into(),
        })
    }

    /// The error of a file that must fail, and the line of `text` it points at.
    fn error_and_line(text: &str) -> (String, String) {
        let e = load(text).unwrap_err();
        let (line, _) = e.position.unwrap();
        (e.message, text.lines().nth(line - 1).unwrap().to_string())
    }

    const BASE: &str = r#"
dt = 1e-3
[[link]]
name = "body"
mass = 1.0
shape = { type = "box", size = [0.1, 0.2, 0.1] }
contacts = [[0.0, -0.1, 0.0]]
joint = { type = "planar", position = [0.0, 0.5], velocity = [1.0, 0.0], angle = 0.5 }
[[link]]
name = "arm"
mass = 0.5
shape = { type = "capsule", radius = 0.02, from = [0, 0, 0], to = [0.3, 0, 0] }
joint = { type = "revolute", parent = "body", origin = [0.0, 0.1, 0.0], limits = [-1.0, 1.0], position = 0.2 }
[[actuator]]
name = "shoulder"
joint = "arm"
bounds = [-2.0, 2.0]
[[task]]
time = 0.5
quantity = "airborne"
min = 0.1
"#;

    #[test]
    fn a_valid_file_loads() {
        let p = load(BASE).unwrap();
        assert_eq!((p.model.nq, p.model.nv), (4, 4));
        assert_eq!(p.constraints[0].step, 500);
        assert_eq!(p.horizon, 0.5);
        assert_eq!(p.start, vec![vec![0.0; 6]]);
        assert_eq!(p.segments, 1);
        let p = load(&BASE.replacen(
            "[[task]]",
            "[controls]\nshooting_segments = 500\n[[task]]",
            1,
        ))
        .unwrap();
        assert_eq!(p.segments, 500);
        // World velocity (1, 0) seen from a link rotated by 0.5 rad.
        assert!(
            (p.initial.v[1] - 0.5f64.cos()).abs() < 1e-15
                && (p.initial.v[2] + 0.5f64.sin()).abs() < 1e-15
        );
        // Inertia from the capsule shape: centre of mass at its middle.
        assert_eq!(p.model.links[1].inertia.com.0, [0.15, 0.0, 0.0]);
    }

    /// A servo's set point at zero control is the joint's initial angle and its controls span
    /// the joint's limits less that; a servo needs limits and positive gains.
    #[test]
    fn servos_load_relative_to_the_initial_pose() {
        let servo = "bounds = [-2.0, 2.0]\nservo = { stiffness = 10.0, damping = 0.5 }";
        let p = load(&BASE.replacen("bounds = [-2.0, 2.0]", servo, 1)).unwrap();
        let s = p.model.actuators[0].servo.unwrap();
        assert_eq!((s.stiffness, s.damping, s.rest), (10.0, 0.5, 0.2));
        assert_eq!(p.model.actuators[0].control_range(), [-1.2, 0.8]);
        assert!(p.model.has_servos());
        let no_limits = BASE.replacen("bounds = [-2.0, 2.0]", servo, 1).replacen(
            " limits = [-1.0, 1.0],",
            "",
            1,
        );
        let (message, line) = error_and_line(&no_limits);
        assert!(message.contains("a servo needs limits"), "{message}");
        assert!(line.starts_with("servo"), "{line}");
        let negative = BASE.replacen(
            "bounds = [-2.0, 2.0]",
            "bounds = [-2.0, 2.0]\nservo = { stiffness = -1.0, damping = 0.5 }",
            1,
        );
        assert!(load(&negative).is_err());
    }

    #[test]
    fn shaping_rows_are_kept_apart_and_merged_in_time_order() {
        let text = BASE.to_string()
            + "[[task]]\ntime = 0.2\nquantity = \"com_position\"\naxis = \"y\"\nmin = 0.4\nshaping = true\n";
        let p = load(&text).unwrap();
        assert_eq!(p.constraints.len(), 1);
        assert_eq!(p.shaping.len(), 1);
        assert_eq!(p.horizon, 0.5);
        let shaped = p.shaped();
        assert!(shaped.shaping.is_empty());
        let times: Vec<f64> = shaped.constraints.iter().map(|c| c.time).collect();
        assert_eq!(times, vec![0.2, 0.5]);
    }

    /// A cone's centre of mass is 3/4 of the way from apex to base; its inertia is the solid
    /// cone's: 3/10·m·r² along the axis, 3/80·m·(4r² + h²) across it.
    #[test]
    fn a_cone_link_has_the_solid_cones_mass_properties() {
        let text = BASE.replacen(
            "shape = { type = \"capsule\", radius = 0.02, from = [0, 0, 0], to = [0.3, 0, 0] }",
            "shape = { type = \"cone\", radius = 0.02, apex = [0, 0, 0], base = [0.3, 0, 0] }",
            1,
        );
        let p = load(&text).unwrap();
        let arm = &p.model.links[1].inertia;
        assert!((arm.com.0[0] - 0.225).abs() < 1e-15 && arm.com.0[1] == 0.0);
        let i = arm.inertia_com.0;
        let (m, r, h) = (0.5, 0.02, 0.3);
        assert!((i[0][0] - 0.3 * m * r * r).abs() < 1e-15);
        let across = 3.0 * m * (4.0 * r * r + h * h) / 80.0;
        assert!((i[1][1] - across).abs() < 1e-15 && (i[2][2] - across).abs() < 1e-15);
        assert_eq!(i[0][1], 0.0);
    }

    #[test]
    fn errors_point_at_the_key() {
        let cases = [
            ("mass = 0.5\n", "mass = -0.5\n", "`mass` must be positive"),
            ("parent = \"body\"", "parent = \"leg\"", "parent `leg`"),
            (
                "joint = \"arm\"",
                "joint = \"body\"",
                "revolute or prismatic",
            ),
            ("time = 0.5", "time = 0.5004", "multiple of dt"),
            ("min = 0.1", "mni = 0.1", "did you mean `min`"),
            (
                "shape = { type = \"capsule\", radius = 0.02, from = [0, 0, 0], to = [0.3, 0, 0] }",
                "shape = { type = \"cone\", radius = 0.02, apex = [0, 0, 0], base = [0, 0, 0] }",
                "a cone's apex apart from its base",
            ),
            (
                "limits = [-1.0, 1.0]",
                "limits = [1.0, -1.0]",
                "lower < upper",
            ),
        ];
        for (from, to, msg) in cases {
            let text = BASE.replacen(from, to, 1);
            let (message, bad) = error_and_line(&text);
            assert!(message.contains(msg), "{to}: {message}");
            let key = to.split([' ', '=']).next().unwrap();
            assert!(
                bad.contains(key) || bad.contains("[[task]]") || bad.contains("quantity"),
                "{to}: `{bad}`"
            );
        }
    }

    #[test]
    fn start_and_global_tables_load_and_bad_keys_point_at_them() {
        let p = load(BASE).unwrap();
        assert_eq!(p.starts.kind, StartKind::Given);
        assert!(p.global.is_none());
        let text = BASE.to_string()
            + "[start]\nkind = \"random\"\namplitude = 0.5\n[global]\nevaluations = 400\n";
        let p = load(&text).unwrap();
        assert_eq!(
            p.starts,
            StartSettings {
                kind: StartKind::Random,
                amplitude: 0.5
            }
        );
        let g = p.global.unwrap();
        assert_eq!(
            (
                g.generations,
                g.evaluations,
                g.population,
                g.sigma,
                g.staged,
                g.fallback,
                g.coarsening
            ),
            (300, 400, None, 0.3, false, false, 1)
        );
        let staged = load(&(BASE.to_string() + "[global]\nstaged = true\n")).unwrap();
        assert!(staged.global.unwrap().staged);
        let fallback = load(&(BASE.to_string() + "[global]\nfallback = true\n")).unwrap();
        assert!(fallback.global.unwrap().fallback);
        let coarse = load(&(BASE.to_string() + "[global]\ncoarsening = 2\n")).unwrap();
        assert_eq!(coarse.global.unwrap().coarsening, 2);
        let off_step = load(&(BASE.to_string() + "[global]\ncoarsening = 64\n")).unwrap_err();
        assert!(
            off_step.to_string().contains("multiple of `coarsening`"),
            "{off_step}"
        );
        for (table, says, key) in [
            (
                "[start]\nkind = \"zero\"\namplitude = 0.5",
                "applies to",
                "amplitude",
            ),
            (
                "[start]\nkind = \"random\"\namplitude = 1.5",
                "in [0, 1]",
                "amplitude",
            ),
            ("[start]\nkind = \"searched\"", "unknown variant", "kind"),
            ("[global]\npopulation = 1", "2..=10000", "population"),
            ("[global]\nsigma = 0.0", "(0, 2]", "sigma"),
            ("[global]\ncoarsening = 0", "1..=64", "coarsening"),
            ("[global]\ngenerations = 0", "1..=100000", "generations"),
            ("[global]\nevaluations = 0", "1..=10000000", "evaluations"),
            (
                "[global]\nmethod = \"anneal\"",
                "unknown key `method`",
                "method",
            ),
        ] {
            let (message, at) = error_and_line(&format!("{BASE}{table}\n"));
            assert!(message.contains(says), "{table}: {message}");
            assert!(at.contains(key), "{table}: `{at}`");
        }
    }

    #[test]
    fn shooting_segments_out_of_range_point_at_the_key() {
        for bad in [0, 501] {
            let text = BASE.replacen(
                "[[task]]",
                &format!("[controls]\nshooting_segments = {bad}\n[[task]]"),
                1,
            );
            let (message, at) = error_and_line(&text);
            assert!(
                message.contains("`shooting_segments` must be in 1..=500"),
                "{message}"
            );
            assert!(at.contains("shooting_segments"), "`{at}`");
        }
    }

    #[test]
    fn shooting_times_become_steps() {
        let text = BASE.replacen(
            "[[task]]",
            "[controls]\nshooting_times = [0.1, 0.25]\n[[task]]",
            1,
        );
        let p = load(&text).unwrap();
        assert_eq!(p.shooting_steps, vec![100, 250]);
        assert_eq!(p.segments, 3);
        assert_eq!(load(BASE).unwrap().shooting_steps, Vec::<usize>::new());
    }

    #[test]
    fn bad_shooting_times_point_at_the_key() {
        for (bad, says) in [
            ("shooting_times = [0.25, 0.1]", "ascending"),
            ("shooting_times = [0.5]", "strictly between"),
            ("shooting_times = [0.0]", "strictly between"),
            ("shooting_times = [0.1005]", "multiples of `dt`"),
            ("shooting_segments = 2\nshooting_times = [0.1]", "not both"),
        ] {
            let text = BASE.replacen("[[task]]", &format!("[controls]\n{bad}\n[[task]]"), 1);
            let (message, at) = error_and_line(&text);
            assert!(message.contains(says), "{bad}: {message}");
            assert!(at.contains("shooting_times"), "`{at}`");
        }
    }

    #[test]
    fn initial_state_box_around_the_file_state() {
        let text = BASE.replacen(
            "[[task]]",
            "[controls]\ninitial_state = { position = [0.0, 0.01, 0.1, 0.2], velocity = 0.5 }\n[[task]]",
            1,
        );
        let p = load(&text).unwrap();
        let (lo, hi) = p.initial_box.clone().unwrap();
        let w = [0.0, 0.01, 0.1, 0.2, 0.5, 0.5, 0.5, 0.5];
        for i in 0..8 {
            let x = if i < 4 {
                p.initial.q[i]
            } else {
                p.initial.v[i - 4]
            };
            assert!((lo[i] - (x - w[i])).abs() < 1e-15 && (hi[i] - (x + w[i])).abs() < 1e-15);
        }
        assert_eq!(p.spline_parameters(), 12);
        assert_eq!(p.motion_parameters(), 20);
        let mut x = vec![0.0; 20];
        x[12..].copy_from_slice(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]);
        assert_eq!(p.initial_of(&x).v, vec![5.0, 6.0, 7.0, 8.0]);
        assert_eq!(p.initial_of(&x[..12]).q, p.initial.q);
        assert!(load(BASE).unwrap().initial_box.is_none());
        for bad in [
            "initial_state = { position = [0.1, 0.2], velocity = 0.0 }",
            "initial_state = { position = -0.1, velocity = 0.0 }",
        ] {
            let text = BASE.replacen("[[task]]", &format!("[controls]\n{bad}\n[[task]]"), 1);
            let e = load(&text).unwrap_err();
            assert!(e.message.contains("half-width"), "{bad}: {}", e.message);
        }
    }
}
