//! Ground-structure generation (seed §4.2.1): free joints around the user's anchors and loads,
//! then beams from every joint to its k nearest neighbours.
//!
//! Free joints (positions in metres):
//! - layers: each source joint (loads, anchors or both) copied `k·h` above or below, k = 1..N
//!   (the seed's "one free joint above each load" for N = 1);
//! - lattice: a regular grid `lo + (i·hx, j·hy, k·hz)` filling a box;
//! - random: uniform in a box or a ball, drawn from a seeded ChaCha8 generator.
//!
//! A generated point is skipped when it lies within `1e-9·scale` of an existing joint or inside
//! an obstacle (clearance < 0).
//!
//! Connection rule (deterministic): for every joint, the admissible candidates are sorted by
//! (distance, index) and the first k are joined; the beam set is the union over all joints,
//! sorted, without duplicates. A pair is admissible when
//! - it is not two anchors (such a beam carries nothing the earth does not),
//! - it is not a forbidden pair,
//! - no other joint lies on the segment between them (collinear overlaps are left to the
//!   shorter beams),
//! - if both ends are fixed, the segment does not enter an obstacle (no variable could fix it).
//!
//! Crossing beams (such as the two diagonals of a square) are allowed in the ground structure:
//! beams are not joined where they cross. The topology rounds join crossing beams of a solved
//! design by a joint (`rounds.split_crossings`) or remove the weaker
//! (`rounds.remove_crossings`). User-listed extra beams are added as given.
//!
//! With symmetry planes the beam set is closed under the mirrors ([`mirror_closure`]): the
//! tie-breaking by index is not mirror symmetric.

use std::collections::BTreeSet;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::geometry::segment_point_distance;
use super::model::{Beam, Joint, JointKind, Mirror, Obstacle, Settings, Vec3};

/// How free joints are placed.
#[derive(Debug, Clone, PartialEq)]
pub enum Placement {
    /// Offset copies of `sources` (joint indices) by `k·step` along `up`, k = 1..=layers.
    Layers {
        /// Indices of the joints copied.
        sources: Vec<usize>,
        /// Vertical step, m (negative for "below").
        step: f64,
        /// Number of layers.
        layers: usize,
    },
    /// A grid over the box `lo..hi` with per-axis steps, m.
    Lattice {
        /// Lower corner.
        lo: Vec3,
        /// Upper corner.
        hi: Vec3,
        /// Steps.
        steps: [f64; 3],
    },
    /// `count` points uniform in the box `lo..hi`.
    RandomBox {
        /// Lower corner.
        lo: Vec3,
        /// Upper corner.
        hi: Vec3,
        /// Number of points.
        count: usize,
        /// Seed.
        seed: u64,
    },
    /// `count` points uniform in a ball (a disk in the plane z = centre.z when `planar`).
    RandomBall {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f64,
        /// Number of points.
        count: usize,
        /// Sample in the plane z = centre.z.
        planar: bool,
        /// Seed.
        seed: u64,
    },
    /// No generated joints.
    None,
}

/// How many candidate points `placement` asks for, counted in floating point so that absurd
/// sizes cannot overflow: the caller bounds it before [`candidate_points`] allocates them.
pub fn candidate_count(placement: &Placement) -> f64 {
    match placement {
        Placement::Layers {
            sources, layers, ..
        } => sources.len() as f64 * *layers as f64,
        Placement::Lattice { lo, hi, steps } => lattice_counts(lo, hi, steps).iter().product(),
        Placement::RandomBox { count, .. } | Placement::RandomBall { count, .. } => *count as f64,
        Placement::None => 0.0,
    }
}

/// Lattice points per axis over `lo..hi` with `steps`, m.
fn lattice_counts(lo: &Vec3, hi: &Vec3, steps: &[f64; 3]) -> [f64; 3] {
    std::array::from_fn(|k| ((hi[k] - lo[k]) / steps[k] + 1e-9).floor() + 1.0)
}

/// Candidate free-joint positions for `placement` (before skipping near-duplicates and obstacles);
/// its size, [`candidate_count`], must have been bounded.
pub fn candidate_points(placement: &Placement, joints: &[Joint]) -> Vec<Vec3> {
    match placement {
        Placement::Layers {
            sources,
            step,
            layers,
        } => (1..=*layers)
            .flat_map(|k| {
                sources
                    .iter()
                    .map(move |&i| joints[i].position + Vec3::new(0.0, step * k as f64, 0.0))
            })
            .collect(),
        Placement::Lattice { lo, hi, steps } => {
            let n = lattice_counts(lo, hi, steps).map(|c| c as usize);
            let mut points = Vec::with_capacity(n[0] * n[1] * n[2]);
            for i in 0..n[0] {
                for j in 0..n[1] {
                    for k in 0..n[2] {
                        points.push(Vec3::new(
                            lo[0] + i as f64 * steps[0],
                            lo[1] + j as f64 * steps[1],
                            lo[2] + k as f64 * steps[2],
                        ));
                    }
                }
            }
            points
        }
        Placement::RandomBox {
            lo,
            hi,
            count,
            seed,
        } => {
            let mut rng = ChaCha8Rng::seed_from_u64(*seed);
            (0..*count)
                .map(|_| {
                    let u = Vec3::new(rng.random(), rng.random(), rng.random());
                    lo + (hi - lo).component_mul(&u)
                })
                .collect()
        }
        Placement::RandomBall {
            center,
            radius,
            count,
            planar,
            seed,
        } => {
            let mut rng = ChaCha8Rng::seed_from_u64(*seed);
            let mut points = Vec::with_capacity(*count);
            while points.len() < *count {
                let mut u = Vec3::new(
                    2.0 * rng.random::<f64>() - 1.0,
                    2.0 * rng.random::<f64>() - 1.0,
                    2.0 * rng.random::<f64>() - 1.0,
                );
                if *planar {
                    u.z = 0.0;
                }
                if u.norm_squared() <= 1.0 {
                    points.push(center + *radius * u);
                }
            }
            points
        }
        Placement::None => Vec::new(),
    }
}

/// Appends free joints at `points`, skipping near-duplicates (within `tol`, m) of joints already
/// present and points inside an obstacle. Returns how many were added.
pub fn add_free_joints(
    joints: &mut Vec<Joint>,
    points: &[Vec3],
    obstacles: &[Obstacle],
    cases: usize,
    tol: f64,
) -> usize {
    let before = joints.len();
    for p in points {
        let taken = joints.iter().any(|j| (j.position - p).norm() <= tol);
        let blocked = obstacles.iter().any(|o| o.clearance(p) < 0.0);
        if !taken && !blocked {
            joints.push(Joint {
                position: *p,
                kind: JointKind::Free,
                name: None,
                loads: vec![Vec3::zeros(); cases],
            });
        }
    }
    joints.len() - before
}

/// Beams of the ground structure by the rule in the module header. `forbidden` and `extra` are
/// joint-index pairs; `tol` (m) decides when a joint lies on a segment.
pub fn connect(
    joints: &[Joint],
    neighbours: usize,
    forbidden: &BTreeSet<Beam>,
    extra: &[Beam],
    obstacles: &[Obstacle],
    tol: f64,
) -> Vec<Beam> {
    let n = joints.len();
    let mut beams: BTreeSet<Beam> = BTreeSet::new();
    for i in 0..n {
        let mut candidates: Vec<(f64, usize)> = (0..n)
            .filter(|&j| j != i)
            .map(|j| ((joints[j].position - joints[i].position).norm(), j))
            .collect();
        candidates.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut taken = 0;
        for &(_, j) in &candidates {
            if taken == neighbours {
                break;
            }
            let beam = Beam::new(i, j);
            if beams.contains(&beam) {
                taken += 1;
                continue;
            }
            if admissible(joints, beam, forbidden, obstacles, tol) {
                beams.insert(beam);
                taken += 1;
            }
        }
    }
    beams.extend(extra.iter().copied());
    beams.into_iter().collect()
}

/// Adds the mirror image of every beam under every plane, repeatedly, where both image joints
/// exist (within `tol`, m) and the image pair is admissible. The k-nearest rule breaks distance
/// ties by joint index, which no mirror respects: on a lattice it picks one of two mirror-image
/// diagonals, so the ground structure, its layout LP and the pruned start would not be mirror
/// symmetric while the symmetry rows force the geometry to be.
pub fn mirror_closure(
    joints: &[Joint],
    beams: Vec<Beam>,
    mirrors: &[Mirror],
    forbidden: &BTreeSet<Beam>,
    obstacles: &[Obstacle],
    tol: f64,
) -> Vec<Beam> {
    let images: Vec<Vec<Option<usize>>> = (mirrors.iter())
        .map(|m| {
            (joints.iter())
                .map(|j| {
                    let p = m.reflect(&j.position);
                    joints.iter().position(|k| (k.position - p).norm() <= tol)
                })
                .collect()
        })
        .collect();
    let mut set: BTreeSet<Beam> = beams.into_iter().collect();
    let mut added = true;
    while added {
        added = false;
        for image in &images {
            let new: Vec<Beam> = (set.iter())
                .filter_map(|b| Some(Beam::new(image[b.ends[0]]?, image[b.ends[1]]?)))
                .filter(|b| !set.contains(b) && admissible(joints, *b, forbidden, obstacles, tol))
                .collect();
            added |= !new.is_empty();
            set.extend(new);
        }
    }
    set.into_iter().collect()
}

fn admissible(
    joints: &[Joint],
    beam: Beam,
    forbidden: &BTreeSet<Beam>,
    obstacles: &[Obstacle],
    tol: f64,
) -> bool {
    let [a, b] = beam.ends;
    let (pa, pb) = (joints[a].position, joints[b].position);
    let through_joint = joints
        .iter()
        .enumerate()
        .any(|(k, j)| k != a && k != b && segment_point_distance(&pa, &pb, &j.position).0 <= tol);
    !through_joint && admissible_ends(joints, beam, forbidden, obstacles)
}

/// The rules of [`admissible`] besides "no joint on the segment": not two anchors, not a
/// forbidden pair, and a beam between two fixed joints clear of every obstacle.
fn admissible_ends(
    joints: &[Joint],
    beam: Beam,
    forbidden: &BTreeSet<Beam>,
    obstacles: &[Obstacle],
) -> bool {
    let [a, b] = beam.ends;
    let (ja, jb) = (&joints[a], &joints[b]);
    if ja.is_anchor() && jb.is_anchor() || forbidden.contains(&beam) {
        return false;
    }
    let (pa, pb) = (ja.position, jb.position);
    if !ja.is_free() && !jb.is_free() {
        return obstacles.iter().all(|o| match o {
            Obstacle::HalfSpace { .. } => o.clearance(&pa) >= 0.0 && o.clearance(&pb) >= 0.0,
            Obstacle::Sphere { center, radius } => {
                segment_point_distance(&pa, &pb, center).0 >= *radius * (1.0 - 1e-12)
            }
        });
    }
    true
}

/// The full ground structure (`[connect] full`): every admissible pair of joints is a potential
/// beam. It is never built; the layout LP prices it ([`super::member_adding`]).
#[derive(Debug, Clone, PartialEq)]
pub struct FullConnectivity {
    /// Pairs never joined.
    pub forbidden: BTreeSet<Beam>,
    /// Distance, m, within which a joint lies on a segment.
    pub tol: f64,
}

impl FullConnectivity {
    /// Whether `beam` passes the admissibility rules other than "no joint on the segment"
    /// (which member adding tests by direction).
    pub fn admits_ends(&self, joints: &[Joint], beam: Beam, obstacles: &[Obstacle]) -> bool {
        admissible_ends(joints, beam, &self.forbidden, obstacles)
    }

    /// `beams` closed under the problem's mirror planes ([`mirror_closure`]), sorted.
    pub fn close(&self, joints: &[Joint], beams: Vec<Beam>, settings: &Settings) -> Vec<Beam> {
        mirror_closure(
            joints,
            beams,
            &settings.symmetry,
            &self.forbidden,
            &settings.obstacles,
            self.tol,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::truss::model::Support;

    fn joint(p: [f64; 3], kind: JointKind) -> Joint {
        Joint {
            position: Vec3::new(p[0], p[1], p[2]),
            kind,
            name: None,
            loads: vec![Vec3::zeros()],
        }
    }

    fn bridge() -> Vec<Joint> {
        let mut joints = vec![
            joint([0.0, 0.0, 0.0], JointKind::Anchor(Support::Pinned)),
            joint([40.0, 0.0, 0.0], JointKind::Anchor(Support::Pinned)),
        ];
        for i in 1..8 {
            joints.push(joint([5.0 * i as f64, 0.0, 0.0], JointKind::Load));
        }
        joints
    }

    #[test]
    fn layers_copy_the_loads_and_skip_duplicates() {
        let mut joints = bridge();
        let placement = Placement::Layers {
            sources: (2..9).collect(),
            step: 5.0,
            layers: 2,
        };
        let points = candidate_points(&placement, &joints);
        assert_eq!(points.len(), 14);
        let mut doubled = points.clone();
        doubled.extend(points.iter().copied());
        let added = add_free_joints(&mut joints, &doubled, &[], 1, 1e-9);
        assert_eq!(added, 14);
        assert!((joints[9].position - Vec3::new(5.0, 5.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn obstacles_remove_generated_points() {
        let mut joints = bridge();
        let placement = Placement::Lattice {
            lo: Vec3::new(0.0, -10.0, 0.0),
            hi: Vec3::new(40.0, 10.0, 0.0),
            steps: [5.0, 5.0, 1.0],
        };
        let points = candidate_points(&placement, &joints);
        assert_eq!(points.len(), 9 * 5);
        let below = Obstacle::HalfSpace {
            point: Vec3::zeros(),
            normal: Vec3::new(0.0, -1.0, 0.0),
        };
        let added = add_free_joints(&mut joints, &points, &[below], 1, 1e-9);
        // Rows y = -10, -5 are kept; the row y = 0 coincides with the deck joints.
        assert_eq!(added, 18);
        assert!(joints[9..].iter().all(|j| j.position.y < 0.0));
    }

    #[test]
    fn connection_is_deterministic_without_duplicates_or_overlaps() {
        let mut joints = bridge();
        let points = candidate_points(
            &Placement::RandomBox {
                lo: Vec3::new(0.0, 1.0, 0.0),
                hi: Vec3::new(40.0, 9.0, 0.0),
                count: 30,
                seed: 7,
            },
            &joints,
        );
        let again = candidate_points(
            &Placement::RandomBox {
                lo: Vec3::new(0.0, 1.0, 0.0),
                hi: Vec3::new(40.0, 9.0, 0.0),
                count: 30,
                seed: 7,
            },
            &joints,
        );
        assert_eq!(points, again);
        add_free_joints(&mut joints, &points, &[], 1, 1e-9);
        let beams = connect(&joints, 8, &BTreeSet::new(), &[], &[], 1e-9);
        assert_eq!(beams, connect(&joints, 8, &BTreeSet::new(), &[], &[], 1e-9));
        let unique: BTreeSet<Beam> = beams.iter().copied().collect();
        assert_eq!(unique.len(), beams.len());
        for b in &beams {
            assert!(b.ends[0] < b.ends[1]);
            assert!(!(joints[b.ends[0]].is_anchor() && joints[b.ends[1]].is_anchor()));
        }
        // The deck is collinear: no beam may skip over a deck joint.
        assert!(!beams.contains(&Beam::new(2, 4)));
        assert!(beams.contains(&Beam::new(2, 3)));
        // Every joint got at least min(k, admissible) neighbours, so at least 2 here.
        for i in 0..joints.len() {
            let degree = beams.iter().filter(|b| b.ends.contains(&i)).count();
            assert!(degree >= 2, "joint {i} has degree {degree}");
        }
        let different = candidate_points(
            &Placement::RandomBox {
                lo: Vec3::new(0.0, 1.0, 0.0),
                hi: Vec3::new(40.0, 9.0, 0.0),
                count: 30,
                seed: 8,
            },
            &joints,
        );
        assert_ne!(points, different);
    }

    #[test]
    fn forbidden_pairs_and_blocked_fixed_beams_are_skipped() {
        let joints = vec![
            joint([-2.0, 0.0, 0.0], JointKind::Anchor(Support::Pinned)),
            joint([2.0, 0.0, 0.0], JointKind::Load),
            joint([0.0, 3.0, 0.0], JointKind::Free),
        ];
        let sphere = Obstacle::Sphere {
            center: Vec3::zeros(),
            radius: 1.0,
        };
        let beams = connect(&joints, 8, &BTreeSet::new(), &[], &[sphere], 1e-9);
        assert_eq!(beams, vec![Beam::new(0, 2), Beam::new(1, 2)]);
        let forbidden: BTreeSet<Beam> = [Beam::new(2, 1)].into_iter().collect();
        let beams = connect(&joints, 8, &forbidden, &[Beam::new(0, 1)], &[], 1e-9);
        assert_eq!(beams, vec![Beam::new(0, 1), Beam::new(0, 2)]);
    }

    #[test]
    fn random_ball_points_lie_inside() {
        let placement = Placement::RandomBall {
            center: Vec3::new(1.0, 2.0, 3.0),
            radius: 2.0,
            count: 200,
            planar: true,
            seed: 3,
        };
        let points = candidate_points(&placement, &[]);
        assert_eq!(points.len(), 200);
        for p in &points {
            assert!((p - Vec3::new(1.0, 2.0, 3.0)).norm() <= 2.0);
            assert_eq!(p.z, 3.0);
        }
    }
}
