//! The truss problem file (TOML): what the user writes, parsed with `deny_unknown_fields` and
//! validated with errors positioned at the offending key.
//!
//! Units: metres, newtons, kilograms, pascals (SI). y is up; gravity is −9.81 m/s² along y.
//! Every key is documented in `docs/problem-files.md`; the short form:
//! ```toml
//! name = "warren_bridge"          # optional, default: the file stem
//! objective = "mass"              # "mass" | "length" | "mass_tension_preference"
//! compression_penalty = 2.0       # weight on compression mass for mass_tension_preference
//! max_force = 1e8                 # λ_max, N
//! min_length = 0.1                # l_min, m
//! max_length = 14.6               # optional l_max, m
//! self_weight = true              # lump beam weight into the joints (seed eq. 4.1)
//! planar = false                  # 2-D problem in the plane z = const
//! hold_in_planes = "z"            # free joints keep their z: they move in vertical planes
//! move_joints = true              # false: size the beams of the fixed ground structure only
//! seed = 1                        # seed for random ground structures and starts
//! start_forces = "layout"         # "layout" (LP at the start geometry, idle beams dropped),
//!                                 # "random" (small, seeded) or "zero"
//! [mass]  model = "seed" (k_t, k_c) | "linear" (sigma_t, sigma_c, density); blend_force
//! [[joint]] kind = "anchor" | "load" | "free"; at = [x, y, z]; optional to = [...], count = n
//!           (a row of n evenly spaced joints from `at` to `to`); name; anchors: support =
//!           "pinned" | "roller", reactions = [[dx, dy, dz], ...]; loads: force = [..] N,
//!           mass = kg (weight M·g)
//! [ground] kind = "layers" | "lattice" | "random" | "none" (see [`GroundSpec`])
//! [connect] neighbours = 8, extra = [["a", "b"]], forbidden = [["a", "b"]], full = false
//! [[symmetry]] point, normal       [[obstacle]] kind = "half_space" | "sphere"
//! [[load_case]] name, factor (on the joints' own loads), loads = [{ joint, force, mass }]
//! [rounds] count, prune, split_crossings, remove_crossings, merge_tolerance
//! [solver] (shared, see crate::solver::Options)
//! ```

use serde::Deserialize;

use crate::error::InputError;
use crate::solver::Options;
use crate::spec::{Key, Source, validate_solver};

/// Most joints a problem may have: the user's joints with rows expanded plus the generated
/// ground structure (the k-nearest connection costs O(n² log n)).
pub const MAX_JOINTS: usize = 5_000;
/// Largest `[connect] neighbours`.
pub const MAX_NEIGHBOURS: usize = 64;
/// Largest `[rounds] count` (and `--rounds`).
pub const MAX_ROUNDS: usize = 100;

/// The whole problem file.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TrussSpec {
    /// Problem name; defaults to the file stem.
    pub name: Option<String>,
    /// Free text shown nowhere; for the reader of the file.
    pub description: Option<String>,
    /// What to minimize.
    #[serde(default)]
    pub objective: ObjectiveKind,
    /// Weight on the compression part of the mass for `mass_tension_preference` (default 2).
    pub compression_penalty: Option<f64>,
    /// λ_max, N.
    pub max_force: f64,
    /// l_min, m (default 0.1, seed §4.3.2).
    #[serde(default = "default_min_length")]
    pub min_length: f64,
    /// Optional l_max, m.
    pub max_length: Option<f64>,
    /// Whether beam self-weight is lumped into the joints (default true).
    #[serde(default = "yes")]
    pub self_weight: bool,
    /// 2-D problem: every joint at one z, loads without z components.
    #[serde(default)]
    pub planar: bool,
    /// Free joints keep this coordinate ("x", "y" or "z").
    pub hold_in_planes: Option<Axis>,
    /// Whether free joints move (default true); false sizes the beams of a fixed geometry.
    #[serde(default = "yes")]
    pub move_joints: bool,
    /// Seed for random ground structures and random starting forces (default: the run's seed).
    pub seed: Option<u64>,
    /// Starting forces.
    #[serde(default)]
    pub start_forces: StartForces,
    /// Mass model.
    #[serde(default)]
    pub mass: MassSpec,
    /// User joints.
    #[serde(default, rename = "joint")]
    pub joints: Vec<JointSpec>,
    /// Ground-structure generation.
    #[serde(default)]
    pub ground: GroundSpec,
    /// Connection rules.
    #[serde(default)]
    pub connect: ConnectSpec,
    /// Mirror planes.
    #[serde(default)]
    pub symmetry: Vec<MirrorSpec>,
    /// Obstacles.
    #[serde(default, rename = "obstacle")]
    pub obstacles: Vec<ObstacleSpec>,
    /// Load cases; none means one case with the joints' own loads.
    #[serde(default, rename = "load_case")]
    pub load_cases: Vec<LoadCaseSpec>,
    /// Topology rounds.
    #[serde(default)]
    pub rounds: RoundsSpec,
    /// Solver options.
    #[serde(default)]
    pub solver: Options,
}

fn default_min_length() -> f64 {
    0.1
}

fn yes() -> bool {
    true
}

/// What to minimize.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ObjectiveKind {
    /// Total beam mass.
    #[default]
    Mass,
    /// Total beam length.
    Length,
    /// Beam mass with compression weighted by `compression_penalty`.
    MassTensionPreference,
}

/// A coordinate axis.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    /// x.
    X,
    /// y (vertical).
    Y,
    /// z.
    Z,
}

impl Axis {
    /// 0, 1 or 2.
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }
}

/// How the beam forces start.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum StartForces {
    /// The layout LP at the start geometry; the beams it leaves idle are dropped (see
    /// `crate::truss::start`).
    #[default]
    Layout,
    /// Uniform in ±10% of the largest load, from the seeded generator.
    Random,
    /// All zero.
    Zero,
}

/// The `[mass]` table.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MassSpec {
    /// "seed" (default) or "linear".
    #[serde(default)]
    pub model: MassKind,
    /// Tension factor k_T, kg/(N·m) (seed model; default 5e-6).
    pub k_t: Option<f64>,
    /// Euler compression factor k_C (seed model; default 5e-3).
    pub k_c: Option<f64>,
    /// Allowable tensile stress σ_T, Pa (linear model).
    pub sigma_t: Option<f64>,
    /// Allowable compressive stress σ_C, Pa (linear model).
    pub sigma_c: Option<f64>,
    /// Density ρ, kg/m³ (linear model; default 7850, steel).
    pub density: Option<f64>,
    /// δ, N: below this compression force the Euler √c is a quartic matching it to third order
    /// (default 5% of the largest load; ignored by the linear model).
    pub blend_force: Option<f64>,
}

/// Which mass law.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum MassKind {
    /// Seed eqs. 4.4 and 4.7.
    #[default]
    Seed,
    /// Stress-limited in both tension and compression (plastic design).
    Linear,
}

/// One `[[joint]]` entry (or a row of joints).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct JointSpec {
    /// Anchor, load or free.
    pub kind: JointKindSpec,
    /// Position, m (the first of a row).
    #[serde(deserialize_with = "crate::spec::arrays::exact")]
    pub at: [f64; 3],
    /// End of a row, m.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt")]
    pub to: Option<[f64; 3]>,
    /// Number of joints in the row (≥ 2 with `to`).
    pub count: Option<usize>,
    /// Name; rows get `name.1`, `name.2`, ...
    pub name: Option<String>,
    /// Anchor support type (default pinned).
    pub support: Option<SupportKind>,
    /// Roller reaction directions (one or two).
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt_vec")]
    pub reactions: Option<Vec<[f64; 3]>>,
    /// External force on a load joint, N.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt")]
    pub force: Option<[f64; 3]>,
    /// External mass on a load joint, kg (its weight acts downward).
    pub mass: Option<f64>,
}

/// Joint kinds in the file.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum JointKindSpec {
    /// Joined to the earth.
    Anchor,
    /// Fixed, carries external forces.
    Load,
    /// Variable position.
    Free,
}

/// Anchor supports.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum SupportKind {
    /// Fixed in every direction.
    Pinned,
    /// Reactions only along `reactions`.
    Roller,
}

/// The `[ground]` table: how free joints are generated.
/// - `layers`: copies of the load (or anchor, or both) positions offset vertically by
///   `spacing·k`, k = 1..`layers`, `direction` "above" or "below" (seed §4.2.1);
/// - `lattice`: a regular grid with `spacing` (scalar or per axis) over the box `min`..`max`
///   (default: the bounding box of the user joints grown by `margin`);
/// - `random`: `count` points uniform in the box or in the sphere `center`, `radius`;
/// - `none`: only the user's joints.
///
/// Generated points that coincide with a user joint or lie inside an obstacle are skipped.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GroundSpec {
    /// Generation method (default "layers").
    #[serde(default)]
    pub kind: GroundKind,
    /// Layers: vertical step, m; lattice: grid step, m (scalar or [hx, hy, hz]).
    pub spacing: Option<Spacing>,
    /// Layers: number of layers (default 1).
    pub layers: Option<usize>,
    /// Layers: "above" (default) or "below".
    pub direction: Option<Direction>,
    /// Layers: which joints are copied (default "loads").
    pub from: Option<LayerSource>,
    /// Lattice or random box: lower corner, m.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt")]
    pub min: Option<[f64; 3]>,
    /// Lattice or random box: upper corner, m.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt")]
    pub max: Option<[f64; 3]>,
    /// Growth of the default box beyond the user joints, m (default 0).
    pub margin: Option<f64>,
    /// Random: number of points.
    pub count: Option<usize>,
    /// Random: "box" (default) or "sphere".
    pub region: Option<Region>,
    /// Random sphere centre, m.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt")]
    pub center: Option<[f64; 3]>,
    /// Random sphere radius, m.
    pub radius: Option<f64>,
}

/// Ground generation methods.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum GroundKind {
    /// Offset copies of the loads (seed).
    #[default]
    Layers,
    /// Regular grid.
    Lattice,
    /// Seeded random points.
    Random,
    /// No generated joints.
    None,
}

/// A scalar or per-axis spacing, m.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum Spacing {
    /// The same step on every axis.
    Uniform(f64),
    /// Per-axis steps.
    PerAxis([f64; 3]),
}

impl Spacing {
    /// Per-axis steps.
    pub fn steps(self) -> [f64; 3] {
        match self {
            Spacing::Uniform(h) => [h; 3],
            Spacing::PerAxis(h) => h,
        }
    }
}

/// Layer direction.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Direction {
    /// +y.
    Above,
    /// −y.
    Below,
}

/// Which joints layers copy.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum LayerSource {
    /// Load joints.
    Loads,
    /// Anchors.
    Anchors,
    /// Loads and anchors.
    All,
}

/// Random regions.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Region {
    /// The box `min`..`max`.
    Box,
    /// The ball `center`, `radius`.
    Sphere,
}

/// The `[connect]` table.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ConnectSpec {
    /// k nearest neighbours per joint (default 8).
    #[serde(default = "default_neighbours")]
    pub neighbours: usize,
    /// Extra beams by joint name.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_vec")]
    pub extra: Vec<[String; 2]>,
    /// Pairs never joined, by joint name.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_vec")]
    pub forbidden: Vec<[String; 2]>,
    /// Every admissible pair of joints is a potential beam: the layout start prices them all
    /// and adds the ones that lower its LP (member adding), from the k-nearest beams (default
    /// false).
    #[serde(default)]
    pub full: bool,
}

impl Default for ConnectSpec {
    fn default() -> Self {
        ConnectSpec {
            neighbours: default_neighbours(),
            extra: Vec::new(),
            forbidden: Vec::new(),
            full: false,
        }
    }
}

fn default_neighbours() -> usize {
    8
}

/// A `[[symmetry]]` mirror plane.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MirrorSpec {
    /// A point on the plane, m.
    #[serde(deserialize_with = "crate::spec::arrays::exact")]
    pub point: [f64; 3],
    /// Plane normal (any length > 0).
    #[serde(deserialize_with = "crate::spec::arrays::exact")]
    pub normal: [f64; 3],
}

/// An `[[obstacle]]`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ObstacleSpec {
    /// "half_space" or "sphere".
    pub kind: ObstacleKind,
    /// Half-space: a point on the plane, m.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt")]
    pub point: Option<[f64; 3]>,
    /// Half-space: normal pointing into the allowed side.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt")]
    pub normal: Option<[f64; 3]>,
    /// Sphere centre, m.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt")]
    pub center: Option<[f64; 3]>,
    /// Sphere radius, m.
    pub radius: Option<f64>,
}

/// Obstacle kinds.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ObstacleKind {
    /// Keep to one side of a plane (seed eq. 4.9).
    HalfSpace,
    /// Keep out of a ball.
    Sphere,
}

/// A `[[load_case]]`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LoadCaseSpec {
    /// Case name.
    pub name: String,
    /// Factor on the load joints' own `force`/`mass` (default 1).
    #[serde(default = "one")]
    pub factor: f64,
    /// Additional loads.
    #[serde(default)]
    pub loads: Vec<CaseLoadSpec>,
}

fn one() -> f64 {
    1.0
}

/// An additional load in a case.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CaseLoadSpec {
    /// Name of a load joint.
    pub joint: String,
    /// Force, N.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt")]
    pub force: Option<[f64; 3]>,
    /// Mass, kg (weight downward).
    pub mass: Option<f64>,
}

/// The `[rounds]` table (seed §4.3.2).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RoundsSpec {
    /// At most this many solve + clean-up rounds (`--rounds` overrides); by default the rounds
    /// run until the design stops changing, at most `ROUND_CAP` (src/truss/rounds.rs).
    pub count: Option<usize>,
    /// Drop beams whose largest |λ| is below this fraction of the largest |λ| (default 1e-6:
    /// zero-force members).
    #[serde(default = "default_prune")]
    pub prune: f64,
    /// Join two crossing beams by a new free joint at the crossing (default false).
    #[serde(default)]
    pub split_crossings: bool,
    /// Remove the weaker of two crossing beams instead (takes precedence over the split).
    #[serde(default)]
    pub remove_crossings: bool,
    /// Beams shorter than l_min·(1 + merge_tolerance) have their joints merged (default 1e-3).
    #[serde(default = "default_merge_tolerance")]
    pub merge_tolerance: f64,
}

impl Default for RoundsSpec {
    fn default() -> Self {
        RoundsSpec {
            count: None,
            prune: default_prune(),
            split_crossings: false,
            remove_crossings: false,
            merge_tolerance: default_merge_tolerance(),
        }
    }
}

fn default_prune() -> f64 {
    1e-6
}

fn default_merge_tolerance() -> f64 {
    1e-3
}

/// Validation of everything that can be checked without building the ground structure.
pub fn validate(spec: &TrussSpec, src: &Source) -> Result<(), InputError> {
    use Key::{Index as I, Name as N};
    let err = |path: &[Key<'_>], msg: String| src.error_at(path, msg);
    if let Some(name) = &spec.name
        && name.trim().is_empty()
    {
        return Err(err(&[N("name")], "`name` must not be empty".into()));
    }
    src.positive(&[N("max_force")], spec.max_force)?;
    src.positive(&[N("min_length")], spec.min_length)?;
    if let Some(l) = spec.max_length {
        src.positive(&[N("max_length")], l)?;
        if l <= spec.min_length {
            return Err(err(
                &[N("max_length")],
                format!(
                    "`max_length` ({l}) must exceed `min_length` ({})",
                    spec.min_length
                ),
            ));
        }
    }
    match (spec.objective, spec.compression_penalty) {
        (ObjectiveKind::MassTensionPreference, Some(p)) => {
            src.positive(&[N("compression_penalty")], p)?
        }
        (ObjectiveKind::MassTensionPreference, None) => {}
        (_, Some(_)) => {
            return Err(err(
                &[N("compression_penalty")],
                "`compression_penalty` applies only to objective = \"mass_tension_preference\""
                    .into(),
            ));
        }
        _ => {}
    }
    if spec.objective == ObjectiveKind::MassTensionPreference && spec.load_cases.len() > 1 {
        return Err(err(
            &[N("objective")],
            "\"mass_tension_preference\" supports a single load case".into(),
        ));
    }
    if spec.planar && spec.hold_in_planes == Some(Axis::Z) {
        return Err(err(
            &[N("hold_in_planes")],
            "`planar` problems already keep z; drop `hold_in_planes = \"z\"`".into(),
        ));
    }
    validate_mass(&spec.mass, src)?;
    validate_joints(spec, src)?;
    validate_ground(&spec.ground, src)?;
    src.count_in(
        &[N("connect"), N("neighbours")],
        spec.connect.neighbours,
        1,
        MAX_NEIGHBOURS,
    )?;
    if spec.connect.full && spec.start_forces != StartForces::Layout {
        return Err(err(
            &[N("connect"), N("full")],
            "`full` connectivity needs start_forces = \"layout\" (the layout LP adds its members)"
                .into(),
        ));
    }
    for (i, m) in spec.symmetry.iter().enumerate() {
        finite3(&m.point, src, &[N("symmetry"), I(i), N("point")])?;
        unit(&m.normal, src, &[N("symmetry"), I(i), N("normal")])?;
        if spec.planar && m.normal[2] != 0.0 {
            return Err(err(
                &[N("symmetry"), I(i), N("normal")],
                "a planar problem's mirror normal must lie in the plane (z component 0)".into(),
            ));
        }
    }
    for (i, o) in spec.obstacles.iter().enumerate() {
        let at = |k: &'static str| [N("obstacle"), I(i), N(k)];
        let (need, forbid): (&[&str], &[&str]) = match o.kind {
            ObstacleKind::HalfSpace => (&["point", "normal"], &["center", "radius"]),
            ObstacleKind::Sphere => (&["center", "radius"], &["point", "normal"]),
        };
        let present = |k: &str| match k {
            "point" => o.point.is_some(),
            "normal" => o.normal.is_some(),
            "center" => o.center.is_some(),
            _ => o.radius.is_some(),
        };
        for k in need {
            if !present(k) {
                return Err(err(
                    &[N("obstacle"), I(i)],
                    format!("this obstacle needs `{k}`"),
                ));
            }
        }
        for k in forbid {
            if present(k) {
                return Err(err(
                    &at(k),
                    format!("`{k}` does not apply to this obstacle kind"),
                ));
            }
        }
        if let Some(p) = &o.point {
            finite3(p, src, &at("point"))?;
        }
        if let Some(n) = &o.normal {
            unit(n, src, &at("normal"))?;
        }
        if let Some(c) = &o.center {
            finite3(c, src, &at("center"))?;
        }
        if let Some(r) = o.radius {
            src.positive(&at("radius"), r)?;
        }
    }
    for (i, case) in spec.load_cases.iter().enumerate() {
        src.finite(&[N("load_case"), I(i), N("factor")], case.factor)?;
        for (k, load) in case.loads.iter().enumerate() {
            let at = [N("load_case"), I(i), N("loads"), I(k)];
            if load.force.is_none() && load.mass.is_none() {
                return Err(err(&at, "a case load needs `force` or `mass`".into()));
            }
            if let Some(f) = &load.force {
                finite3(f, src, &at)?;
            }
            if let Some(m) = load.mass {
                src.non_negative(&[&at[..], &[N("mass")]].concat(), m)?;
            }
        }
    }
    let r = &spec.rounds;
    if !(r.prune.is_finite() && (0.0..1.0).contains(&r.prune)) {
        return Err(err(
            &[N("rounds"), N("prune")],
            format!("`prune` must be in [0, 1), got {}", r.prune),
        ));
    }
    src.non_negative(&[N("rounds"), N("merge_tolerance")], r.merge_tolerance)?;
    if let Some(count) = r.count {
        src.count_in(&[N("rounds"), N("count")], count, 1, MAX_ROUNDS)?;
    }
    validate_solver(&spec.solver, src, &[N("solver")])
}

fn validate_mass(m: &MassSpec, src: &Source) -> Result<(), InputError> {
    use Key::Name as N;
    let (allowed, other): (&[&str], &[&str]) = match m.model {
        MassKind::Seed => (&["k_t", "k_c"], &["sigma_t", "sigma_c", "density"]),
        MassKind::Linear => (&["sigma_t", "sigma_c", "density"], &["k_t", "k_c"]),
    };
    let value = |k: &str| match k {
        "k_t" => m.k_t,
        "k_c" => m.k_c,
        "sigma_t" => m.sigma_t,
        "sigma_c" => m.sigma_c,
        _ => m.density,
    };
    for k in other {
        if value(k).is_some() {
            return Err(src.error_at(
                &[N("mass"), N(k)],
                format!("`{k}` does not apply to this mass model"),
            ));
        }
    }
    for k in allowed.iter().chain(std::iter::once(&"blend_force")) {
        let v = if *k == "blend_force" {
            m.blend_force
        } else {
            value(k)
        };
        if let Some(v) = v {
            src.positive(&[N("mass"), N(k)], v)?;
        }
    }
    if m.model == MassKind::Linear && (m.sigma_t.is_none() || m.sigma_c.is_none()) {
        return Err(src.error_at(
            &[N("mass")],
            "the linear mass model needs `sigma_t` and `sigma_c`",
        ));
    }
    Ok(())
}

fn validate_joints(spec: &TrussSpec, src: &Source) -> Result<(), InputError> {
    use Key::{Index as I, Name as N};
    let mut total = 0.0;
    for (i, j) in spec.joints.iter().enumerate() {
        let at = |k: &'static str| [N("joint"), I(i), N(k)];
        let here = [N("joint"), I(i)];
        finite3(&j.at, src, &at("at"))?;
        total += j.count.unwrap_or(1) as f64;
        match (j.to, j.count) {
            (Some(to), Some(n)) => {
                finite3(&to, src, &at("to"))?;
                if n < 2 {
                    return Err(src.error_at(&at("count"), "a row needs `count` ≥ 2"));
                }
                src.within_limit(&at("count"), total, MAX_JOINTS as f64, "joints")?;
            }
            (None, None) => {}
            (Some(_), None) => {
                return Err(src.error_at(&at("to"), "`to` needs `count`"));
            }
            (None, Some(_)) => {
                return Err(src.error_at(&at("count"), "`count` needs `to`"));
            }
        }
        if spec.planar && (j.at[2] != spec.joints[0].at[2] || j.to.is_some_and(|t| t[2] != j.at[2]))
        {
            return Err(src.error_at(&at("at"), "in a planar problem every joint has the same z"));
        }
        let is_anchor = j.kind == JointKindSpec::Anchor;
        let is_load = j.kind == JointKindSpec::Load;
        if !is_anchor && (j.support.is_some() || j.reactions.is_some()) {
            let k = if j.support.is_some() {
                "support"
            } else {
                "reactions"
            };
            return Err(src.error_at(&at(k), format!("`{k}` applies only to anchors")));
        }
        if !is_load && (j.force.is_some() || j.mass.is_some()) {
            let k = if j.force.is_some() { "force" } else { "mass" };
            return Err(src.error_at(&at(k), format!("`{k}` applies only to load joints")));
        }
        if let Some(f) = &j.force {
            finite3(f, src, &at("force"))?;
            if spec.planar && f[2] != 0.0 {
                return Err(src.error_at(
                    &at("force"),
                    "a planar problem's forces have no z component",
                ));
            }
        }
        if let Some(m) = j.mass {
            src.non_negative(&at("mass"), m)?;
        }
        let roller = j.support == Some(SupportKind::Roller);
        match (&j.reactions, roller) {
            (Some(_), false) => {
                return Err(
                    src.error_at(&at("reactions"), "`reactions` needs `support = \"roller\"`")
                );
            }
            (None, true) => {
                return Err(src.error_at(
                    &here,
                    "a roller needs `reactions` (its reaction directions)",
                ));
            }
            (Some(r), true) => {
                if r.is_empty() || r.len() > 2 {
                    return Err(src.error_at(
                        &at("reactions"),
                        "a roller has one or two reaction directions",
                    ));
                }
                for d in r {
                    unit(d, src, &at("reactions"))?;
                }
                if r.len() == 2 && cross_norm(&r[0], &r[1]) < 1e-6 {
                    return Err(
                        src.error_at(&at("reactions"), "the two reaction directions are parallel")
                    );
                }
            }
            (None, false) => {}
        }
    }
    let count = |k: JointKindSpec| spec.joints.iter().filter(|j| j.kind == k).count();
    if count(JointKindSpec::Anchor) == 0 {
        return Err(src.error_at(&[N("joint")], "the problem needs at least one anchor"));
    }
    if count(JointKindSpec::Load) == 0 {
        return Err(src.error_at(&[N("joint")], "the problem needs at least one load joint"));
    }
    Ok(())
}

fn validate_ground(g: &GroundSpec, src: &Source) -> Result<(), InputError> {
    use Key::Name as N;
    let at = |k: &'static str| [N("ground"), N(k)];
    let used: &[&str] = match g.kind {
        GroundKind::Layers => &["spacing", "layers", "direction", "from"],
        GroundKind::Lattice => &["spacing", "min", "max", "margin"],
        GroundKind::Random => &[
            "count", "region", "min", "max", "margin", "center", "radius",
        ],
        GroundKind::None => &[],
    };
    let present = [
        ("spacing", g.spacing.is_some()),
        ("layers", g.layers.is_some()),
        ("direction", g.direction.is_some()),
        ("from", g.from.is_some()),
        ("min", g.min.is_some()),
        ("max", g.max.is_some()),
        ("margin", g.margin.is_some()),
        ("count", g.count.is_some()),
        ("region", g.region.is_some()),
        ("center", g.center.is_some()),
        ("radius", g.radius.is_some()),
    ];
    for (k, p) in present {
        if p && !used.contains(&k) {
            return Err(src.error_at(&at(k), format!("`{k}` does not apply to this ground kind")));
        }
    }
    if let Some(s) = g.spacing {
        for h in s.steps() {
            src.positive(&at("spacing"), h)?;
        }
    }
    if matches!(g.kind, GroundKind::Layers | GroundKind::Lattice) && g.spacing.is_none() {
        return Err(src.error_at(&[N("ground")], "this ground kind needs `spacing`"));
    }
    if let Some(n) = g.layers {
        src.at_least(&at("layers"), n, 1)?;
    }
    if let Some(m) = g.margin {
        src.non_negative(&at("margin"), m)?;
    }
    if let (Some(lo), Some(hi)) = (g.min, g.max) {
        finite3(&lo, src, &at("min"))?;
        finite3(&hi, src, &at("max"))?;
        if (0..3).any(|k| lo[k] > hi[k]) {
            return Err(src.error_at(&at("max"), "`max` must be ≥ `min` on every axis"));
        }
    } else if g.min.is_some() != g.max.is_some() {
        return Err(src.error_at(&[N("ground")], "give both `min` and `max`"));
    }
    if g.kind == GroundKind::Random {
        match g.count {
            None | Some(0) => {
                return Err(src.error_at(&[N("ground")], "random ground needs `count` ≥ 1"));
            }
            Some(_) => {}
        }
        if g.region == Some(Region::Sphere) {
            match (g.center, g.radius) {
                (Some(c), Some(r)) => {
                    finite3(&c, src, &at("center"))?;
                    src.positive(&at("radius"), r)?;
                }
                _ => {
                    return Err(src.error_at(
                        &[N("ground")],
                        "a random sphere needs `center` and `radius`",
                    ));
                }
            }
        } else if g.center.is_some() || g.radius.is_some() {
            let k = if g.center.is_some() {
                "center"
            } else {
                "radius"
            };
            return Err(src.error_at(&at(k), format!("`{k}` needs `region = \"sphere\"`")));
        }
    }
    Ok(())
}

fn finite3(v: &[f64; 3], src: &Source, path: &[Key<'_>]) -> Result<(), InputError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(src.error_at(path, "coordinates must be finite"))
    }
}

fn unit(v: &[f64; 3], src: &Source, path: &[Key<'_>]) -> Result<(), InputError> {
    finite3(v, src, path)?;
    if v.iter().map(|x| x * x).sum::<f64>() > 0.0 {
        Ok(())
    } else {
        Err(src.error_at(path, "a direction must not be zero"))
    }
}

fn cross_norm(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let (na, nb) = (
        a.iter().map(|x| x * x).sum::<f64>().sqrt(),
        b.iter().map(|x| x * x).sum::<f64>().sqrt(),
    );
    let c = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    c.iter().map(|x| x * x).sum::<f64>().sqrt() / (na * nb)
}
