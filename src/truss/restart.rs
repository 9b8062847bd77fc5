//! Starting a truss run from a previous result (`--start out/<name>/result.json`).
//!
//! A run writes its final design under `figures.design` of `result.json` ([`design_json`]):
//! every joint's position (m) and user name, the beams as joint-index pairs, and each load
//! case's beam forces λ (N, positive in compression). [`nlp_from`] rebuilds the NLP on that
//! structure with those forces as the start: a joint with a user name, or at the position of
//! one of the problem's supports or loads, takes that joint's kind and loads from the problem
//! file; every other joint is free. The result must hold every support and load of the problem
//! and as many load cases, or it is not a result of this problem (a one-line error).

use serde::Deserialize;
use serde_json::{Value, json};

use super::build::Model;
use super::design::Design;
use super::model::{Joint, JointKind, Structure, Vec3};
use super::nlp::TrussNlp;
use crate::error::InputError;
use crate::outcome::Previous;

/// The design as written under `figures.design`.
pub fn design_json(design: &Design) -> Value {
    let joints: Vec<Value> = design
        .structure
        .joints
        .iter()
        .map(|j| json!({ "position": [j.position.x, j.position.y, j.position.z], "name": j.name }))
        .collect();
    let beams: Vec<[usize; 2]> = design.structure.beams.iter().map(|b| b.ends).collect();
    json!({ "joints": joints, "beams": beams, "forces_n": design.forces })
}

#[derive(Deserialize)]
struct Saved {
    joints: Vec<SavedJoint>,
    beams: Vec<[usize; 2]>,
    forces_n: Vec<Vec<f64>>,
}

#[derive(Deserialize)]
struct SavedJoint {
    position: [f64; 3],
    name: Option<String>,
}

/// The NLP of `model`'s problem on the previous result's structure, starting at its geometry
/// and forces.
pub fn nlp_from(previous: &Previous, model: &Model) -> Result<TrussNlp, InputError> {
    let saved: Saved = serde_json::from_value(previous.figure("design")?.clone())
        .map_err(|e| previous.mismatch(format!("figures.design: {e}")))?;
    let cases = model.settings.load_cases.len();
    let beams = saved.beams.len();
    if saved.forces_n.len() != cases || saved.forces_n.iter().any(|f| f.len() != beams) {
        return Err(previous.mismatch(format!(
            "has {} load case(s) of {beams} beams; this problem has {cases} load case(s)",
            saved.forces_n.len()
        )));
    }
    if let Some(b) = saved
        .beams
        .iter()
        .find(|[a, b]| a == b || *a.max(b) >= saved.joints.len())
    {
        return Err(previous.mismatch(format!("beam {b:?} does not join two of its joints")));
    }
    let fixed: Vec<&Joint> = model
        .structure
        .joints
        .iter()
        .filter(|j| !j.is_free())
        .collect();
    let same_place = |a: &Vec3, b: &Vec3| (a - b).norm() <= 1e-9 * (1.0 + a.norm());
    let mut joints = Vec::with_capacity(saved.joints.len());
    for s in &saved.joints {
        let position = Vec3::from(s.position);
        let problem_joint = model
            .structure
            .joints
            .iter()
            .find(|j| s.name.is_some() && j.name == s.name)
            .or_else(|| {
                fixed
                    .iter()
                    .copied()
                    .find(|j| same_place(&j.position, &position))
            });
        joints.push(match problem_joint {
            Some(j) => Joint {
                position,
                ..j.clone()
            },
            None => Joint {
                position,
                kind: JointKind::Free,
                name: None,
                loads: vec![Vec3::zeros(); cases],
            },
        });
    }
    if let Some(missing) = fixed.iter().find(|f| {
        !joints
            .iter()
            .any(|j| j.kind == f.kind && same_place(&j.position, &f.position))
    }) {
        let p = missing.position;
        return Err(previous.mismatch(format!(
            "has no joint at ({}, {}, {}) m, a support or load of this problem",
            p.x, p.y, p.z
        )));
    }
    let structure = Structure {
        joints,
        beams: saved
            .beams
            .iter()
            .map(|&[a, b]| super::model::Beam::new(a, b))
            .collect(),
    };
    TrussNlp::new(structure, model.settings.clone(), saved.forces_n.concat())
        .map_err(|e| previous.mismatch(format!("cannot start from its design: {e}")))
}
