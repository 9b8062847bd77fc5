//! CMC problem files (TOML, SI units: metres, cubic metres), see `problems/cmc/`.
//!
//! ```toml
//! name = "double_bubble"        # optional; defaults to the file stem
//! resolution = 6                # optional refinement level (meaning per shape, see below)
//! formulation = "normal"        # normal (area in normal coordinates) | area | curvature (per-vertex rows, seed eq. 5.4), cmc::nlp
//! [shape]
//! type = "double_bubble"        # sphere | double_bubble | triple_bubble | cube_frame |
//! volumes = [1.0e-6, 2.0e-6]    # octahedron_frame | catenoid | u_wires | tents | cells |
//!                               # cluster | obj | gltf
//! [quality]
//! tangential_weight = 0.01      # w of the tangential regularization (cmc::nlp), ≥ 0; default per shape
//! flip_rounds = 1               # edge-flip + re-solve rounds after the first solve (cmc::remesh)
//! coarse_resolution = 1         # solve coarse first, then refine (cmc::multilevel); default per shape
//! refine = 1.5                  # optional: in those rounds split edges > 1.5 × median start edge
//! [refine]                      # optional refinement study (cmc::refinement)
//! levels = 4                    # the resolution, then 3 levels each subdivided ×2
//! expected_order = 2.0          # order the area is expected to converge at
//! [stability]                   # optional: the stability analysis at the solution
//! eigenvalues = 6               # smallest eigenvalues reported (0–50); 0 switches it off
//! [[chord]]                     # optional chord-length constraints between vertex indices
//! a = 0
//! b = 12
//! length = 0.5
//! [[pressure]]                  # optional: a body at a prescribed pressure, no volume row
//! body = "dome"                 # a volume of the shape, by name
//! value = 2.0                   # pressure / surface tension, 1/m (a cap of radius 2/value)
//! [solver]                      # the shared solver table
//! ```
//! Resolution: icosphere subdivision level (sphere), 12·resolution segments per ring (catenoid),
//! rings per cap (double bubble), rows per
//! half-meridian (triple bubble), segments per wire (frames, U wires), rings from centre to rim
//! (tents, cells), segments per polygon edge of the start complex (cluster); ignored for OBJ and
//! glTF imports.

use std::path::Path;

use serde::Deserialize;

use super::catenoid;
use super::cluster::{self, Bubble};
use super::generators::{self, CellSpec, Pole, Shape, TentSpec};
use super::mesh::Point;
use super::nlp::{Chord, Formulation};
use super::octahedron::{self, OctahedronTopology};
use super::ring_tent;
use super::volume::Region;
use crate::error::InputError;
use crate::solver::Options;
use crate::spec::{Key, Source, is_positive as positive, validate_solver};

/// Largest `resolution` and `[quality] coarse_resolution` (the face count is bounded too,
/// [`MAX_FACES`]).
pub const MAX_RESOLUTION: usize = 64;
/// Most start-mesh faces a problem may ask for, estimated before the mesh is built
/// ([`ShapeSpec::face_estimate`]).
pub const MAX_FACES: usize = 500_000;
/// Most bubbles of a cluster.
pub const MAX_BUBBLES: usize = 32;
/// Most corners of a regular polygon (`sides`).
pub const MAX_SIDES: usize = 1_000;

/// The whole file.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CmcFile {
    /// Problem name; defaults to the file stem.
    pub name: Option<String>,
    /// Refinement level; defaults per shape ([`ShapeSpec::default_resolution`]).
    pub resolution: Option<usize>,
    /// How the vertices are placed normally ([`Formulation`]); default `normal`.
    #[serde(default)]
    pub formulation: Formulation,
    /// The start shape.
    #[serde(deserialize_with = "crate::spec::tagged::deserialize")]
    pub shape: ShapeSpec,
    /// Mesh-quality settings.
    #[serde(default)]
    pub quality: QualitySpec,
    /// Refinement study.
    #[serde(default)]
    pub refine: RefineSpec,
    /// Stability analysis.
    #[serde(default)]
    pub stability: StabilitySpec,
    /// Topology events.
    #[serde(default)]
    pub topology: TopologySpec,
    /// Chord-length constraints.
    #[serde(default)]
    pub chord: Vec<ChordSpec>,
    /// Bodies at a prescribed pressure.
    #[serde(default)]
    pub pressure: Vec<PressureSpec>,
    /// Solver options.
    #[serde(default)]
    pub solver: Options,
}

/// `[quality]`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct QualitySpec {
    /// Weight of the tangential regularization (dimensionless, ≥ 0); default per shape
    /// ([`ShapeSpec::default_tangential_weight`]).
    #[serde(default)]
    pub tangential_weight: Option<f64>,
    /// Rounds of equiangulation (edge flips) and re-solving after the first solve; default 1.
    #[serde(default = "default_flip_rounds")]
    pub flip_rounds: usize,
    /// Resolution of the first solve of a coarse-to-fine start ([`super::multilevel`]);
    /// default per shape ([`ShapeSpec::default_coarse_resolution`]), for most shapes none
    /// (solve the resolution's start directly).
    #[serde(default)]
    pub coarse_resolution: Option<usize>,
    /// In those rounds also split edges longer than `refine` × the start mesh's median edge
    /// length (cmc::remesh::split_long_edges); omitted: no refinement.
    #[serde(default)]
    pub refine: Option<f64>,
}

fn default_flip_rounds() -> usize {
    1
}

impl Default for QualitySpec {
    fn default() -> Self {
        QualitySpec {
            tangential_weight: None,
            flip_rounds: default_flip_rounds(),
            coarse_resolution: None,
            refine: None,
        }
    }
}

/// `[refine]`: a refinement study ([`super::refinement`]).
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RefineSpec {
    /// Levels solved: the file's resolution, then `levels − 1` ×2 subdivisions (1–6);
    /// default 1 (no study).
    #[serde(default = "default_levels")]
    pub levels: usize,
    /// Expected order of convergence of the area in the edge length (0.5–8); default 2.
    #[serde(default = "default_order")]
    pub expected_order: f64,
}

/// `[stability]`: the stability analysis at the solution ([`super::stability`]).
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct StabilitySpec {
    /// Smallest eigenvalues reported (0 to [`MAX_REPORTED_EIGENVALUES`]); 0 switches the
    /// analysis off (no `figures.stability`); default [`super::stability::REPORTED`].
    #[serde(default = "default_eigenvalues")]
    pub eigenvalues: usize,
    /// When the solution is a saddle, move it along the negative mode and solve again
    /// ([`super::descend`]); default false.
    #[serde(default)]
    pub descend: bool,
}

/// `[topology]`: topology events ([`super::topology`]).
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TopologySpec {
    /// Pop the non-minimal junctions after each solve and solve again (Surface Evolver's `O`
    /// and `o`, [`super::pop`]); default false: they are counted and reported only.
    #[serde(default)]
    pub pop: bool,
}

/// Most eigenvalues `[stability] eigenvalues` may ask for.
pub const MAX_REPORTED_EIGENVALUES: usize = 50;

fn default_eigenvalues() -> usize {
    super::stability::REPORTED
}

impl Default for StabilitySpec {
    fn default() -> Self {
        StabilitySpec {
            eigenvalues: default_eigenvalues(),
            descend: false,
        }
    }
}

/// Most levels of a refinement study.
pub const MAX_REFINE_LEVELS: usize = 6;

fn default_levels() -> usize {
    1
}

fn default_order() -> f64 {
    2.0
}

impl Default for RefineSpec {
    fn default() -> Self {
        RefineSpec {
            levels: default_levels(),
            expected_order: default_order(),
        }
    }
}

/// `[[pressure]]`: the shape's volume named `body` has the prescribed pressure `value`
/// (pressure over surface tension, 1/m) instead of its volume (Surface Evolver's `pressure`).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PressureSpec {
    /// Name of a volume of the shape (a cell, bubble or `[[shape.volume]]`).
    pub body: String,
    /// Pressure / surface tension, 1/m.
    pub value: f64,
}

/// `[[chord]]`: vertices `a` and `b` (0-based indices of the built mesh) stay `length` m apart.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ChordSpec {
    /// First vertex index.
    pub a: usize,
    /// Second vertex index.
    pub b: usize,
    /// Length, m.
    pub length: f64,
}

/// `[shape]`: which start shape, with its parameters.
///
/// Read from a table whose `type` key names the variant ([`crate::spec::tagged`]).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum ShapeSpec {
    /// One bubble of `volume` m³ (an icosphere).
    Sphere {
        /// Volume, m³.
        volume: f64,
    },
    /// The standard double bubble.
    DoubleBubble {
        /// The two volumes, m³.
        #[serde(deserialize_with = "crate::spec::arrays::exact")]
        volumes: [f64; 2],
    },
    /// Three bubbles (wedges of a ball to start).
    TripleBubble {
        /// The three volumes, m³.
        #[serde(deserialize_with = "crate::spec::arrays::exact")]
        volumes: [f64; 3],
    },
    /// Wire cube, with a central bubble or without (the central-square film).
    CubeFrame {
        /// Wire edge length, m.
        edge: f64,
        /// Central bubble volume, m³; absent: no bubble.
        bubble_volume: Option<f64>,
    },
    /// Two coaxial fixed rings spanned by a film (the catenoid).
    Catenoid {
        /// Ring radius, m.
        radius: f64,
        /// Distance between the rings, m.
        separation: f64,
    },
    /// Wire octahedron.
    OctahedronFrame {
        /// Wire edge length, m.
        edge: f64,
        /// Film topology.
        topology: OctahedronTopology,
    },
    /// Two U-shaped wires meeting at their tips.
    UWires {
        /// Width of each U, m.
        width: f64,
        /// Depth of each U, m.
        depth: f64,
    },
    /// The film from a square wire at y = 0 to a raised horizontal ring about the y axis.
    RingTent {
        /// Half the side of the square wire, m.
        half_width: f64,
        /// Radius of the ring, m (below `half_width`).
        ring_radius: f64,
        /// Height of the ring above the square, m.
        ring_height: f64,
    },
    /// Membranes over polygons, lifted by poles.
    Tents {
        /// The membranes.
        tent: Vec<TentToml>,
    },
    /// Free bubbles sharing walls, placed by their centres (`cmc::cluster`).
    Cluster {
        /// The bubbles.
        bubble: Vec<BubbleToml>,
    },
    /// Pneumatic cells on the ground.
    Cells {
        /// The cells.
        cell: Vec<CellToml>,
    },
    /// A mesh from a glTF file, `.glb` or `.gltf` (see `cmc::import_gltf`).
    Gltf {
        /// Path, relative to the problem file.
        file: String,
        /// Fix every boundary vertex.
        #[serde(default)]
        fix_boundary: bool,
        /// Volume constraints.
        #[serde(default)]
        volume: Vec<VolumeToml>,
    },
    /// A mesh from an OBJ file (see `cmc::import`).
    Obj {
        /// Path, relative to the problem file.
        file: String,
        /// Fix every boundary vertex (films spanning wires modelled as open edges).
        #[serde(default)]
        fix_boundary: bool,
        /// Volume constraints.
        #[serde(default)]
        volume: Vec<VolumeToml>,
    },
}

/// A closed or ground-standing polygon: explicit corners or a regular polygon.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RimToml {
    /// Centre (x, z), m.
    #[serde(deserialize_with = "crate::spec::arrays::exact")]
    pub centre: [f64; 2],
    /// Circumradius, m.
    pub radius: f64,
    /// Height of the rim, m.
    #[serde(default)]
    pub height: f64,
    /// Number of corners.
    pub sides: usize,
}

/// A ring of equal poles.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PoleRingToml {
    /// Centre (x, z), m.
    #[serde(deserialize_with = "crate::spec::arrays::exact")]
    pub centre: [f64; 2],
    /// Ring radius, m.
    pub radius: f64,
    /// Number of poles.
    pub count: usize,
    /// Pole height, m.
    pub height: f64,
    /// Radius of each lifted cap, m.
    pub cap: f64,
    /// Angle of the first pole from +x towards −z, degrees.
    #[serde(default)]
    pub phase: f64,
}

/// One pole.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PoleToml {
    /// Position (x, z), m.
    #[serde(deserialize_with = "crate::spec::arrays::exact")]
    pub at: [f64; 2],
    /// Height, m.
    pub height: f64,
    /// Radius of the lifted cap, m.
    pub cap: f64,
}

/// `[[shape.bubble]]` of a cluster.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BubbleToml {
    /// Name of the bubble's volume and outer skin.
    pub name: String,
    /// Where the bubble sits, m.
    #[serde(deserialize_with = "crate::spec::arrays::exact")]
    pub centre: [f64; 3],
    /// Its volume, m³.
    pub volume: f64,
}

/// `[[shape.tent]]`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TentToml {
    /// Surface name.
    pub name: String,
    /// Rim corners (x, y, z), m, counter-clockwise seen from above.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt_vec")]
    pub boundary: Option<Vec<[f64; 3]>>,
    /// Or a regular polygon rim.
    pub rim: Option<RimToml>,
    /// Single poles.
    #[serde(default)]
    pub pole: Vec<PoleToml>,
    /// Rings of poles.
    #[serde(default)]
    pub pole_ring: Vec<PoleRingToml>,
}

/// `[[shape.cell]]`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CellToml {
    /// Surface name.
    pub name: String,
    /// Footprint corners (x, z), m, counter-clockwise seen from above.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact_opt_vec")]
    pub footprint: Option<Vec<[f64; 2]>>,
    /// Or a regular polygon footprint (its `height` is ignored).
    pub circle: Option<RimToml>,
    /// Crown height of a paraboloid start dome, m; omitted: the start is inflated to `volume`.
    #[serde(default)]
    pub height: Option<f64>,
    /// Enclosed volume, m³.
    pub volume: f64,
}

/// `[[shape.volume]]` for imported meshes.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct VolumeToml {
    /// Name used in reports.
    pub name: String,
    /// Bounding surfaces; prefix `-` for surfaces whose normals point into the region.
    pub surfaces: Vec<String>,
    /// Reference point (m), on the fixed plane for regions closed by one; default origin.
    #[serde(default, deserialize_with = "crate::spec::arrays::exact")]
    pub reference: [f64; 3],
    /// Volume, m³.
    pub volume: f64,
}

impl ShapeSpec {
    /// An upper estimate of the start mesh's triangles at `resolution`, in floating point so
    /// that absurd inputs cannot overflow: an icosphere has 20·4ʳ; tents their generator's
    /// count (at most 6·r² per fan, 2·r·(r·a + 1) per quadrilateral grid of aspect ratio a);
    /// the other generators grow with r² per surface piece (a cell), at most 100·r² each,
    /// times the aspect ratio where rows follow it (U wires: depth/width; quadrilateral cells:
    /// long/short side). Imports are bounded when read ([`super::import`]).
    pub fn face_estimate(&self, resolution: usize) -> f64 {
        let r = resolution as f64;
        let pieces = match self {
            ShapeSpec::Sphere { .. } => return 20.0 * 4f64.powf(r),
            ShapeSpec::Obj { .. } | ShapeSpec::Gltf { .. } => return 0.0,
            ShapeSpec::UWires { width, depth } => (depth / width).max(1.0),
            ShapeSpec::Tents { tent } => {
                let faces: f64 = tent.iter().map(|t| tent_faces(t, r)).sum();
                return if faces.is_nan() { f64::INFINITY } else { faces };
            }
            ShapeSpec::Cluster { bubble } => 3.0 * bubble.len() as f64,
            ShapeSpec::Cells { cell } => cell
                .iter()
                .map(|c| {
                    let corners: Vec<[f64; 3]> = (c.footprint.iter().flatten())
                        .map(|&[x, z]| [x, 0.0, z])
                        .collect();
                    quad_aspect(&corners)
                })
                .sum(),
            _ => 1.0,
        };
        // NaN (a zero width) counts as over every limit.
        if pieces.is_nan() {
            return f64::INFINITY;
        }
        100.0 * r * r * pieces
    }

    /// The tangential weight `w` used when `[quality] tangential_weight` is not given: 1 for
    /// the shapes whose films drift into collapsed triangles at w = 0.01 (frames, cells,
    /// clusters, the triple bubble), 0.01 for the others, where w = 1 would raise the area
    /// more than it helps (U wires +0.04 %, tents +0.15–0.4 %, the double bubble +0.007 % at the
    /// shipped resolutions). Measured at w = 0.01: the cube frame with its bubble and the triple
    /// bubble Stalled with 0° triangles from resolution 3 on, the tennis cushion with 0.08°
    /// triangles; a triple bubble of 1, 2 and 3 cm³ Stalled at resolution 4 and took 7.3 s at
    /// resolution 8 (0.05 and 0.32 s with these defaults); the cube film took 116 iterations
    /// instead of 35 (docs/notes/cmc.md, "defaults for far starts").
    pub fn default_tangential_weight(&self) -> f64 {
        match self {
            ShapeSpec::CubeFrame { .. }
            | ShapeSpec::OctahedronFrame { .. }
            | ShapeSpec::Cells { .. }
            | ShapeSpec::Cluster { .. }
            | ShapeSpec::TripleBubble { .. } => 1.0,
            _ => 0.01,
        }
    }

    /// The coarse level used when `[quality] coarse_resolution` is not given
    /// (cmc::multilevel): the octahedral frames and clusters start at one segment per wall
    /// edge (1), their starts being flat partitions whose junctions must travel far (without
    /// it the quadrilateral and pentagon films stall on collapsed triangles, and five clusters
    /// written from the docs, 2–6 bubbles, took 8–45× longer or stopped at the iteration
    /// limit). Other shapes solve their start directly (the triple bubble from resolution 12
    /// on after a prolonged coarse level, [`ShapeSpec::default_prolonged_resolution`]): from its digon
    /// start (two triangles per lune and one per wall at each pole) the direct solve at
    /// resolutions 4–16 took 23–122 iterations, smallest angle ≥ 12.1°; the grid start's
    /// coarse levels (the largest divisor from 2 to 4, subdivided) and direct solves collapsed
    /// at the poles from resolution 10 on (docs/notes/cmc.md, "the triple bubble's poles").
    pub fn default_coarse_resolution(&self) -> Option<usize> {
        match self {
            ShapeSpec::OctahedronFrame { .. } | ShapeSpec::Cluster { .. } => Some(1),
            _ => None,
        }
    }

    /// The coarse level whose solution starts the solve at `resolution` when `[quality]
    /// coarse_resolution` is not given, prolonged onto the generator's own start
    /// (cmc::prolong: same triangulation, no subdivision): the bubble-free cube frame film at
    /// a third of its resolution when that is at least 2. Its start is a flat partition whose
    /// films must curve and whose vertices must spread tangentially; on the generator's own
    /// start the normal-coordinate rounds' tangential relaxation converges slowly (7 rounds at
    /// resolution 6, the 8-round cap at 12 and 22), from the prolonged coarse solution in 2–3
    /// rounds: CPU at resolutions 6 / 12 / 22 (792 / 3,168 / 10,648 facets, `flip_rounds = 0`)
    /// 26.5 / 93 / 405 → 19.2 / 52 / 160 ms, areas 0.004–0.027 % lower, 0.001 / 0.003 % above
    /// the area formulation's minimum on the same triangulation at 792 / 10,648 facets
    /// (docs/notes/cmc.md). A coarse level of 1 segment per wire (resolutions 3–5) or of half
    /// the resolution took more iterations than none. The
    /// cube frame with a bubble, whose start already holds the bubble's volume, gained nothing
    /// (resolution 8: 14 → 16 iterations): no coarse level. The triple bubble from resolution
    /// 12 on at half its resolution: from its own start the first normal-coordinate solve
    /// stalled near the answer from resolution 14 on and the area-formulation fallback
    /// finished it (120–130 iterations, 1.4–7.0 s at 14–24); from the prolonged half-resolution
    /// solution 28–46 iterations, 0.24–0.80 s, smallest angle 12.4–16.3° (docs/notes/cmc.md).
    pub fn default_prolonged_resolution(&self, resolution: usize) -> Option<usize> {
        match self {
            ShapeSpec::CubeFrame {
                bubble_volume: None,
                ..
            } if resolution / 3 >= 2 => Some(resolution / 3),
            ShapeSpec::TripleBubble { .. } if resolution >= 12 => Some(resolution / 2),
            _ => None,
        }
    }

    /// The resolution used when the file gives none.
    pub fn default_resolution(&self) -> usize {
        match self {
            ShapeSpec::Sphere { .. } | ShapeSpec::Catenoid { .. } => 4,
            ShapeSpec::DoubleBubble { .. } | ShapeSpec::TripleBubble { .. } => 8,
            ShapeSpec::CubeFrame { .. } | ShapeSpec::OctahedronFrame { .. } => 8,
            ShapeSpec::UWires { .. } => 16,
            ShapeSpec::RingTent { .. } => 4,
            ShapeSpec::Tents { .. } | ShapeSpec::Cells { .. } => 10,
            ShapeSpec::Cluster { .. } => 4,
            ShapeSpec::Obj { .. } | ShapeSpec::Gltf { .. } => 1,
        }
    }
}

/// A validated file plus where it came from.
#[derive(Debug, Clone)]
pub struct CmcSpec {
    /// The parsed file.
    pub file: CmcFile,
    /// Its text, for positioned errors.
    pub source: Source,
}

/// Parses and validates a problem file.
/// The key path `shape.<key>`.
fn shape(key: &'static str) -> [Key<'static>; 2] {
    [Key::Name("shape"), Key::Name(key)]
}

/// The key path `shape.<table>[i].<key>` (an entry of an array of tables inside `[shape]`).
fn shape_entry(table: &'static str, i: usize, key: &'static str) -> [Key<'static>; 4] {
    [
        Key::Name("shape"),
        Key::Name(table),
        Key::Index(i),
        Key::Name(key),
    ]
}

pub fn parse(source: Source) -> Result<CmcSpec, InputError> {
    let file: CmcFile = source.parse()?;
    let spec = CmcSpec { file, source };
    spec.validate()?;
    Ok(spec)
}

impl CmcSpec {
    fn err(&self, path: &[Key<'_>], message: impl Into<String>) -> InputError {
        self.source.error_at(path, message)
    }

    /// Checks every range of the file, in the order of its tables: solver, meshing
    /// (resolution, quality, refine, chords), the shape, then the mesh size (estimated from
    /// the shape's dimensions, so a zero width is named as such, not as an infinite mesh).
    fn validate(&self) -> Result<(), InputError> {
        validate_solver(&self.file.solver, &self.source, &[Key::Name("solver")])?;
        self.validate_meshing()?;
        self.validate_shape()?;
        self.validate_size()
    }

    /// The meshing keys: `resolution`, `[quality]`, `[refine]`, `[stability]` and the chord
    /// lengths (m).
    fn validate_meshing(&self) -> Result<(), InputError> {
        let f = &self.file;
        let src = &self.source;
        if let Some(r) = f.resolution {
            src.count_in(&["resolution".into()], r, 1, MAX_RESOLUTION)?;
        }
        src.count_in(
            &["quality".into(), "flip_rounds".into()],
            f.quality.flip_rounds,
            0,
            10,
        )?;
        if let Some(r) = f.quality.coarse_resolution {
            src.count_in(
                &["quality".into(), "coarse_resolution".into()],
                r,
                1,
                MAX_RESOLUTION,
            )?;
        }
        if f.quality
            .refine
            .is_some_and(|r| !(r.is_finite() && r >= 1.0))
        {
            return Err(self.err(
                &["quality".into(), "refine".into()],
                "`refine` must be a finite number ≥ 1 (a multiple of the median edge length)",
            ));
        }
        src.count_in(
            &["refine".into(), "levels".into()],
            f.refine.levels,
            1,
            MAX_REFINE_LEVELS,
        )?;
        src.count_in(
            &["stability".into(), "eigenvalues".into()],
            f.stability.eigenvalues,
            0,
            MAX_REPORTED_EIGENVALUES,
        )?;
        let order = f.refine.expected_order;
        if !(order.is_finite() && (0.5..=8.0).contains(&order)) {
            return Err(self.err(
                &["refine".into(), "expected_order".into()],
                "`expected_order` must be a number from 0.5 to 8",
            ));
        }
        if let Some(w) = f.quality.tangential_weight {
            src.non_negative(&["quality".into(), "tangential_weight".into()], w)?;
        }
        for (i, c) in f.chord.iter().enumerate() {
            src.positive(&["chord".into(), i.into(), "length".into()], c.length)?;
        }
        for (i, p) in f.pressure.iter().enumerate() {
            if !p.value.is_finite() {
                return Err(self.err(
                    &["pressure".into(), i.into(), "value".into()],
                    format!("a pressure must be a finite number (1/m), got {}", p.value),
                ));
            }
        }
        Ok(())
    }

    /// The start mesh (times `4^(levels − 1)` for a refinement study) stays within
    /// `MAX_FACES` faces.
    fn validate_size(&self) -> Result<(), InputError> {
        let (f, src) = (&self.file, &self.source);
        let resolution = f.resolution.unwrap_or_else(|| f.shape.default_resolution());
        let sized_by: &[Key<'_>] = if f.resolution.is_some() {
            &[Key::Name("resolution")]
        } else {
            &[Key::Name("shape")]
        };
        let study_faces = 4f64.powi(f.refine.levels as i32 - 1);
        src.within_limit(
            sized_by,
            f.shape.face_estimate(resolution) * study_faces,
            MAX_FACES as f64,
            if f.refine.levels > 1 {
                "faces at the finest refinement level"
            } else {
                "start-mesh faces"
            },
        )
    }

    /// The `[shape]` table's dimensions (m) and volumes (m³).
    fn validate_shape(&self) -> Result<(), InputError> {
        let (f, src) = (&self.file, &self.source);
        let check_volumes = |volumes: &[f64]| match volumes.iter().find(|v| !positive(**v)) {
            Some(v) => Err(self.err(
                &shape("volumes"),
                format!("volumes must be positive cubic metres, got {v}"),
            )),
            None => Ok(()),
        };
        match &f.shape {
            ShapeSpec::Sphere { volume } => src.positive(&shape("volume"), *volume)?,
            ShapeSpec::DoubleBubble { volumes } => check_volumes(volumes)?,
            ShapeSpec::TripleBubble { volumes } => check_volumes(volumes)?,
            ShapeSpec::CubeFrame {
                edge,
                bubble_volume,
            } => {
                src.positive(&shape("edge"), *edge)?;
                if let Some(bubble_volume) = bubble_volume
                    && !(positive(*bubble_volume) && bubble_volume.cbrt() < 0.8 * edge)
                {
                    return Err(self.err(
                        &shape("bubble_volume"),
                        "`bubble_volume` must be positive and its cube root below 0.8·edge",
                    ));
                }
            }
            ShapeSpec::RingTent {
                half_width,
                ring_radius,
                ring_height,
            } => {
                src.positive(&shape("half_width"), *half_width)?;
                src.positive(&shape("ring_radius"), *ring_radius)?;
                if ring_radius >= half_width {
                    return Err(self.err(
                        &shape("ring_radius"),
                        "`ring_radius` must be below `half_width` (the ring inside the square)",
                    ));
                }
                if !(ring_height.is_finite() && ring_height.abs() <= 100.0 * half_width) {
                    return Err(self.err(
                        &shape("ring_height"),
                        "`ring_height` must be a finite height within 100·half_width",
                    ));
                }
            }
            ShapeSpec::Catenoid { radius, separation } => {
                for (key, v) in [("radius", radius), ("separation", separation)] {
                    src.positive(&shape(key), *v)?;
                }
                if catenoid::exact_catenoid(*radius, *separation).is_none() {
                    return Err(self.err(
                        &shape("separation"),
                        format!(
                            "no catenoid spans rings {separation} m apart: the separation must \
                             be at most 1.3255·radius ({} m)",
                            1.3255 * radius
                        ),
                    ));
                }
            }
            ShapeSpec::OctahedronFrame { edge, .. } => src.positive(&shape("edge"), *edge)?,
            ShapeSpec::UWires { width, depth } => {
                for (key, v) in [("width", width), ("depth", depth)] {
                    src.positive(&shape(key), *v)?;
                }
            }
            ShapeSpec::Tents { tent } => self.validate_tents(tent)?,
            ShapeSpec::Cells { cell } => self.validate_cells(cell)?,
            ShapeSpec::Cluster { bubble } => self.validate_cluster(bubble)?,
            ShapeSpec::Obj { volume, .. } | ShapeSpec::Gltf { volume, .. } => {
                for (i, v) in volume.iter().enumerate() {
                    let at = shape_entry("volume", i, "volume");
                    src.positive(&at, v.volume)?;
                }
            }
        }
        Ok(())
    }

    /// `[[shape.tent]]`: at least one, each with one outline, a simple boundary, positive
    /// pole caps (m) and pole rings.
    fn validate_tents(&self, tent: &[TentToml]) -> Result<(), InputError> {
        if tent.is_empty() {
            return Err(self.err(&shape("tent"), "at least one `[[shape.tent]]`"));
        }
        for (i, t) in tent.iter().enumerate() {
            let at = |k: &'static str| shape_entry("tent", i, k);
            self.check_outline(t.boundary.is_some(), t.rim.as_ref(), &at("name"))?;
            if let Some(b) = &t.boundary {
                let flat: Vec<[f64; 2]> = b.iter().map(|p| [p[0], p[2]]).collect();
                self.check_polygon(&flat, &at("boundary"))?;
            }
            for (j, p) in t.pole.iter().enumerate() {
                let path = [
                    Key::Name("shape"),
                    Key::Name("tent"),
                    Key::Index(i),
                    Key::Name("pole"),
                    Key::Index(j),
                ];
                if !(positive(p.cap) && p.height.is_finite()) {
                    return Err(self.err(&path, "a pole needs a positive `cap` radius"));
                }
            }
            for (j, r) in t.pole_ring.iter().enumerate() {
                let path = [
                    Key::Name("shape"),
                    Key::Name("tent"),
                    Key::Index(i),
                    Key::Name("pole_ring"),
                    Key::Index(j),
                ];
                if !(positive(r.cap) && positive(r.radius) && r.count > 0) {
                    return Err(self.err(
                        &path,
                        "a pole ring needs positive `cap`, `radius` and `count`",
                    ));
                }
            }
        }
        Ok(())
    }

    /// `[[shape.bubble]]`: one to [`MAX_BUBBLES`], distinct names, finite centres (m) at
    /// distinct places, positive volumes (m³).
    fn validate_cluster(&self, bubble: &[BubbleToml]) -> Result<(), InputError> {
        if bubble.is_empty() || bubble.len() > MAX_BUBBLES {
            return Err(self.err(
                &shape("bubble"),
                format!("a cluster needs 1 to {MAX_BUBBLES} `[[shape.bubble]]` entries"),
            ));
        }
        for (i, b) in bubble.iter().enumerate() {
            let at = |k: &'static str| shape_entry("bubble", i, k);
            if b.name.is_empty() || bubble[..i].iter().any(|o| o.name == b.name) {
                return Err(self.err(&at("name"), "bubble names must be distinct and non-empty"));
            }
            if !b.centre.iter().all(|x| x.is_finite())
                || bubble[..i].iter().any(|o| o.centre == b.centre)
            {
                return Err(self.err(
                    &at("centre"),
                    "a bubble's centre must be finite and differ from the others'",
                ));
            }
            self.source.positive(&at("volume"), b.volume)?;
        }
        Ok(())
    }

    /// `[[shape.cell]]`: at least one, each with one outline, a simple footprint, a positive
    /// volume (m³) and height (m).
    fn validate_cells(&self, cell: &[CellToml]) -> Result<(), InputError> {
        let src = &self.source;
        if cell.is_empty() {
            return Err(self.err(&shape("cell"), "at least one `[[shape.cell]]`"));
        }
        for (i, c) in cell.iter().enumerate() {
            let at = |k: &'static str| shape_entry("cell", i, k);
            self.check_outline(c.footprint.is_some(), c.circle.as_ref(), &at("name"))?;
            if let Some(fp) = &c.footprint {
                self.check_polygon(fp, &at("footprint"))?;
            }
            src.positive(&at("volume"), c.volume)?;
            if let Some(h) = c.height {
                src.positive(&at("height"), h)?;
            }
        }
        Ok(())
    }

    fn check_outline(
        &self,
        explicit: bool,
        regular: Option<&RimToml>,
        path: &[Key<'_>],
    ) -> Result<(), InputError> {
        if explicit == regular.is_some() {
            return Err(self.err(
                path,
                "give either corner points or a regular polygon, not both",
            ));
        }
        if let Some(r) = regular
            && !(positive(r.radius) && (3..=MAX_SIDES).contains(&r.sides) && r.height.is_finite())
        {
            return Err(self.err(
                path,
                format!("a regular polygon needs radius > 0 and 3 to {MAX_SIDES} sides"),
            ));
        }
        Ok(())
    }

    /// At least three corners, counter-clockwise seen from above (positive area in (x, −z)),
    /// and star-shaped from the centroid (every fan triangle positively oriented).
    fn check_polygon(&self, corners: &[[f64; 2]], path: &[Key<'_>]) -> Result<(), InputError> {
        if corners.len() < 3 || corners.iter().flatten().any(|v| !v.is_finite()) {
            return Err(self.err(path, "a polygon needs at least three finite corners"));
        }
        let n = corners.len() as f64;
        let cx = corners.iter().map(|c| c[0]).sum::<f64>() / n;
        let cz = corners.iter().map(|c| c[1]).sum::<f64>() / n;
        for i in 0..corners.len() {
            let (a, b) = (corners[i], corners[(i + 1) % corners.len()]);
            // Counter-clockwise seen from +y means clockwise in (x, z).
            let cross = (a[0] - cx) * (b[1] - cz) - (a[1] - cz) * (b[0] - cx);
            if cross >= 0.0 {
                return Err(self.err(
                    path,
                    "the polygon must be counter-clockwise seen from above and star-shaped from its centroid",
                ));
            }
        }
        Ok(())
    }

    /// Builds the start shape at `resolution` and the chords; geometry problems are positioned
    /// at `[shape]`.
    pub fn build(&self, resolution: usize) -> Result<(Shape, Vec<Chord>), InputError> {
        let at_shape = |e: &dyn std::fmt::Display| {
            self.err(
                &["shape".into()],
                format!("cannot build the start mesh: {e}"),
            )
        };
        let shape = match &self.file.shape {
            ShapeSpec::Sphere { volume } => {
                let radius = (3.0 * volume / (4.0 * std::f64::consts::PI)).cbrt();
                let mesh = generators::icosphere(radius, resolution.min(7), "bubble")
                    .map_err(|e| at_shape(&e))?;
                Shape {
                    mesh,
                    volumes: vec![(
                        "bubble".into(),
                        Region {
                            boundary: vec![(0, 1.0)],
                            reference: Point::zeros(),
                        },
                        *volume,
                    )],
                }
            }
            ShapeSpec::DoubleBubble { volumes } => {
                generators::double_bubble(*volumes, resolution).map_err(|e| at_shape(&e))?
            }
            ShapeSpec::TripleBubble { volumes } => {
                generators::triple_bubble(*volumes, resolution).map_err(|e| at_shape(&e))?
            }
            ShapeSpec::CubeFrame {
                edge,
                bubble_volume,
            } => generators::cube_frame(*edge, *bubble_volume, resolution)
                .map_err(|e| at_shape(&e))?,
            ShapeSpec::Catenoid { radius, separation } => {
                catenoid::catenoid(*radius, *separation, resolution).map_err(|e| at_shape(&e))?
            }
            ShapeSpec::RingTent {
                half_width,
                ring_radius,
                ring_height,
            } => ring_tent::ring_tent(*half_width, *ring_radius, *ring_height, resolution)
                .map_err(|e| at_shape(&e))?,
            ShapeSpec::OctahedronFrame { edge, topology } => {
                octahedron::octahedron_frame(*edge, *topology, resolution)
                    .map_err(|e| at_shape(&e))?
            }
            ShapeSpec::UWires { width, depth } => {
                generators::u_wires(*width, *depth, resolution).map_err(|e| at_shape(&e))?
            }
            ShapeSpec::Tents { tent } => {
                let specs: Vec<TentSpec> = tent.iter().map(tent_spec).collect();
                generators::tents(&specs, resolution).map_err(|e| at_shape(&e))?
            }
            ShapeSpec::Cluster { bubble } => {
                let bubbles: Vec<Bubble> = bubble
                    .iter()
                    .map(|b| Bubble {
                        name: b.name.clone(),
                        centre: Point::from(b.centre),
                        volume: b.volume,
                    })
                    .collect();
                cluster::cluster(&bubbles, resolution).map_err(|e| at_shape(&e))?
            }
            ShapeSpec::Cells { cell } => {
                let specs: Vec<CellSpec> = cell.iter().map(cell_spec).collect();
                generators::cells(&specs, resolution).map_err(|e| at_shape(&e))?
            }
            ShapeSpec::Obj {
                file,
                fix_boundary,
                volume,
            } => self.import(file, false, *fix_boundary, volume)?,
            ShapeSpec::Gltf {
                file,
                fix_boundary,
                volume,
            } => self.import(file, true, *fix_boundary, volume)?,
        };
        let n = shape.mesh.vertex_count();
        let mut chords = Vec::new();
        for (i, c) in self.file.chord.iter().enumerate() {
            if c.a >= n || c.b >= n || c.a == c.b {
                return Err(self.err(
                    &["chord".into(), i.into()],
                    format!("chord vertices must be two different indices below {n}"),
                ));
            }
            chords.push(Chord {
                a: c.a,
                b: c.b,
                length: c.length,
            });
        }
        self.pressures(&shape)?;
        Ok((shape, chords))
    }

    /// The prescribed pressure (1/m) of each of `shape`'s volumes, in their order (`None`: the
    /// volume is held at its target); a `[[pressure]]` naming no volume, or one named twice, is
    /// an error at its `body`.
    pub fn pressures(&self, shape: &Shape) -> Result<Vec<Option<f64>>, InputError> {
        let mut pressures = vec![None; shape.volumes.len()];
        for (i, p) in self.file.pressure.iter().enumerate() {
            let at = ["pressure".into(), i.into(), "body".into()];
            let Some(k) = shape.volumes.iter().position(|(name, ..)| *name == p.body) else {
                let names: Vec<&str> = shape.volumes.iter().map(|(n, ..)| n.as_str()).collect();
                return Err(self.err(
                    &at,
                    format!(
                        "no volume `{}` in this shape (volumes: {})",
                        p.body,
                        if names.is_empty() {
                            "none".to_string()
                        } else {
                            names.join(", ")
                        }
                    ),
                ));
            };
            if pressures[k].replace(p.value).is_some() {
                return Err(self.err(&at, format!("volume `{}` has two pressures", p.body)));
            }
        }
        Ok(pressures)
    }

    /// Reads an OBJ (`gltf` false) or glTF start mesh and resolves its volume regions.
    fn import(
        &self,
        file: &str,
        gltf: bool,
        fix_boundary: bool,
        volumes: &[VolumeToml],
    ) -> Result<Shape, InputError> {
        let dir = self.source.path.parent().unwrap_or(Path::new("."));
        let path = dir.join(file);
        let at_file = |m: String| self.err(&["shape".into(), "file".into()], m);
        let mut mesh = if gltf {
            if !path.is_file() {
                return Err(at_file(format!("cannot read `{}`", path.display())));
            }
            super::import_gltf::read_gltf_file(&path)
        } else {
            let text = std::fs::read_to_string(&path)
                .map_err(|e| at_file(format!("cannot read `{}`: {e}", path.display())))?;
            super::import::read_obj(&text)
        }
        .map_err(|e| at_file(format!("`{}`: {e}", path.display())))?;
        if fix_boundary {
            mesh.fix_boundary();
        }
        let mut regions = Vec::new();
        for (i, v) in volumes.iter().enumerate() {
            let mut boundary = Vec::new();
            for name in &v.surfaces {
                let (sign, bare) = match name.strip_prefix('-') {
                    Some(bare) => (-1.0, bare),
                    None => (1.0, name.as_str()),
                };
                let s = mesh.surface_index(bare).ok_or_else(|| {
                    self.err(
                        &shape_entry("volume", i, "surfaces"),
                        format!(
                            "no surface `{bare}` in the mesh; it has: {}",
                            mesh.surfaces().join(", ")
                        ),
                    )
                })?;
                boundary.push((s, sign));
            }
            let region = Region {
                boundary,
                reference: Point::from(v.reference),
            };
            let enclosed = region.volume(&mesh);
            if enclosed.is_nan() || enclosed <= 0.0 {
                return Err(self.err(
                    &shape_entry("volume", i, "surfaces"),
                    format!(
                        "the surfaces of volume `{}` enclose {enclosed:.3e} m³ as wound: their \
                         normals must point out of the region (reverse the faces, or prefix a \
                         surface whose normals point in with `-`)",
                        v.name
                    ),
                ));
            }
            regions.push((v.name.clone(), region, v.volume));
        }
        Ok(Shape {
            mesh,
            volumes: regions,
        })
    }
}

/// Most triangles of one tent's start mesh at resolution `r` (`generators::tents`): a grid of
/// r cells along the short side and round(r·a) along the long one (a the aspect ratio) for a
/// quadrilateral `boundary`, else a fan disk of at most six sectors with r rings (`sides·r²`
/// triangles); poles fix vertices of that mesh and add none. NaN for a zero-length side.
fn tent_faces(tent: &TentToml, r: f64) -> f64 {
    match tent.boundary.as_deref() {
        Some(corners) if corners.len() == 4 => 2.0 * r * (r * quad_aspect(corners) + 1.0),
        Some(corners) => corners.len().min(6) as f64 * r * r,
        None => 6.0 * r * r,
    }
}

/// The ratio of the longer to the shorter mean side of a quadrilateral (the generators grid it
/// with rows along the short side); 1 for other polygons.
fn quad_aspect(corners: &[[f64; 3]]) -> f64 {
    if corners.len() != 4 {
        return 1.0;
    }
    let len = |i: usize, j: usize| {
        let d: f64 = (0..3)
            .map(|k| (corners[i][k] - corners[j][k]).powi(2))
            .sum();
        d.sqrt()
    };
    let (u, v) = ((len(0, 1) + len(3, 2)) / 2.0, (len(1, 2) + len(0, 3)) / 2.0);
    (u.max(v) / u.min(v)).max(1.0)
}

/// Corners of a regular polygon, counter-clockwise seen from above, first corner at +x.
fn regular_polygon(r: &RimToml) -> Vec<[f64; 2]> {
    (0..r.sides)
        .map(|k| {
            let a = 2.0 * std::f64::consts::PI * k as f64 / r.sides as f64;
            // Counter-clockwise seen from +y: from +x towards −z.
            [
                r.centre[0] + r.radius * a.cos(),
                r.centre[1] - r.radius * a.sin(),
            ]
        })
        .collect()
}

fn tent_spec(t: &TentToml) -> TentSpec {
    let boundary = match (&t.boundary, &t.rim) {
        (Some(b), _) => b.iter().map(|&p| Point::from(p)).collect(),
        (None, Some(r)) => regular_polygon(r)
            .into_iter()
            .map(|[x, z]| Point::new(x, r.height, z))
            .collect(),
        (None, None) => Vec::new(),
    };
    let mut poles: Vec<Pole> = t
        .pole
        .iter()
        .map(|p| Pole {
            at: p.at,
            height: p.height,
            radius: p.cap,
        })
        .collect();
    for ring in &t.pole_ring {
        for k in 0..ring.count {
            let a =
                ring.phase.to_radians() + 2.0 * std::f64::consts::PI * k as f64 / ring.count as f64;
            poles.push(Pole {
                at: [
                    ring.centre[0] + ring.radius * a.cos(),
                    ring.centre[1] - ring.radius * a.sin(),
                ],
                height: ring.height,
                radius: ring.cap,
            });
        }
    }
    TentSpec {
        name: t.name.clone(),
        boundary,
        poles,
    }
}

fn cell_spec(c: &CellToml) -> CellSpec {
    let footprint = match (&c.footprint, &c.circle) {
        (Some(f), _) => f.clone(),
        (None, Some(r)) => regular_polygon(r),
        (None, None) => Vec::new(),
    };
    CellSpec {
        name: c.name.clone(),
        footprint,
        height: c.height,
        volume: c.volume,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The face estimate that bounds a start mesh before it is built is an upper bound of the
    /// real mesh for every shipped problem at resolutions 1 to 3.
    #[test]
    fn face_estimate_bounds_the_built_meshes() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("problems/cmc");
        let mut files: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect();
        files.sort();
        for file in files {
            let spec = parse(Source::read(&file).unwrap()).unwrap();
            for r in 1..=3 {
                let (shape, _) = spec.build(r).unwrap();
                let faces = shape.mesh.triangles().len() as f64;
                let estimate = spec.file.shape.face_estimate(r);
                if estimate > 0.0 {
                    assert!(
                        faces <= estimate,
                        "{}: r{r} {faces} > {estimate}",
                        file.display()
                    );
                }
            }
        }
    }

    #[test]
    fn a_tent_roof_is_sized_by_its_own_mesh() {
        // The convention center's eight tents (five with mast caps, one 100 m × 8 m quadrilateral
        // with five): 1,974 triangles at resolution 7; resolution 8 was refused as 5.6e5
        // faces by an estimate of 100·r² per tent and per pole.
        let file =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("problems/cmc/convention_center.toml");
        let spec = parse(Source::read(&file).unwrap()).unwrap();
        for r in [4, 8] {
            let (shape, _) = spec.build(r).unwrap();
            let faces = shape.mesh.triangles().len() as f64;
            let estimate = spec.file.shape.face_estimate(r);
            assert!(
                faces <= estimate && estimate <= 1.5 * faces,
                "r{r}: {faces} {estimate}"
            );
        }
    }

    /// The error `text` (a file's contents) is refused with.
    fn refusal(text: &str) -> InputError {
        parse(Source {
            path: "s.toml".into(),
            text: text.into(),
        })
        .unwrap_err()
    }

    #[test]
    fn a_zero_wire_width_is_named_not_sized() {
        let e = refusal("[shape]\ntype = \"u_wires\"\nwidth = 0.0\ndepth = 0.03\n");
        assert!(e.message.starts_with("`width` must be positive"), "{e}");
    }

    #[test]
    fn an_absurd_resolution_is_refused_before_building() {
        let e = refusal("resolution = 40\n[shape]\ntype = \"sphere\"\nvolume = 1.0\n");
        assert_eq!(e.position, Some((1, 1)));
        assert!(
            e.message
                .starts_with("`resolution` would generate 2.4e25 start-mesh faces; limit 5e5"),
            "{e}"
        );
    }
}
