//! Output files of a truss design that need no solver: `beams.csv` and an SVG preview with an
//! elevation (x–y) and a plan (x–z).
//!
//! CSV columns: beam index, end joint indices, end points (m), length (m), force per load case
//! (N, + compression), mass (kg), and "compression"/"tension"/"idle" from the largest-|λ| case.
//! SVG: beams drawn with stroke width ∝ √mass (cross-section radius), compression blue, tension
//! orange, idle beams (below 1e-3 of the largest |λ|) thin grey; anchors as black triangles, load
//! joints as green discs, free joints as small grey discs.
//! glTF (`model.glb`, through the shared writer in `crate::io::gltf`): every working beam its own
//! node, a cylinder whose radius is that of a solid round bar of its cross-section,
//! A = m/(ρ·L) with steel's ρ = 7850 kg/m³, but at least [`MIN_SHOWN_RADIUS`] of the bounding
//! box's diagonal so that the structure is visible; coloured by compression/tension; the node's
//! `extras` carry the beam's forces, length, mass and true radius. Joints as spheres, loads as
//! larger green spheres, anchors as dark blocks under the joint. Idle beams are left out.

use std::fmt::Write;

use super::build::STEEL_DENSITY;
use super::design::Design;
use super::model::{JointKind, Support, Vec3};
use crate::io::gltf::{GltfError, Material, Mesh, Node, Scene};
use crate::io::shapes;
use crate::io::svg::escape;

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

/// SVG preview: `caption` on top, the elevation (x right, y up) above the plan (x right, z
/// down), both at one scale in px/m chosen so the x extent fills the width (each view's height
/// follows its own extent, so a long bridge is not squeezed into a square), then a legend and
/// a scale bar. A structure with every joint at one z (a planar problem) has the elevation only:
/// its plan would be a line. Beam width grows with √mass; colours give the force state.
pub fn preview_svg(design: &Design, caption: &str) -> String {
    const WIDTH: f64 = 960.0;
    const MARGIN: f64 = 30.0;
    const MAX_VIEW: f64 = 420.0;
    const MIN_VIEW: f64 = 24.0;
    let joints = &design.structure.joints;
    let mut lo = Vec3::repeat(f64::INFINITY);
    let mut hi = Vec3::repeat(f64::NEG_INFINITY);
    for j in joints {
        lo = lo.inf(&j.position);
        hi = hi.sup(&j.position);
    }
    let flat = hi.z - lo.z <= 1e-9 * (hi.x - lo.x).max(hi.y - lo.y);
    let extent = (hi - lo).map(|e| e.max(1e-9));
    let scale = ((WIDTH - 2.0 * MARGIN) / extent.x)
        .min(MAX_VIEW / extent.y)
        .min(MAX_VIEW / extent.z);
    let view_height = |e: f64| (e * scale).max(MIN_VIEW) + 2.0 * MARGIN;
    let elevation_top = 40.0;
    let plan_top = elevation_top + view_height(extent.y);
    let legend_top = if flat {
        plan_top
    } else {
        plan_top + view_height(extent.z)
    };
    let height = legend_top + 50.0;
    // Screen coordinates of a point in the elevation (x, y) or plan (x, z) view.
    let to_screen = |p: &Vec3, plan: bool| -> (f64, f64) {
        let x = MARGIN + (p.x - lo.x) * scale;
        let y = if plan {
            plan_top + MARGIN + (p.z - lo.z) * scale
        } else {
            elevation_top + MARGIN + (hi.y - p.y) * scale
        };
        (x, y)
    };
    let peaks = design.peak_forces();
    let top = peaks.iter().copied().fold(0.0, f64::max);
    let heaviest = design.masses.iter().copied().fold(0.0, f64::max);
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{WIDTH}\" height=\"{height:.0}\" \
         viewBox=\"0 0 {WIDTH} {height:.0}\" font-family=\"sans-serif\">"
    );
    let _ = writeln!(
        svg,
        "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n\
         <text x=\"10\" y=\"22\" font-size=\"15\">{}</text>\n\
         <text x=\"10\" y=\"{:.1}\" font-size=\"12\" fill=\"#555\">elevation (x right, y up)</text>",
        escape(caption),
        elevation_top + 14.0,
    );
    if !flat {
        let _ = writeln!(
            svg,
            "<text x=\"10\" y=\"{:.1}\" font-size=\"12\" fill=\"#555\">plan (x right, z down)</text>\n\
             <line x1=\"0\" y1=\"{plan_top:.1}\" x2=\"{WIDTH}\" y2=\"{plan_top:.1}\" stroke=\"#ccc\"/>",
            plan_top + 14.0,
        );
    }
    let views: &[bool] = if flat { &[false] } else { &[false, true] };
    for &plan in views {
        let _ = writeln!(svg, "<g>");
        for (j, beam) in design.structure.beams.iter().enumerate() {
            let (x1, y1) = to_screen(&joints[beam.ends[0]].position, plan);
            let (x2, y2) = to_screen(&joints[beam.ends[1]].position, plan);
            let (colour, w) = match state(design, j, peaks[j], top) {
                "compression" => (
                    COMPRESSION,
                    0.6 + 5.0 * (design.masses[j] / heaviest).sqrt(),
                ),
                "tension" => (TENSION, 0.6 + 5.0 * (design.masses[j] / heaviest).sqrt()),
                _ => (IDLE, 0.3),
            };
            let _ = writeln!(
                svg,
                "<line x1=\"{x1:.2}\" y1=\"{y1:.2}\" x2=\"{x2:.2}\" y2=\"{y2:.2}\" \
                 stroke=\"{colour}\" stroke-width=\"{w:.2}\" stroke-linecap=\"round\"/>"
            );
        }
        for j in joints {
            let (x, y) = to_screen(&j.position, plan);
            let _ = writeln!(svg, "{}", joint_mark(&j.kind, x, y));
        }
        let _ = writeln!(svg, "</g>");
    }
    legend(&mut svg, legend_top + 20.0);
    scale_bar(&mut svg, extent.x, scale, WIDTH - MARGIN, legend_top + 20.0);
    svg.push_str("</svg>\n");
    svg
}

const COMPRESSION: &str = "#1f6fb4";
const TENSION: &str = "#d9822b";
const IDLE: &str = "#bbbbbb";

/// A joint's mark at screen point (x, y): a black triangle (anchor), a green dot (load) or a
/// small grey dot (free joint).
fn joint_mark(kind: &JointKind, x: f64, y: f64) -> String {
    match kind {
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
        JointKind::Free => format!("<circle cx=\"{x:.2}\" cy=\"{y:.2}\" r=\"1.5\" fill=\"#666\"/>"),
    }
}

/// The legend row at height `y`: beam colours, joint marks and what the width means.
fn legend(svg: &mut String, y: f64) {
    let mut x = 10.0;
    for (colour, label) in [
        (COMPRESSION, "compression"),
        (TENSION, "tension"),
        (IDLE, "idle"),
    ] {
        let _ = writeln!(
            svg,
            "<line x1=\"{x:.1}\" y1=\"{y:.1}\" x2=\"{:.1}\" y2=\"{y:.1}\" stroke=\"{colour}\" \
             stroke-width=\"4\"/><text x=\"{:.1}\" y=\"{:.1}\" font-size=\"12\">{label}</text>",
            x + 24.0,
            x + 30.0,
            y + 4.0
        );
        x += 40.0 + 7.0 * label.len() as f64;
    }
    for (kind, label) in [
        (JointKind::Anchor(Support::Pinned), "anchor"),
        (JointKind::Load, "load"),
        (JointKind::Free, "free joint"),
    ] {
        let _ = writeln!(
            svg,
            "{}<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"12\">{label}</text>",
            joint_mark(&kind, x + 5.0, y - 3.0),
            x + 14.0,
            y + 4.0
        );
        x += 24.0 + 7.0 * label.len() as f64;
    }
    let _ = writeln!(
        svg,
        "<text x=\"{x:.1}\" y=\"{:.1}\" font-size=\"12\" fill=\"#555\">width ∝ √mass</text>",
        y + 4.0
    );
}

/// A scale bar ending at `right`, at height `y`: a round length (1, 2 or 5 × 10ᵏ m) near a
/// fifth of the x extent, drawn at `scale` px/m.
fn scale_bar(svg: &mut String, extent_x: f64, scale: f64, right: f64, y: f64) {
    let target = extent_x / 5.0;
    let decade = 10f64.powf(target.log10().floor());
    let length = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|k| k * decade)
        .rfind(|&l| l <= target)
        .unwrap_or(decade);
    let px = length * scale;
    let left = right - px;
    let _ = writeln!(
        svg,
        "<path d=\"M{left:.1},{:.1} V{y:.1} H{right:.1} V{:.1}\" fill=\"none\" stroke=\"black\" \
         stroke-width=\"1.5\"/><text x=\"{:.1}\" y=\"{:.1}\" font-size=\"12\" \
         text-anchor=\"middle\">{} m</text>",
        y - 5.0,
        y - 5.0,
        (left + right) / 2.0,
        y + 15.0,
        round_metres(length)
    );
}

/// A round length as text without trailing zeros ("20", "0.5").
fn round_metres(length: f64) -> String {
    let text = format!("{length:.6}");
    text.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// Smallest radius a beam is drawn with in `model.glb`, as a fraction of the structure's
/// bounding-box diagonal (real bars are centimetres thick on spans of tens of metres).
pub const MIN_SHOWN_RADIUS: f64 = 0.004;

/// `model.glb` bytes (module header): one node and mesh per working beam, named `beam J` (J as
/// in `beams.csv`), drawn at its true radius or [`MIN_SHOWN_RADIUS`] of the bounding-box
/// diagonal, whichever is larger, with `extras` `{force_n: [λ per load case, + compression],
/// length_m, mass_kg, radius_m}` (the true radius); then one mesh each for free joints, loads
/// and anchors.
pub fn model_glb(design: &Design) -> Result<Vec<u8>, GltfError> {
    let joints = &design.structure.joints;
    let peaks = design.peak_forces();
    let top = peaks.iter().copied().fold(0.0, f64::max);
    let f32s = |p: &Vec3| [p.x as f32, p.y as f32, p.z as f32];
    let mut lo = Vec3::repeat(f64::INFINITY);
    let mut hi = Vec3::repeat(f64::NEG_INFINITY);
    for j in joints {
        lo = lo.inf(&j.position);
        hi = hi.sup(&j.position);
    }
    let min_radius = MIN_SHOWN_RADIUS * (hi - lo).norm();
    let mut scene = Scene {
        materials: vec![
            Material::matte("compression", [0.12, 0.44, 0.71, 1.0]),
            Material::matte("tension", [0.85, 0.51, 0.17, 1.0]),
            Material::matte("free joint", [0.4, 0.4, 0.4, 1.0]),
            Material::matte("load", [0.16, 0.62, 0.23, 1.0]),
            Material::matte("anchor", [0.1, 0.1, 0.1, 1.0]),
        ],
        ..Scene::default()
    };
    let mut largest_shown: f64 = 0.0;
    for (j, beam) in design.structure.beams.iter().enumerate() {
        let material = match state(design, j, peaks[j], top) {
            "compression" => 0,
            "tension" => 1,
            _ => continue,
        };
        let area = design.masses[j] / (STEEL_DENSITY * design.lengths[j]);
        let radius = (area / std::f64::consts::PI).sqrt();
        let shown = radius.max(min_radius);
        largest_shown = largest_shown.max(shown);
        let [a, b] = beam.ends;
        let mut mesh = Mesh {
            name: format!("beam {j}"),
            material,
            ..Mesh::default()
        };
        let bar = shapes::cylinder(
            f32s(&joints[a].position),
            f32s(&joints[b].position),
            shown as f32,
            12,
        );
        shapes::append(&mut mesh, &bar);
        let mut node = Node::with_mesh(&mesh.name, scene.meshes.len());
        node.extras = Some(serde_json::json!({
            "force_n": design.forces.iter().map(|f| f[j]).collect::<Vec<f64>>(),
            "length_m": design.lengths[j],
            "mass_kg": design.masses[j],
            "radius_m": radius,
        }));
        scene.meshes.push(mesh);
        scene.nodes.push(node);
    }
    let joint_radius = (1.5 * largest_shown).max(2e-3 * (hi - lo).norm());
    let mut joint_meshes: Vec<Mesh> = (2..5)
        .map(|material| Mesh {
            name: ["free joints", "loads", "anchors"][material - 2].into(),
            material,
            ..Mesh::default()
        })
        .collect();
    for j in joints {
        let c = f32s(&j.position);
        let r = joint_radius as f32;
        match j.kind {
            JointKind::Free => shapes::append(&mut joint_meshes[0], &shapes::sphere(c, r, 10)),
            JointKind::Load => {
                shapes::append(&mut joint_meshes[1], &shapes::sphere(c, 2.0 * r, 14))
            }
            JointKind::Anchor(_) => {
                shapes::append(&mut joint_meshes[2], &shapes::sphere(c, r, 10));
                let base = [c[0], c[1] - 2.0 * r, c[2]];
                shapes::append(
                    &mut joint_meshes[2],
                    &shapes::cuboid(base, [2.0 * r, r, 2.0 * r]),
                );
            }
        }
    }
    for mesh in joint_meshes.into_iter().filter(|m| !m.indices.is_empty()) {
        scene
            .nodes
            .push(Node::with_mesh(&mesh.name, scene.meshes.len()));
        scene.meshes.push(mesh);
    }
    scene.roots = (0..scene.nodes.len()).collect();
    scene.to_glb()
}

#[cfg(test)]
mod tests {
    #[test]
    fn scale_bars_are_round_lengths() {
        assert_eq!(super::round_metres(20.0), "20");
        assert_eq!(super::round_metres(0.5), "0.5");
        let mut svg = String::new();
        // 72 m span: a 10 m bar (the largest of 1, 2, 5, 10 × 10ᵏ up to 14.4 m) at 12 px/m.
        super::scale_bar(&mut svg, 72.0, 12.0, 900.0, 50.0);
        assert!(
            svg.contains("M780.0,45.0") && svg.contains(">10 m<"),
            "{svg}"
        );
    }

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

    /// The test design with its free joint lifted out of the others' plane.
    fn spatial_design() -> Design {
        let mut d = design();
        d.structure.joints[2].position.z = 1.5;
        d
    }

    #[test]
    fn svg_draws_every_beam_in_both_views() {
        let svg = preview_svg(&spatial_design(), "bridge: mass 9 kg <test>");
        assert!(svg.starts_with("<svg"));
        assert!(svg.trim_end().ends_with("</svg>"));
        // 3 beams in 2 views, the views' divider, 3 legend lines.
        assert_eq!(svg.matches("<line x1=").count(), 2 * 3 + 1 + 3);
        // The anchor in 2 views and in the legend; the load likewise.
        assert_eq!(svg.matches("<polygon").count(), 2 + 1);
        assert_eq!(svg.matches("#2a9d3a").count(), 2 + 1);
        assert!(svg.contains("plan (x right, z down)"));
        assert!(svg.contains("bridge: mass 9 kg &lt;test&gt;"));
        assert!(svg.contains("width ∝ √mass") && svg.contains(" m</text>"));
    }

    #[test]
    fn a_planar_structure_is_drawn_in_elevation_only() {
        // Every joint of the test design is at z = 0.5.
        let svg = preview_svg(&design(), "");
        assert!(!svg.contains("plan (x right"), "{svg}");
        // 3 beams in one view and 3 legend lines, no divider; the anchor once and in the legend.
        assert_eq!(svg.matches("<line x1=").count(), 3 + 3);
        assert_eq!(svg.matches("<polygon").count(), 1 + 1);
    }

    #[test]
    fn glb_holds_a_node_per_working_beam_and_the_joints() {
        let bytes = model_glb(&design()).unwrap();
        assert_eq!(&bytes[0..4], b"glTF");
        let crate::io::gltf_read::Loaded {
            document: doc,
            buffers,
        } = crate::io::gltf_read::read_slice(&bytes, None).unwrap();
        let names: Vec<String> = doc
            .meshes()
            .map(|m| m.name().unwrap_or_default().to_string())
            .collect();
        assert_eq!(
            names,
            ["beam 0", "beam 1", "free joints", "loads", "anchors"]
        );
        assert_eq!(buffers.len(), 1);
        // Beam 0: tension, 4 m, 1 kg: a 3.2 mm bar, drawn at 0.4 % of the 4.47 m diagonal.
        let node = doc.nodes().next().unwrap();
        assert_eq!(node.name(), Some("beam 0"));
        // The glTF crate reads extras only with a feature this crate does not enable: read the
        // GLB's JSON chunk (length at bytes 12..16, text from byte 20).
        let length = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        let json: serde_json::Value = serde_json::from_slice(&bytes[20..20 + length]).unwrap();
        let extras = &json["nodes"][0]["extras"];
        let radius = (1.0 / (STEEL_DENSITY * 4.0) / std::f64::consts::PI).sqrt();
        assert_eq!(extras["force_n"], serde_json::json!([-10.0, -3.0]));
        assert_eq!(
            (extras["length_m"].as_f64(), extras["mass_kg"].as_f64()),
            (Some(4.0), Some(1.0))
        );
        assert!((extras["radius_m"].as_f64().unwrap() / radius - 1.0).abs() < 1e-12);
        let bbox = node
            .mesh()
            .unwrap()
            .primitives()
            .next()
            .unwrap()
            .bounding_box();
        let shown = 0.5 * f64::from(bbox.max[1] - bbox.min[1]);
        let minimum = MIN_SHOWN_RADIUS * 20f64.sqrt();
        assert!(
            radius < minimum && (shown / minimum - 1.0).abs() < 1e-3,
            "{shown} vs {minimum}"
        );
    }
}
