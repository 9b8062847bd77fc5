//! The collocation problem file (`formulation = "collocation"`): a point-mass "actuated rubber
//! ball" in the vertical x–y plane (seed §3.4), its contact phases with given times, pose
//! constraints at key times, and the collocation frame rate. Parsed with `deny_unknown_fields`
//! and validated with errors positioned at the offending key.
//!
//! Units: m, kg, s, N; y is up; `gravity` is the signed vertical acceleration (m/s², negative
//! downwards). Layout (every key documented on its field; `problems/gait/ball.toml` is a
//! complete example, docs/problem-files-gait.md the reference):
//! ```toml
//! formulation = "collocation"
//! mass = 1.0
//! gravity = -9.8
//! fps = 30
//! duration = 2.0
//! max_compression = 0.1
//! start = { position = [-2.0, 1.0], velocity = [0.0, 0.0] }
//! end = { position = [2.0, 0.0] }
//! [[contact]]
//! start = 0.4518
//! end = 0.65
//! [[pose]]
//! time = 1.3
//! axis = "y"
//! min = 2.0
//! [wall]
//! x = 0.0
//! height = 2.0
//! ```

use serde::Deserialize;

use crate::error::InputError;
use crate::solver::Options;
use crate::spec::{Key, Source, is_positive as positive, validate_solver};

/// The whole file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FileSpec {
    /// Must be "collocation" (selects this formulation).
    pub formulation: String,
    /// Problem name; defaults to the file stem.
    pub name: Option<String>,
    /// What the task is, for people.
    pub description: Option<String>,
    /// The ball's mass (kg).
    pub mass: f64,
    /// Signed vertical gravity acceleration (m/s²); default −9.8 (the seed's G).
    #[serde(default = "default_gravity")]
    pub gravity: f64,
    /// Collocation frames per second: the spline knots and the Newtonian constraints sit on
    /// every frame (seed: 30).
    pub fps: f64,
    /// Length of the motion (s); the last frame is at `duration`.
    pub duration: f64,
    /// How far the deforming ball's bottom may sink below the floor during contact (m).
    pub max_compression: f64,
    /// Friction coefficient of the contact force cone |F_x| ≤ μ·F_y; omitted = infinite
    /// friction (the seed's assumption).
    pub friction: Option<f64>,
    /// Position (m) and velocity (m/s) at t = 0.
    pub start: StartSpec,
    /// Position at `duration` (m): the landing.
    pub end: EndSpec,
    /// Contact phases: the only times the ball can push on the floor.
    #[serde(default)]
    pub contact: Vec<ContactSpec>,
    /// Pose constraints at key times.
    #[serde(default)]
    pub pose: Vec<PoseSpec>,
    /// A thin wall the flight must clear (checked on the re-simulated motion).
    pub wall: Option<WallSpec>,
    /// Solver options.
    #[serde(default)]
    pub solver: Options,
}

fn default_gravity() -> f64 {
    -9.8
}

/// `start = { position, velocity }`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartSpec {
    /// m.
    #[serde(deserialize_with = "crate::spec::arrays::exact")]
    pub position: [f64; 2],
    /// m/s.
    #[serde(deserialize_with = "crate::spec::arrays::exact")]
    pub velocity: [f64; 2],
}

/// `end = { position }`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EndSpec {
    /// m.
    #[serde(deserialize_with = "crate::spec::arrays::exact")]
    pub position: [f64; 2],
}

/// One `[[contact]]` phase: touch-down at `start`, take-off at `end` (s).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    /// Touch-down time (s).
    pub start: f64,
    /// Take-off time (s).
    pub end: f64,
}

/// One `[[pose]]` constraint on the position or velocity along one axis at a time.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseSpec {
    /// Time (s), in [0, duration].
    pub time: f64,
    /// "x" or "y".
    pub axis: String,
    /// "position" (default, m) or "velocity" (m/s).
    pub quantity: Option<String>,
    /// Equality target.
    pub value: Option<f64>,
    /// Lower bound.
    pub min: Option<f64>,
    /// Upper bound.
    pub max: Option<f64>,
}

/// `[wall]`: a thin vertical wall at `x` of the given height (m).
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallSpec {
    /// Horizontal position (m).
    pub x: f64,
    /// Height above the floor (m).
    pub height: f64,
}

/// Position or velocity.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// m.
    Position,
    /// m/s.
    Velocity,
}

/// A validated pose constraint: `min ≤ quantity[axis](time) ≤ max`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// s.
    pub time: f64,
    /// 0 = x, 1 = y.
    pub axis: usize,
    /// What is constrained.
    pub quantity: Quantity,
    /// Lower bound (−∞ if none).
    pub min: f64,
    /// Upper bound (+∞ if none).
    pub max: f64,
}

/// A validated collocation problem.
#[derive(Debug, Clone)]
pub struct Problem {
    /// Name.
    pub name: String,
    /// kg.
    pub mass: f64,
    /// Signed vertical gravity (m/s²).
    pub gravity: f64,
    /// Frames per second.
    pub fps: f64,
    /// s.
    pub duration: f64,
    /// m.
    pub max_compression: f64,
    /// μ, or `None` for infinite friction.
    pub friction: Option<f64>,
    /// Start position (m) and velocity (m/s).
    pub start: ([f64; 2], [f64; 2]),
    /// End position (m).
    pub end: [f64; 2],
    /// Contact phases (touch-down, take-off) in s, sorted and disjoint.
    pub contacts: Vec<(f64, f64)>,
    /// Pose constraints.
    pub poses: Vec<Pose>,
    /// The wall, if any.
    pub wall: Option<WallSpec>,
    /// Solver options table.
    pub solver: Options,
}

/// Whether a problem file's text selects this formulation (a top-level
/// `formulation = "collocation"`). Text that does not parse as TOML is left to the default
/// loader, which reports the error.
pub fn selects_collocation(source: &Source) -> bool {
    toml::from_str::<toml::Table>(&source.text)
        .ok()
        .and_then(|t| t.get("formulation").cloned())
        .is_some_and(|v| v.as_str() == Some("collocation"))
}

/// Parses and validates a collocation problem file's text.
pub fn load_source(source: &Source) -> Result<Problem, InputError> {
    let file: FileSpec = source.parse()?;
    build(source, file)
}

/// The problem of a parsed file, every range checked in the order of the file's keys:
/// the scalars, the contact phases, the poses, the wall.
fn build(source: &Source, file: FileSpec) -> Result<Problem, InputError> {
    check_scalars(source, &file)?;
    let contacts = contact_phases(source, &file)?;
    let poses = (file.pose.iter().enumerate())
        .map(|(i, p)| pose(source, &file, i, p))
        .collect::<Result<Vec<_>, _>>()?;
    if let Some(w) = &file.wall {
        // `x` is finite like every float in the file (`Source::parse`).
        source.positive_quantity(&[Key::Name("wall"), Key::Name("height")], w.height, "m")?;
    }
    let name = file.name.clone().unwrap_or_else(|| {
        source
            .path
            .file_stem()
            .map_or("ball".into(), |s| s.to_string_lossy().into_owned())
    });
    Ok(Problem {
        name,
        mass: file.mass,
        gravity: file.gravity,
        fps: file.fps,
        duration: file.duration,
        max_compression: file.max_compression,
        friction: file.friction,
        start: (file.start.position, file.start.velocity),
        end: file.end.position,
        contacts,
        poses,
        wall: file.wall,
        solver: file.solver,
    })
}

/// The top-level keys: `formulation`, `[solver]`, mass (kg), gravity (m/s²), fps, duration
/// (s), max_compression (m), friction, start and end.
fn check_scalars(source: &Source, file: &FileSpec) -> Result<(), InputError> {
    let err = |p: &[Key<'_>], msg: String| source.error_at(p, msg);
    let top = |k: &'static str| [Key::Name(k)];
    if file.formulation != "collocation" {
        return Err(err(
            &top("formulation"),
            format!(
                "`formulation` must be \"collocation\" here, got {:?}",
                file.formulation
            ),
        ));
    }
    validate_solver(&file.solver, source, &[Key::Name("solver")])?;
    if !positive(file.mass) {
        return Err(err(
            &top("mass"),
            format!("`mass` must be positive kg, got {}", file.mass),
        ));
    }
    if !file.gravity.is_finite() {
        return Err(err(&top("gravity"), "`gravity` must be finite".into()));
    }
    if !(positive(file.fps) && file.fps <= 1000.0) {
        return Err(err(
            &top("fps"),
            format!("`fps` must be in (0, 1000], got {}", file.fps),
        ));
    }
    let frames = file.duration * file.fps;
    if !(positive(file.duration) && (2.0..=100_000.0).contains(&frames)) {
        return Err(err(
            &top("duration"),
            format!(
                "`duration` must be positive and span 2 to 100000 frames, got {} s",
                file.duration
            ),
        ));
    }
    if !(file.max_compression >= 0.0 && file.max_compression.is_finite()) {
        return Err(err(
            &top("max_compression"),
            "`max_compression` must be a non-negative length (m)".into(),
        ));
    }
    if let Some(mu) = file.friction
        && !(mu >= 0.0 && mu.is_finite())
    {
        return Err(err(
            &top("friction"),
            format!("`friction` must be ≥ 0, got {mu}"),
        ));
    }
    let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    if !finite(&file.start.position) || !finite(&file.start.velocity) {
        return Err(err(&top("start"), "`start` must be finite".into()));
    }
    if !finite(&file.end.position) {
        return Err(err(&top("end"), "`end` must be finite".into()));
    }
    Ok(())
}

/// The `[[contact]]` phases as `(start, end)` times (s): inside the motion, at least two
/// frames long, in time order at least a frame apart.
fn contact_phases(source: &Source, file: &FileSpec) -> Result<Vec<(f64, f64)>, InputError> {
    let err = |p: &[Key<'_>], msg: String| source.error_at(p, msg);
    let frame = 1.0 / file.fps;
    let mut contacts: Vec<(f64, f64)> = Vec::new();
    for (i, c) in file.contact.iter().enumerate() {
        let at = [Key::Name("contact"), Key::Index(i)];
        if !(c.start.is_finite() && c.end.is_finite() && c.start > 0.0 && c.end < file.duration) {
            return Err(err(
                &at,
                format!(
                    "a contact phase must lie inside (0, duration) = (0, {}) s",
                    file.duration
                ),
            ));
        }
        if c.end - c.start < 2.0 * frame {
            return Err(err(
                &at,
                format!(
                    "a contact phase must last at least two frames ({:.4} s), got {:.4} s",
                    2.0 * frame,
                    c.end - c.start
                ),
            ));
        }
        if let Some(&(_, prev_end)) = contacts.last()
            && c.start < prev_end + frame
        {
            return Err(err(
                &at,
                "contact phases must be in time order, at least a frame apart".into(),
            ));
        }
        contacts.push((c.start, c.end));
    }
    Ok(contacts)
}

/// `[[pose]]` number `i`: a time within the motion (s), an axis, a quantity (position m or
/// velocity m/s) and non-empty bounds.
fn pose(source: &Source, file: &FileSpec, i: usize, p: &PoseSpec) -> Result<Pose, InputError> {
    let err = |path: &[Key<'_>], msg: String| source.error_at(path, msg);
    let at = |k: &'static str| [Key::Name("pose"), Key::Index(i), Key::Name(k)];
    if !(p.time >= 0.0 && p.time <= file.duration) {
        return Err(err(
            &at("time"),
            format!("`time` must be in [0, {}] s, got {}", file.duration, p.time),
        ));
    }
    let axis = match p.axis.as_str() {
        "x" => 0,
        "y" => 1,
        other => {
            return Err(err(
                &at("axis"),
                format!("`axis` must be \"x\" or \"y\", got {other:?}"),
            ));
        }
    };
    let quantity = match p.quantity.as_deref() {
        None | Some("position") => Quantity::Position,
        Some("velocity") => Quantity::Velocity,
        Some(other) => {
            return Err(err(
                &at("quantity"),
                format!("`quantity` must be \"position\" or \"velocity\", got {other:?}"),
            ));
        }
    };
    let (min, max) = match (p.value, p.min, p.max) {
        (Some(v), None, None) => (v, v),
        (None, lo, hi) if lo.is_some() || hi.is_some() => {
            (lo.unwrap_or(f64::NEG_INFINITY), hi.unwrap_or(f64::INFINITY))
        }
        _ => {
            return Err(err(
                &[Key::Name("pose"), Key::Index(i)],
                "give either `value` or `min`/`max`".into(),
            ));
        }
    };
    if min.is_nan() || max.is_nan() || min > max || (min == max && !min.is_finite()) {
        return Err(err(
            &[Key::Name("pose"), Key::Index(i)],
            format!("the bounds [{min}, {max}] are empty or not numbers"),
        ));
    }
    Ok(Pose {
        time: p.time,
        axis,
        quantity,
        min,
        max,
    })
}
