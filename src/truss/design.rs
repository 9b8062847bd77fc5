//! A truss design in physical units, read back from an NLP point: joint positions (m), beam forces
//! per load case (N, + compression), lengths (m), beam masses (kg, worst case), and the figures
//! reported in `result.json`.
//!
//! The force-balance residual is recomputed here from the design alone (eq. 4.1 with the lumped
//! self-weight of the reported beam masses), independently of the NLP's constraint code.

use serde::Serialize;

use super::mass::gravity;
use super::model::{JointKind, Settings, Structure, Support, Vec3};
use super::nlp::TrussNlp;

/// A design: the structure at its final geometry with beam forces and masses.
#[derive(Debug, Clone, PartialEq)]
pub struct Design {
    /// Joints at their final positions, beams.
    pub structure: Structure,
    /// λ per case and beam, N.
    pub forces: Vec<Vec<f64>>,
    /// Beam lengths, m.
    pub lengths: Vec<f64>,
    /// Beam masses, kg (worst case over load cases).
    pub masses: Vec<f64>,
    /// Load-case names.
    pub cases: Vec<String>,
    /// λ_max, N.
    pub max_force: f64,
}

/// The figures of a design reported in `result.json`.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct DesignFigures {
    /// Total beam mass, kg.
    pub mass_kg: f64,
    /// Total beam length, m.
    pub length_m: f64,
    /// Number of joints.
    pub joints: usize,
    /// Number of beams.
    pub beams: usize,
    /// Beams carrying more than 1e-3 of the largest |λ|.
    pub active_beams: usize,
    /// Largest force-balance residual over joints and cases, N.
    pub max_balance_residual_n: f64,
    /// The same relative to the largest external load.
    pub max_balance_residual_relative: f64,
    /// Largest |λ| / λ_max.
    pub max_force_ratio: f64,
}

impl Design {
    /// Reads a design from the NLP point `x`.
    pub fn from_point(nlp: &TrussNlp, x: &[f64]) -> Self {
        let mut structure = nlp.structure().clone();
        for (j, p) in structure.joints.iter_mut().zip(nlp.positions(x)) {
            j.position = p;
        }
        let lengths = (0..structure.beams.len())
            .map(|j| structure.length(j))
            .collect();
        Design {
            forces: nlp.forces(x),
            masses: nlp.beam_masses(x),
            lengths,
            cases: nlp.settings().load_cases.clone(),
            max_force: nlp.settings().max_force,
            structure,
        }
    }

    /// Largest |λ| of each beam over the cases, N.
    pub fn peak_forces(&self) -> Vec<f64> {
        (0..self.structure.beams.len())
            .map(|j| self.forces.iter().map(|f| f[j].abs()).fold(0.0, f64::max))
            .collect()
    }

    /// Net force on every joint and case (external + beams + lumped self-weight), N, with the
    /// components an anchor's supports take removed.
    pub fn residuals(&self, settings: &Settings) -> Vec<Vec<Vec3>> {
        let s = &self.structure;
        let g = gravity();
        (0..self.cases.len())
            .map(|c| {
                let mut net: Vec<Vec3> = s.joints.iter().map(|j| j.loads[c]).collect();
                for (b, beam) in s.beams.iter().enumerate() {
                    let [a, bb] = beam.ends;
                    let e = (s.joints[bb].position - s.joints[a].position) / self.lengths[b];
                    let lambda = self.forces[c][b];
                    net[a] -= lambda * e;
                    net[bb] += lambda * e;
                    if settings.self_weight {
                        net[a] += 0.5 * self.masses[b] * g;
                        net[bb] += 0.5 * self.masses[b] * g;
                    }
                }
                (s.joints.iter().zip(net))
                    .map(|(j, mut f)| match &j.kind {
                        JointKind::Anchor(Support::Pinned) => Vec3::zeros(),
                        JointKind::Anchor(Support::Roller(dirs)) => {
                            // Remove the part the reactions can carry (orthonormalized).
                            let mut basis: Vec<Vec3> = Vec::new();
                            for d in dirs {
                                let mut v = *d;
                                for q in &basis {
                                    v -= v.dot(q) * q;
                                }
                                if v.norm() > 1e-9 {
                                    basis.push(v.normalize());
                                }
                            }
                            for q in &basis {
                                f -= f.dot(q) * q;
                            }
                            f
                        }
                        _ => f,
                    })
                    .collect()
            })
            .collect()
    }

    /// Figures for `result.json`.
    pub fn figures(&self, settings: &Settings) -> DesignFigures {
        let residual = self
            .residuals(settings)
            .iter()
            .flatten()
            .map(|f| f.norm())
            .fold(0.0, f64::max);
        let largest_load = (self.structure.joints.iter())
            .flat_map(|j| j.loads.iter())
            .map(|f| f.norm())
            .fold(0.0, f64::max);
        let peaks = self.peak_forces();
        let top = peaks.iter().copied().fold(0.0, f64::max);
        DesignFigures {
            mass_kg: self.masses.iter().sum(),
            length_m: self.lengths.iter().sum(),
            joints: self.structure.joints.len(),
            beams: self.structure.beams.len(),
            active_beams: peaks.iter().filter(|&&p| p > 1e-3 * top).count(),
            max_balance_residual_n: residual,
            max_balance_residual_relative: residual / largest_load.max(f64::MIN_POSITIVE),
            max_force_ratio: top / self.max_force,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::Nlp;
    use crate::truss::mass::MassModel;
    use crate::truss::model::{Beam, Joint, Objective};

    #[test]
    fn residual_is_zero_for_a_balanced_two_bar_truss_and_matches_the_nlp() {
        let p = 1e5;
        let joint = |x: f64, y: f64, kind: JointKind, f: f64| Joint {
            position: Vec3::new(x, y, 0.0),
            kind,
            name: None,
            loads: vec![Vec3::new(0.0, -f, 0.0)],
        };
        let s = Structure {
            joints: vec![
                joint(-3.0, 0.0, JointKind::Anchor(Support::Pinned), 0.0),
                joint(3.0, 0.0, JointKind::Anchor(Support::Pinned), 0.0),
                joint(0.0, 4.0, JointKind::Load, p),
                joint(0.0, 6.0, JointKind::Free, 0.0),
            ],
            beams: vec![
                Beam::new(0, 2),
                Beam::new(1, 2),
                Beam::new(2, 3),
                Beam::new(1, 3),
            ],
        };
        let settings = Settings {
            mass: MassModel::seed(100.0),
            objective: Objective::Mass,
            self_weight: true,
            max_force: 1e6,
            min_length: 0.1,
            max_length: None,
            planar: true,
            held_axis: None,
            move_joints: true,
            symmetry: Vec::new(),
            obstacles: Vec::new(),
            load_cases: vec!["main".into()],
        };
        let lambda = p * 5.0 / 8.0;
        let forces = vec![lambda, lambda, 0.0, 0.0];
        let nlp = TrussNlp::new(s, settings.clone(), forces).unwrap();
        let mut x = vec![0.0; nlp.dims().n];
        nlp.start(&mut x);
        let design = Design::from_point(&nlp, &x);
        let fig = design.figures(&settings);
        // Self-weight of the two legs is not carried by the analytic forces: the residual is the
        // weight lumped at the load joint, ½·g·(m₁ + m₂) (the free joint has zero-mass beams).
        let expected = 0.5 * 9.81 * (design.masses[0] + design.masses[1]);
        assert!(
            (fig.max_balance_residual_n - expected).abs() < 1e-9 * p,
            "{} vs {expected}",
            fig.max_balance_residual_n
        );
        assert!(
            (nlp.max_balance_residual(&x).unwrap() - expected).abs() < 1e-9 * p,
            "the NLP's residual agrees"
        );
        assert_eq!(fig.active_beams, 2);
        assert!((fig.max_force_ratio - lambda / 1e6).abs() < 1e-12);
    }
}
