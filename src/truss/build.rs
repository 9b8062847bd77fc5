//! From a validated problem file to a model: user joints (rows expanded, loads per case), the
//! generated ground structure, and the optimization settings.
//!
//! Load cases: without `[[load_case]]` there is one case, "main", with every load joint's own
//! `force + mass·g`. Each `[[load_case]]` gives `factor·(own loads) + (its listed loads)`.
//! Units: m, N, kg.

use std::collections::{BTreeSet, HashMap};

use super::ground::{self, Placement};
use super::mass::{MassModel, gravity};
use super::model::{
    Beam, Joint, JointKind, Mirror, Objective, Obstacle, Settings, Structure, Support, Vec3,
};
use super::spec::{
    Direction, GroundKind, JointKindSpec, LayerSource, MAX_JOINTS, MassKind, ObjectiveKind,
    ObstacleKind, Region, SupportKind, TrussSpec,
};
use crate::error::InputError;
use crate::spec::{Key, Source};

/// Default compression weight for `mass_tension_preference`.
pub const DEFAULT_COMPRESSION_PENALTY: f64 = 2.0;
/// Default steel density for the linear model, kg/m³.
pub const STEEL_DENSITY: f64 = 7850.0;

/// Most candidate beams (joints × `neighbours` + `extra`) a ground structure may have.
pub const MAX_BEAMS: usize = 200_000;
/// Largest distance, m, at which two joints count as one (smaller for structures under 1 km:
/// 1e-9 of their size), whatever the structure's size: a far-away joint must not make the
/// others coincide.
pub const COINCIDENCE_TOLERANCE: f64 = 1e-6;

/// The key whose value sizes the generated ground structure, named by the size-limit error.
fn ground_size_key(spec: &TrussSpec) -> Vec<Key<'static>> {
    use Key::Name as N;
    let g = &spec.ground;
    let key = match g.kind {
        GroundKind::Layers => "layers",
        GroundKind::Random => "count",
        GroundKind::Lattice if g.margin.is_some() && g.min.is_none() => "margin",
        GroundKind::Lattice | GroundKind::None => "spacing",
    };
    vec![N("ground"), N(key)]
}

/// The ground structure and settings built from a problem file.
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    /// Joints and beams.
    pub structure: Structure,
    /// Problem settings.
    pub settings: Settings,
    /// Number of user joints (they come first in `structure.joints`).
    pub user_joints: usize,
    /// With `[connect] full`: every admissible pair is a potential beam (the layout LP prices
    /// them); `structure.beams` is then the first member set.
    pub full: Option<ground::FullConnectivity>,
}

/// Builds the model; `seed` drives random ground structures.
pub fn build(spec: &TrussSpec, src: &Source, seed: u64) -> Result<Model, InputError> {
    use Key::{Index as I, Name as N};
    let cases = case_names(spec);
    let mut joints = user_joints(spec, cases.len());
    let scale = bounding_diagonal(&joints).max(spec.min_length);
    let tol = (1e-9 * scale).min(COINCIDENCE_TOLERANCE);
    check_distinct(spec, src, &joints, tol)?;
    let names = name_index(&joints);
    apply_load_cases(spec, src, &mut joints, &names)?;

    let largest_load = joints
        .iter()
        .flat_map(|j| j.loads.iter())
        .map(|f| f.norm())
        .fold(0.0, f64::max);
    if largest_load == 0.0 {
        return Err(src.error_at(&[N("joint")], "every load is zero"));
    }

    let obstacles = obstacles(spec);
    for (k, o) in obstacles.iter().enumerate() {
        if let Some((i, _)) = joints
            .iter()
            .enumerate()
            .find(|(_, j)| o.clearance(&j.position) < -tol)
        {
            return Err(src.error_at(
                &[N("obstacle"), I(k)],
                format!(
                    "the user joint at {:?} lies inside this obstacle",
                    joints[i].position.as_slice()
                ),
            ));
        }
    }

    let user = joints.len();
    let placement = placement(spec, &joints, seed);
    src.within_limit(
        &ground_size_key(spec),
        user as f64 + ground::candidate_count(&placement),
        MAX_JOINTS as f64,
        "joints (the user's and the ground structure's)",
    )?;
    let points = ground::candidate_points(&placement, &joints);
    ground::add_free_joints(&mut joints, &points, &obstacles, cases.len(), tol);

    let pair = |p: &[String; 2], key: &'static str, i: usize| -> Result<Beam, InputError> {
        let at = |k: usize| [N("connect"), N(key), I(i), I(k)];
        let a = *names
            .get(&p[0])
            .ok_or_else(|| src.error_at(&at(0), format!("no joint named `{}`", p[0])))?;
        let b = *names
            .get(&p[1])
            .ok_or_else(|| src.error_at(&at(1), format!("no joint named `{}`", p[1])))?;
        if a == b {
            return Err(src.error_at(&at(1), "a beam needs two different joints"));
        }
        Ok(Beam::new(a, b))
    };
    let extra = (spec.connect.extra.iter().enumerate())
        .map(|(i, p)| pair(p, "extra", i))
        .collect::<Result<Vec<_>, _>>()?;
    let forbidden = (spec.connect.forbidden.iter().enumerate())
        .map(|(i, p)| pair(p, "forbidden", i))
        .collect::<Result<BTreeSet<_>, _>>()?;
    src.within_limit(
        &[N("connect"), N("neighbours")],
        (joints.len() * spec.connect.neighbours + extra.len()) as f64,
        MAX_BEAMS as f64,
        "candidate beams",
    )?;
    let beams = ground::connect(
        &joints,
        spec.connect.neighbours,
        &forbidden,
        &extra,
        &obstacles,
        tol,
    );
    let settings = settings(spec, largest_load, obstacles, cases);
    let beams = ground::mirror_closure(
        &joints,
        beams,
        &settings.symmetry,
        &forbidden,
        &settings.obstacles,
        tol,
    );
    let structure = Structure { joints, beams };
    let full = spec
        .connect
        .full
        .then_some(ground::FullConnectivity { forbidden, tol });
    Ok(Model {
        structure,
        settings,
        user_joints: user,
        full,
    })
}

fn case_names(spec: &TrussSpec) -> Vec<String> {
    if spec.load_cases.is_empty() {
        vec!["main".to_string()]
    } else {
        spec.load_cases.iter().map(|c| c.name.clone()).collect()
    }
}

fn own_load(force: Option<[f64; 3]>, mass: Option<f64>) -> Vec3 {
    force.map_or(Vec3::zeros(), Vec3::from) + mass.unwrap_or(0.0) * gravity()
}

fn user_joints(spec: &TrussSpec, cases: usize) -> Vec<Joint> {
    let mut joints = Vec::new();
    for j in &spec.joints {
        let kind = match j.kind {
            JointKindSpec::Anchor => JointKind::Anchor(match j.support {
                Some(SupportKind::Roller) => Support::Roller(
                    (j.reactions.iter().flatten())
                        .map(|d| Vec3::from(*d).normalize())
                        .collect(),
                ),
                _ => Support::Pinned,
            }),
            JointKindSpec::Load => JointKind::Load,
            JointKindSpec::Free => JointKind::Free,
        };
        let own = own_load(j.force, j.mass);
        let from = Vec3::from(j.at);
        let (to, count) = match (j.to, j.count) {
            (Some(t), Some(n)) => (Vec3::from(t), n),
            _ => (from, 1),
        };
        for k in 0..count {
            let t = if count > 1 {
                k as f64 / (count - 1) as f64
            } else {
                0.0
            };
            let name = j.name.as_ref().map(|n| {
                if count > 1 {
                    format!("{n}.{}", k + 1)
                } else {
                    n.clone()
                }
            });
            joints.push(Joint {
                position: from + t * (to - from),
                kind: kind.clone(),
                name,
                loads: vec![own; cases],
            });
        }
    }
    joints
}

/// Which spec entry produced user joint `index` (rows expand to several joints).
fn spec_entry(spec: &TrussSpec, index: usize) -> usize {
    let mut seen = 0;
    for (i, j) in spec.joints.iter().enumerate() {
        seen += j.count.unwrap_or(1);
        if index < seen {
            return i;
        }
    }
    spec.joints.len().saturating_sub(1)
}

fn check_distinct(
    spec: &TrussSpec,
    src: &Source,
    joints: &[Joint],
    tol: f64,
) -> Result<(), InputError> {
    use Key::{Index as I, Name as N};
    let mut seen: HashMap<&str, usize> = HashMap::new();
    for (i, j) in joints.iter().enumerate() {
        if let Some(name) = &j.name
            && seen.insert(name, i).is_some()
        {
            return Err(src.error_at(
                &[N("joint"), I(spec_entry(spec, i)), N("name")],
                format!("joint name `{name}` is used twice"),
            ));
        }
        if let Some(k) = (0..i).find(|&k| (joints[k].position - j.position).norm() <= tol) {
            return Err(src.error_at(
                &[N("joint"), I(spec_entry(spec, i)), N("at")],
                format!(
                    "two joints at the same position {:?} (joint entries {} and {} are within \
                     {tol:.1e} m)",
                    j.position.as_slice(),
                    spec_entry(spec, k) + 1,
                    spec_entry(spec, i) + 1
                ),
            ));
        }
    }
    Ok(())
}

fn name_index(joints: &[Joint]) -> HashMap<String, usize> {
    (joints.iter().enumerate())
        .filter_map(|(i, j)| j.name.clone().map(|n| (n, i)))
        .collect()
}

fn apply_load_cases(
    spec: &TrussSpec,
    src: &Source,
    joints: &mut [Joint],
    names: &HashMap<String, usize>,
) -> Result<(), InputError> {
    use Key::{Index as I, Name as N};
    for (c, case) in spec.load_cases.iter().enumerate() {
        for j in joints.iter_mut() {
            j.loads[c] *= case.factor;
        }
        for (k, load) in case.loads.iter().enumerate() {
            let at = [N("load_case"), I(c), N("loads"), I(k), N("joint")];
            let &i = names
                .get(&load.joint)
                .ok_or_else(|| src.error_at(&at, format!("no joint named `{}`", load.joint)))?;
            if joints[i].kind != JointKind::Load {
                return Err(src.error_at(&at, format!("`{}` is not a load joint", load.joint)));
            }
            joints[i].loads[c] += own_load(load.force, load.mass);
        }
    }
    Ok(())
}

fn obstacles(spec: &TrussSpec) -> Vec<Obstacle> {
    // Presence of the keys was checked in validation.
    (spec.obstacles.iter())
        .map(|o| match o.kind {
            ObstacleKind::HalfSpace => Obstacle::HalfSpace {
                point: Vec3::from(o.point.unwrap_or_default()),
                normal: Vec3::from(o.normal.unwrap_or([0.0, 1.0, 0.0])).normalize(),
            },
            ObstacleKind::Sphere => Obstacle::Sphere {
                center: Vec3::from(o.center.unwrap_or_default()),
                radius: o.radius.unwrap_or(1.0),
            },
        })
        .collect()
}

fn bounding_box(joints: &[Joint]) -> (Vec3, Vec3) {
    let mut lo = Vec3::repeat(f64::INFINITY);
    let mut hi = Vec3::repeat(f64::NEG_INFINITY);
    for j in joints {
        lo = lo.inf(&j.position);
        hi = hi.sup(&j.position);
    }
    (lo, hi)
}

/// Diagonal of the user joints' bounding box, m.
fn bounding_diagonal(joints: &[Joint]) -> f64 {
    let (lo, hi) = bounding_box(joints);
    (hi - lo).norm()
}

fn placement(spec: &TrussSpec, joints: &[Joint], seed: u64) -> Placement {
    let g = &spec.ground;
    let (mut lo, mut hi) = match (g.min, g.max) {
        (Some(a), Some(b)) => (Vec3::from(a), Vec3::from(b)),
        _ => {
            let (lo, hi) = bounding_box(joints);
            let m = Vec3::repeat(g.margin.unwrap_or(0.0));
            (lo - m, hi + m)
        }
    };
    if spec.planar {
        lo.z = joints[0].position.z;
        hi.z = lo.z;
    }
    match g.kind {
        GroundKind::Layers => {
            let which = g.from.unwrap_or(LayerSource::Loads);
            let sources = (joints.iter().enumerate())
                .filter(|(_, j)| match which {
                    LayerSource::Loads => j.kind == JointKind::Load,
                    LayerSource::Anchors => j.is_anchor(),
                    LayerSource::All => !j.is_free(),
                })
                .map(|(i, _)| i)
                .collect();
            let h = g.spacing.map_or(1.0, |s| s.steps()[1]);
            let step = match g.direction {
                Some(Direction::Below) => -h,
                _ => h,
            };
            Placement::Layers {
                sources,
                step,
                layers: g.layers.unwrap_or(1),
            }
        }
        GroundKind::Lattice => Placement::Lattice {
            lo,
            hi,
            steps: g.spacing.map_or([1.0; 3], |s| s.steps()),
        },
        GroundKind::Random => match g.region {
            Some(Region::Sphere) => {
                let mut center = Vec3::from(g.center.unwrap_or_default());
                if spec.planar {
                    center.z = lo.z;
                }
                Placement::RandomBall {
                    center,
                    radius: g.radius.unwrap_or(1.0),
                    count: g.count.unwrap_or(0),
                    planar: spec.planar,
                    seed,
                }
            }
            _ => Placement::RandomBox {
                lo,
                hi,
                count: g.count.unwrap_or(0),
                seed,
            },
        },
        GroundKind::None => Placement::None,
    }
}

fn settings(
    spec: &TrussSpec,
    largest_load: f64,
    obstacles: Vec<Obstacle>,
    load_cases: Vec<String>,
) -> Settings {
    let m = &spec.mass;
    let blend = m.blend_force.unwrap_or(0.05 * largest_load);
    let mass = match m.model {
        MassKind::Seed => MassModel {
            k_t: m.k_t.unwrap_or(5e-6),
            compression: super::mass::Compression::Euler {
                k_c: m.k_c.unwrap_or(5e-3),
            },
            blend,
            compression_weight: 1.0,
        },
        MassKind::Linear => MassModel::linear(
            m.sigma_t.unwrap_or(1.0),
            m.sigma_c.unwrap_or(1.0),
            m.density.unwrap_or(STEEL_DENSITY),
        ),
    };
    let objective = match spec.objective {
        ObjectiveKind::Mass => Objective::Mass,
        ObjectiveKind::Length => Objective::Length,
        ObjectiveKind::MassTensionPreference => Objective::MassTensionPreference(
            spec.compression_penalty
                .unwrap_or(DEFAULT_COMPRESSION_PENALTY),
        ),
    };
    Settings {
        mass,
        objective,
        self_weight: spec.self_weight,
        max_force: spec.max_force,
        min_length: spec.min_length,
        max_length: spec.max_length,
        planar: spec.planar,
        held_axis: spec.hold_in_planes.map(|a| a.index()),
        move_joints: spec.move_joints,
        symmetry: (spec.symmetry.iter())
            .map(|s| Mirror {
                point: Vec3::from(s.point),
                normal: Vec3::from(s.normal).normalize(),
            })
            .collect(),
        obstacles,
        load_cases,
    }
}
