//! Output files of a truss design that need no solver: `beams.csv` and an SVG preview with an
//! elevation (x–y) and a plan (x–z).
//!
//! CSV columns: beam index, end joint indices, end points (m), length (m), force per load case
//! (N, + compression), mass (kg), and "compression"/"tension"/"idle" from the largest-|λ| case.
//! SVG: beams drawn with stroke width ∝ √mass (cross-section radius), compression blue, tension
//! orange, idle beams (below 1e-3 of the largest |λ|) thin grey; anchors as black triangles, load
//! joints as green discs, free joints as small grey discs.
//! glTF (`model.glb`, through the shared writer in `crate::io::gltf`): every working beam as a
//! cylinder whose radius is that of a solid round bar of its cross-section, A = m/(ρ·L) with
//! steel's ρ = 7850 kg/m³, coloured by compression/tension; joints as spheres, loads as larger
//! green spheres, anchors as dark blocks under the joint. Idle beams are left out.

use std::fmt::Write;

use super::build::STEEL_DENSITY;
use super::design::Design;
use super::model::{JointKind, Vec3};
use crate::io::gltf::{GltfError, Material, Mesh, Node, Scene};
use crate::io::shapes;

/// Fraction of the largest |λ| below which a beam is reported idle.
pub const IDLE_FRACTION: f64 = 1e-3;

fn state(design: &Design, j: usize, peak: f64, top: f64) -> &'static str {
    if peak <= IDLE_FRACTION * top {
        return "idle";
    }
    let worst = design
        .forces
        .iter()
        .map(|f| f[j])
        .max_by(|a, b| a.abs().total_cmp(&b.abs()))
        .unwrap_or(0.0);
    if worst > 0.0 {
        "compression"
    } else {
        "tension"
    }
}

/// `beams.csv` text.
pub fn beams_csv(design: &Design) -> String {
    let mut out = String::from("beam,a,b,ax,ay,az,bx,by,bz,length_m");
    for c in &design.cases {
        let _ = write!(out, ",force_{c}_n");
    }
    out.push_str(",mass_kg,state\n");
    let peaks = design.peak_forces();
    let top = peaks.iter().copied().fold(0.0, f64::max);
    for (j, beam) in design.structure.beams.iter().enumerate() {
        let [a, b] = beam.ends;
        let (pa, pb) = (
            design.structure.joints[a].position,
            design.structure.joints[b].position,
        );
        let _ = write!(
            out,
            "{j},{a},{b},{},{},{},{},{},{},{}",
            pa.x, pa.y, pa.z, pb.x, pb.y, pb.z, design.lengths[j]
        );
        for f in &design.forces {
            let _ = write!(out, ",{}", f[j]);
        }
        let _ = writeln!(
            out,
            ",{},{}",
            design.masses[j],
            state(design, j, peaks[j], top)
        );
    }
    out
}

/// SVG preview: elevation (x right, y up) on the left, plan (x right, z down) on the right.
pub fn preview_svg(design: &Design) -> String {
    let joints = &design.structure.joints;
    let mut lo = Vec3::repeat(f64::INFINITY);
    let mut hi = Vec3::repeat(f64::NEG_INFINITY);
    for j in joints {
        lo = lo.inf(&j.position);
        hi = hi.sup(&j.position);
    }
    let span = (hi - lo).max().max(1e-9);
    let panel = 480.0;
    let margin = 20.0;
    let scale = (panel - 2.0 * margin) / span;
    let width = 2.0 * panel;
    let height = panel;
    // Screen coordinates of a point in the elevation (x, y) or plan (x, z) panel.
    let to_screen = |p: &Vec3, plan: bool| -> (f64, f64) {
        let x = margin + (p.x - lo.x) * scale + if plan { panel } else { 0.0 };
        let y = if plan {
            margin + (p.z - lo.z) * scale
        } else {
            panel - margin - (p.y - lo.y) * scale
        };
        (x, y)
    };
    let peaks = design.peak_forces();
    let top = peaks.iter().copied().fold(0.0, f64::max);
    let heaviest = design.masses.iter().copied().fold(0.0, f64::max);
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{height}\" \
         viewBox=\"0 0 {width} {height}\">"
    );
    let _ = writeln!(
        svg,
        "<rect width=\"{width}\" height=\"{height}\" fill=\"white\"/>\n\
         <text x=\"10\" y=\"16\" font-size=\"13\" font-family=\"sans-serif\">elevation (x, y)</text>\n\
         <text x=\"{}\" y=\"16\" font-size=\"13\" font-family=\"sans-serif\">plan (x, z)</text>\n\
         <line x1=\"{panel}\" y1=\"0\" x2=\"{panel}\" y2=\"{height}\" stroke=\"#ccc\"/>",
        panel + 10.0
    );
    for plan in [false, true] {
        let _ = writeln!(svg, "<g>");
        for (j, beam) in design.structure.beams.iter().enumerate() {
            let (x1, y1) = to_screen(&joints[beam.ends[0]].position, plan);
            let (x2, y2) = to_screen(&joints[beam.ends[1]].position, plan);
            let (colour, w) = match state(design, j, peaks[j], top) {
                "compression" => ("#1f6fb4", 0.6 + 5.0 * (design.masses[j] / heaviest).sqrt()),
                "tension" => ("#d9822b", 0.6 + 5.0 * (design.masses[j] / heaviest).sqrt()),
                _ => ("#bbbbbb", 0.3),
            };
            let _ = writeln!(
                svg,
                "<line x1=\"{x1:.2}\" y1=\"{y1:.2}\" x2=\"{x2:.2}\" y2=\"{y2:.2}\" \
                 stroke=\"{colour}\" stroke-width=\"{w:.2}\" stroke-linecap=\"round\"/>"
            );
        }
        for j in joints {
            let (x, y) = to_screen(&j.position, plan);
            let mark = match j.kind {
                JointKind::Anchor(_) => format!(
                    "<polygon points=\"{:.2},{:.2} {:.2},{:.2} {:.2},{:.2}\" fill=\"black\"/>",
                    x,
                    y,
                    x - 5.0,
                    y + 8.0,
                    x + 5.0,
                    y + 8.0
                ),
                JointKind::Load => {
                    format!("<circle cx=\"{x:.2}\" cy=\"{y:.2}\" r=\"3.5\" fill=\"#2a9d3a\"/>")
                }
                JointKind::Free => {
                    format!("<circle cx=\"{x:.2}\" cy=\"{y:.2}\" r=\"1.5\" fill=\"#666\"/>")
                }
            };
            let _ = writeln!(svg, "{mark}");
        }
        let _ = writeln!(svg, "</g>");
    }
    svg.push_str("</svg>\n");
    svg
}

/// `model.glb` bytes (module header).
pub fn model_glb(design: &Design) -> Result<Vec<u8>, GltfError> {
    let joints = &design.structure.joints;
    let peaks = design.peak_forces();
    let top = peaks.iter().copied().fold(0.0, f64::max);
    let f32s = |p: &Vec3| [p.x as f32, p.y as f32, p.z as f32];
    let mut meshes: Vec<Mesh> = (0..5)
        .map(|material| Mesh {
            name: ["compression", "tension", "free joints", "loads", "anchors"][material].into(),
            material,
            ..Default::default()
        })
        .collect();
    let mut largest_radius: f64 = 0.0;
    for (j, beam) in design.structure.beams.iter().enumerate() {
        let kind = match state(design, j, peaks[j], top) {
            "compression" => 0,
            "tension" => 1,
            _ => continue,
        };
        let area = design.masses[j] / (STEEL_DENSITY * design.lengths[j]);
        let radius = (area / std::f64::consts::PI).sqrt();
        largest_radius = largest_radius.max(radius);
        let [a, b] = beam.ends;
        let bar = shapes::cylinder(
            f32s(&joints[a].position),
            f32s(&joints[b].position),
            radius as f32,
            12,
        );
        shapes::append(&mut meshes[kind], &bar);
    }
    let mut lo = Vec3::repeat(f64::INFINITY);
    let mut hi = Vec3::repeat(f64::NEG_INFINITY);
    for j in joints {
        lo = lo.inf(&j.position);
        hi = hi.sup(&j.position);
    }
    let joint_radius = (1.5 * largest_radius).max(2e-3 * (hi - lo).norm());
    for j in joints {
        let c = f32s(&j.position);
        let r = joint_radius as f32;
        match j.kind {
            JointKind::Free => shapes::append(&mut meshes[2], &shapes::sphere(c, r, 10)),
            JointKind::Load => shapes::append(&mut meshes[3], &shapes::sphere(c, 2.0 * r, 14)),
            JointKind::Anchor(_) => {
                shapes::append(&mut meshes[4], &shapes::sphere(c, r, 10));
                let base = [c[0], c[1] - 2.0 * r, c[2]];
                shapes::append(&mut meshes[4], &shapes::cuboid(base, [2.0 * r, r, 2.0 * r]));
            }
        }
    }
    let materials = vec![
        Material::matte("compression", [0.12, 0.44, 0.71, 1.0]),
        Material::matte("tension", [0.85, 0.51, 0.17, 1.0]),
        Material::matte("free joint", [0.4, 0.4, 0.4, 1.0]),
        Material::matte("load", [0.16, 0.62, 0.23, 1.0]),
        Material::matte("anchor", [0.1, 0.1, 0.1, 1.0]),
    ];
    let meshes: Vec<Mesh> = meshes
        .into_iter()
        .filter(|m| !m.indices.is_empty())
        .collect();
    let nodes: Vec<Node> = (meshes.iter().enumerate())
        .map(|(k, m)| Node::with_mesh(&m.name, k))
        .collect();
    let scene = Scene {
        materials,
        roots: (0..nodes.len()).collect(),
        meshes,
        nodes,
        animations: Vec::new(),
    };
    scene.to_glb()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::truss::model::{Beam, Joint, Structure, Support};

    fn design() -> Design {
        let joint = |x: f64, y: f64, kind: JointKind| Joint {
            position: Vec3::new(x, y, 0.5),
            kind,
            name: None,
            loads: vec![Vec3::zeros(); 2],
        };
        Design {
            structure: Structure {
                joints: vec![
                    joint(0.0, 0.0, JointKind::Anchor(Support::Pinned)),
                    joint(4.0, 0.0, JointKind::Load),
                    joint(2.0, 2.0, JointKind::Free),
                ],
                beams: vec![Beam::new(0, 1), Beam::new(0, 2), Beam::new(1, 2)],
            },
            forces: vec![vec![-10.0, 5.0, 0.0], vec![-3.0, 7.0, 0.0]],
            lengths: vec![4.0, 8f64.sqrt(), 8f64.sqrt()],
            masses: vec![1.0, 2.0, 0.0],
            cases: vec!["dead".into(), "wind".into()],
            max_force: 100.0,
        }
    }

    #[test]
    fn csv_has_a_row_per_beam_with_forces_per_case() {
        let csv = beams_csv(&design());
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(
            lines[0],
            "beam,a,b,ax,ay,az,bx,by,bz,length_m,force_dead_n,force_wind_n,mass_kg,state"
        );
        assert_eq!(lines.len(), 4);
        assert_eq!(lines[1], "0,0,1,0,0,0.5,4,0,0.5,4,-10,-3,1,tension");
        assert!(lines[2].ends_with(",7,2,compression"));
        assert!(lines[3].ends_with(",idle"));
    }

    #[test]
    fn svg_draws_every_beam_in_both_views() {
        let svg = preview_svg(&design());
        assert!(svg.starts_with("<svg"));
        assert!(svg.trim_end().ends_with("</svg>"));
        assert_eq!(svg.matches("<line x1=").count(), 2 * 3 + 1);
        assert_eq!(svg.matches("<polygon").count(), 2);
        assert_eq!(svg.matches("#2a9d3a").count(), 2);
    }

    #[test]
    fn glb_holds_the_working_beams_and_the_joints() {
        let bytes = model_glb(&design()).unwrap();
        assert_eq!(&bytes[0..4], b"glTF");
        let (doc, buffers, _) = gltf::import_slice(&bytes).unwrap();
        let names: Vec<String> = doc
            .meshes()
            .map(|m| m.name().unwrap_or_default().to_string())
            .collect();
        assert_eq!(
            names,
            ["compression", "tension", "free joints", "loads", "anchors"]
        );
        assert_eq!(buffers.len(), 1);
    }
}
