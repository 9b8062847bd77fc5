//! Output of a solved motion: the simulation re-run from the optimized force splines and
//! sampled, then written as an animated `model.glb`, a `filmstrip.svg`, `trajectory.csv` and
//! `forces.csv`.
//!
//! Sampling: frame `i` is the simulated state after `round(i·Δ/dt)` RK4 steps (Δ = 1/30 s for
//! the animation and the CSVs; its exact time `steps·dt` is written). Link poses come from the
//! world-to-link transforms `X = (E, r)`: the link's origin is `r` (m, world) and its
//! orientation (link → world) is `Eᵀ`, written as a glTF quaternion `[x, y, z, w]`.
//! Each link is a top-level glTF node (no hierarchy) holding its display shape in link
//! coordinates; a ground plane sits at the contact law's ground height. The filmstrip draws the
//! 2-D (x, y) silhouette of every link at frames every 1/4 s, plus the take-off and the apex of
//! the first flight when there is one ([`flight_events`], from the 30 fps samples), shifted
//! sideways so that they stand side by side, over a 10 cm grid (seed Figures 3.9–3.14), under a
//! caption naming the task, the trial's status and its effort.

use nalgebra::{Matrix3, Rotation3, UnitQuaternion};

use super::character::Shape;
use super::sim::{Controls, Simulator, State};
use super::spatial::Xform;
use super::spec::Problem;
use super::spline::SplineControls;
use crate::io::gltf::{Animation, Material, Mesh, Node, Scene, Track};
use crate::io::result::{Csv, num};
use crate::io::shapes;
use crate::io::svg::{Style, Svg};
use crate::outcome::Artifact;

/// Animation and CSV frame rate (frames per second).
pub const FPS: f64 = 30.0;
/// Filmstrip frame interval (s).
pub const FILMSTRIP_INTERVAL: f64 = 0.25;
/// Filmstrip grid spacing (m).
pub const GRID: f64 = 0.1;

/// Height (m) above the ground from which a contact point counts as clear of it: the seed's
/// contact law exerts negligible force more than 5 mm up (§3.5).
pub const CLEAR: f64 = 0.005;

/// A sampled motion.
#[derive(Debug, Clone)]
pub struct Sampled {
    /// Sample times (s).
    pub times: Vec<f64>,
    /// States at the samples.
    pub states: Vec<State<f64>>,
    /// World-to-link transforms per sample and link.
    pub poses: Vec<Vec<Xform<f64>>>,
    /// Actuator forces per sample (N or N·m; a servo's force at the sampled state).
    pub forces: Vec<Vec<f64>>,
}

/// Simulates `problem` with motion parameters `x` (spline parameters, then the initial state
/// when it is a variable) over the control horizon and samples it every
/// `interval` seconds (rounded to whole steps).
pub fn sample(problem: &Problem, x: &[f64], interval: f64) -> Result<Sampled, String> {
    let grid = problem.knot_grid();
    let controls = SplineControls {
        grid,
        params: x.to_vec(),
    };
    let total = (problem.horizon / problem.dt).round() as usize;
    let frames = (problem.horizon / interval + 1e-9).floor() as usize;
    let mut steps: Vec<usize> = (0..=frames)
        .map(|i| ((i as f64 * interval / problem.dt).round() as usize).min(total))
        .collect();
    steps.dedup();
    let mut sim = Simulator::<f64>::new(&problem.model);
    let mut state = problem.initial_of(x);
    let mut out = Sampled {
        times: Vec::new(),
        states: Vec::new(),
        poses: Vec::new(),
        forces: Vec::new(),
    };
    let na = problem.model.actuators.len();
    sim.rollout(&mut state, problem.dt, &steps, &controls, |k, s, sim| {
        let t = steps[k] as f64 * problem.dt;
        let (mut u, mut f) = (vec![0.0; na], vec![0.0; problem.model.nv]);
        controls.forces(t, &mut u);
        problem.model.add_actuators(&u, &s.q, &s.v, &mut f);
        let f = (problem.model.actuators.iter())
            .map(|a| f[problem.model.links[a.link].v_index])
            .collect();
        out.times.push(t);
        out.states.push(s.clone());
        out.poses.push(sim.dynamics.world.clone());
        out.forces.push(f);
    })
    .map_err(|e| e.to_string())?;
    Ok(out)
}

/// Orientation (link → world) and origin (world) of a world-to-link transform.
fn pose(x: &Xform<f64>) -> (UnitQuaternion<f64>, [f64; 3]) {
    let e = &x.e.0;
    let r = Matrix3::from_fn(|i, j| e[j][i]);
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    (q, x.r.0)
}

/// A world point of link `link` at a sample.
fn world_point(x: &Xform<f64>, p: [f64; 3]) -> [f64; 3] {
    let e = &x.e.0;
    std::array::from_fn(|i| x.r.0[i] + (0..3).map(|j| e[j][i] * p[j]).sum::<f64>())
}

fn f32s<const N: usize>(v: [f64; N]) -> [f32; N] {
    v.map(|x| x as f32)
}

/// The display mesh of a shape in link coordinates.
fn shape_mesh(shape: &Shape) -> Mesh {
    match *shape {
        Shape::Box { size, center } => shapes::cuboid(f32s(center), f32s(size.map(|s| 0.5 * s))),
        Shape::Capsule { radius, from, to } => {
            shapes::capsule(f32s(from), f32s(to), radius as f32, 16)
        }
        Shape::Sphere { radius, center } => shapes::sphere(f32s(center), radius as f32, 16),
        Shape::Cone { radius, apex, base } => {
            shapes::cone(f32s(apex), f32s(base), radius as f32, 16)
        }
    }
}

/// The animated scene: a node per link (translation and rotation channels), a ground plane.
pub fn scene(problem: &Problem, motion: &Sampled) -> Scene {
    let model = &problem.model;
    let mut scene = Scene {
        materials: vec![
            Material::matte("link", [0.75, 0.55, 0.2, 1.0]),
            Material::matte("ground", [0.6, 0.6, 0.6, 1.0]),
        ],
        ..Scene::default()
    };
    let mut tracks = Vec::new();
    for (i, link) in model.links.iter().enumerate() {
        let mut mesh = shape_mesh(&link.shape);
        mesh.name = link.name.clone();
        mesh.material = 0;
        scene.meshes.push(mesh);
        let mut node = Node::with_mesh(&link.name, i);
        let (q, r) = pose(&motion.poses[0][i]);
        node.translation = f32s(r);
        node.rotation = f32s([q.i, q.j, q.k, q.w]);
        scene.nodes.push(node);
        scene.roots.push(i);
        let (mut translations, mut rotations) = (Vec::new(), Vec::new());
        for frame in &motion.poses {
            let (q, r) = pose(&frame[i]);
            translations.push(f32s(r));
            rotations.push(f32s([q.i, q.j, q.k, q.w]));
        }
        tracks.push(Track {
            node: i,
            translations,
            rotations,
        });
    }
    let mut ground = shapes::ground(2.0, model.contact.ground as f32);
    ground.name = "ground".into();
    ground.material = 1;
    scene.meshes.push(ground);
    scene
        .nodes
        .push(Node::with_mesh("ground", scene.meshes.len() - 1));
    scene.roots.push(scene.nodes.len() - 1);
    scene.animations.push(Animation {
        name: problem.name.clone(),
        times: motion.times.iter().map(|&t| t as f32).collect(),
        tracks,
    });
    scene
}

/// Outline of a shape in the x–y plane (world), at a sample pose.
fn outline(shape: &Shape, x: &Xform<f64>) -> Vec<[f64; 2]> {
    let at = |p: [f64; 3]| {
        let w = world_point(x, p);
        [w[0], w[1]]
    };
    match *shape {
        Shape::Box { size, center } => [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .iter()
            .map(|&(a, b)| {
                at([
                    center[0] + 0.5 * a * size[0],
                    center[1] + 0.5 * b * size[1],
                    center[2],
                ])
            })
            .collect(),
        Shape::Capsule { radius, from, to } => {
            // The stadium around the segment, in the link's x–y plane.
            let d = [to[0] - from[0], to[1] - from[1]];
            let len = (d[0] * d[0] + d[1] * d[1]).sqrt();
            let base = if len > 1e-12 { d[1].atan2(d[0]) } else { 0.0 };
            let mut pts = Vec::new();
            for (end, offset) in [(to, -0.5), (from, 0.5)] {
                for i in 0..=8 {
                    let a = base + std::f64::consts::PI * (offset + i as f64 / 8.0);
                    pts.push(at([
                        end[0] + radius * a.cos(),
                        end[1] + radius * a.sin(),
                        end[2],
                    ]));
                }
            }
            pts
        }
        Shape::Sphere { radius, center } => (0..24)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / 24.0;
                at([
                    center[0] + radius * a.cos(),
                    center[1] + radius * a.sin(),
                    center[2],
                ])
            })
            .collect(),
        Shape::Cone { radius, apex, base } => {
            // The triangle of apex and base rim, in the link's x–y plane.
            let d = [base[0] - apex[0], base[1] - apex[1]];
            let len = d[0].hypot(d[1]);
            let n = if len > 1e-12 {
                [-d[1] / len, d[0] / len]
            } else {
                [0.0, 1.0]
            };
            vec![
                at(apex),
                at([base[0] + radius * n[0], base[1] + radius * n[1], base[2]]),
                at([base[0] - radius * n[0], base[1] - radius * n[1], base[2]]),
            ]
        }
    }
}

/// The lowest contact point's height above the ground (m) at each sample.
fn lowest_contact(problem: &Problem, motion: &Sampled) -> Vec<f64> {
    let model = &problem.model;
    motion
        .poses
        .iter()
        .map(|frame| {
            model
                .links
                .iter()
                .zip(frame)
                .flat_map(|(l, x)| l.contacts.iter().map(|&p| world_point(x, p)[1]))
                .fold(f64::INFINITY, f64::min)
                - model.contact.ground
        })
        .collect()
}

/// The first flight of a sampled motion, as sample indices `(take-off, apex)`: take-off is the
/// first sample with every contact point more than [`CLEAR`] up after one that was not; the
/// apex is the sample of that flight (until a point comes back within [`CLEAR`]) whose lowest
/// contact point is highest. `None` when the motion never leaves the ground.
pub fn flight_events(problem: &Problem, motion: &Sampled) -> Option<(usize, usize)> {
    let low = lowest_contact(problem, motion);
    let off = (1..low.len()).find(|&k| low[k] > CLEAR && low[k - 1] <= CLEAR)?;
    let end = (off..low.len())
        .find(|&k| low[k] <= CLEAR)
        .unwrap_or(low.len());
    let apex = (off..end).max_by(|&a, &b| low[a].total_cmp(&low[b]))?;
    Some((off, apex))
}

/// Adds an event frame (take-off, apex) to the filmstrip's frames; an event within half a
/// sample (`0.5/FPS`) of a frame already there names that frame instead of repeating it.
fn add_event<'a>(
    frames: &mut Vec<(f64, &'a Vec<Xform<f64>>, &'a str)>,
    time: f64,
    pose: &'a Vec<Xform<f64>>,
    label: &'a str,
) {
    match frames
        .iter_mut()
        .find(|(t, _, _)| (t - time).abs() < 0.5 / FPS)
    {
        Some(frame) if frame.2.is_empty() => frame.2 = label,
        Some(_) => {}
        None => frames.push((time, pose, label)),
    }
}

/// The filmstrip (module header): frames of `strip` (every 1/4 s) and the take-off and apex
/// of `motion` (the 30 fps samples), in time order, under `caption`.
pub fn filmstrip(problem: &Problem, strip: &Sampled, motion: &Sampled, caption: &str) -> String {
    let model = &problem.model;
    let mut frames: Vec<(f64, &Vec<Xform<f64>>, &str)> = strip
        .times
        .iter()
        .zip(&strip.poses)
        .map(|(&t, p)| (t, p, ""))
        .collect();
    if let Some((off, apex)) = flight_events(problem, motion) {
        add_event(
            &mut frames,
            motion.times[off],
            &motion.poses[off],
            "take-off",
        );
        if apex != off {
            add_event(&mut frames, motion.times[apex], &motion.poses[apex], "apex");
        }
    }
    frames.sort_by(|a, b| a.0.total_cmp(&b.0));
    let outlines: Vec<Vec<Vec<[f64; 2]>>> = frames
        .iter()
        .map(|(_, frame, _)| {
            model
                .links
                .iter()
                .zip(frame.iter())
                .map(|(l, x)| outline(&l.shape, x))
                .collect()
        })
        .collect();
    let pts = || outlines.iter().flatten().flatten();
    let (mut xmin, mut xmax, mut ymin, mut ymax) =
        (f64::MAX, f64::MIN, model.contact.ground, 0.0f64);
    for p in pts() {
        xmin = xmin.min(p[0]);
        xmax = xmax.max(p[0]);
        ymin = ymin.min(p[1]);
        ymax = ymax.max(p[1]);
    }
    // Each frame gets a panel as wide as the whole motion's x-extent plus a gap, on the grid.
    let panel = ((xmax - xmin + 0.1) / GRID).ceil() * GRID;
    let n = outlines.len();
    let left = (xmin / GRID).floor() * GRID;
    let (bottom, top) = (
        (ymin / GRID).floor() * GRID,
        (ymax / GRID).ceil() * GRID + 2.0 * GRID,
    );
    let right = left + panel * n as f64;
    let width = (200.0 * n as f64).min(2400.0);
    let mut svg = Svg::new(width, left, right, bottom, top);
    svg.grid(GRID, &Style::line("#dddddd", 0.5));
    let g = model.contact.ground;
    svg.line([left, g], [right, g], &Style::line("#555555", 1.0));
    for (k, frame) in outlines.iter().enumerate() {
        let shift = panel * k as f64;
        for poly in frame {
            let moved: Vec<[f64; 2]> = poly.iter().map(|p| [p[0] + shift, p[1]]).collect();
            svg.polygon(
                &moved,
                &Style {
                    stroke: "#333333",
                    stroke_width: 0.8,
                    fill: "#e0a040",
                    opacity: 0.9,
                },
            );
        }
        let (t, _, event) = frames[k];
        svg.text(
            [left + shift + 0.01, top - GRID - 0.03],
            10.0,
            format!("t = {t:.2} s {event}").trim_end(),
        );
    }
    svg.text([left + 0.01, top - 0.03], 12.0, caption);
    let scale = format!(
        "grid {:.0} cm; ground at y = {g:.2} m; frames side by side, each at its own time",
        GRID * 100.0
    );
    svg.text([left + 0.01, top - 0.03 - 0.4 * GRID], 9.0, &scale);
    svg.finish()
}

/// `trajectory.csv`: time, every coordinate and rate, the centre of mass.
pub fn trajectory_csv(problem: &Problem, motion: &Sampled) -> Artifact {
    let model = &problem.model;
    let mut header = vec!["t_s".to_string()];
    header.extend((0..model.nq).map(|i| format!("q{i}")));
    header.extend((0..model.nv).map(|i| format!("v{i}")));
    for l in &model.links {
        header.push(format!("{}_x_m", l.name));
        header.push(format!("{}_y_m", l.name));
    }
    let refs: Vec<&str> = header.iter().map(String::as_str).collect();
    let mut csv = Csv::new(&refs);
    for ((t, s), frame) in motion.times.iter().zip(&motion.states).zip(&motion.poses) {
        let mut row = vec![num(*t)];
        row.extend(s.q.iter().chain(&s.v).map(|v| num(*v)));
        for x in frame {
            row.push(num(x.r.0[0]));
            row.push(num(x.r.0[1]));
        }
        csv.row(row);
    }
    csv.into_artifact("trajectory.csv")
}

/// `forces.csv`: time and every actuator force (N or N·m).
pub fn forces_csv(problem: &Problem, motion: &Sampled) -> Artifact {
    let mut header = vec!["t_s".to_string()];
    header.extend(problem.model.actuators.iter().map(|a| a.name.clone()));
    let refs: Vec<&str> = header.iter().map(String::as_str).collect();
    let mut csv = Csv::new(&refs);
    for (t, f) in motion.times.iter().zip(&motion.forces) {
        csv.row(std::iter::once(num(*t)).chain(f.iter().map(|v| num(*v))));
    }
    csv.into_artifact("forces.csv")
}

/// Every exported file of the motion with spline parameters `x`; `caption` heads the
/// filmstrip (task, status, effort).
pub fn artifacts(problem: &Problem, x: &[f64], caption: &str) -> Result<Vec<Artifact>, String> {
    let motion = sample(problem, x, 1.0 / FPS)?;
    let strip = sample(problem, x, FILMSTRIP_INTERVAL)?;
    let glb = scene(problem, &motion)
        .to_glb()
        .map_err(|e| e.to_string())?;
    Ok(vec![
        Artifact {
            name: "model.glb".into(),
            bytes: glb,
        },
        Artifact {
            name: "filmstrip.svg".into(),
            bytes: filmstrip(problem, &strip, &motion, caption).into_bytes(),
        },
        trajectory_csv(problem, &motion),
        forces_csv(problem, &motion),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;
    use gltf::animation::util::ReadOutputs;
    use std::path::PathBuf;

    fn problem(name: &str) -> Problem {
        let path =
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("problems/gait/{name}.toml"));
        crate::gait::load(&path).unwrap()
    }

    /// The hand-made pogo jump start, exported and read back with the `gltf` crate: one node per
    /// link plus the ground, translation and rotation channels at 30 fps over the horizon, and
    /// the head's keyframes equal to the simulated head positions.
    #[test]
    fn glb_animation_reads_back_with_the_gltf_crate() {
        let mut p = problem("pogo_jump");
        p.horizon = 0.3;
        let f = crate::gait::formulation::Formulation::new(&p);
        let x = f.hand_made_start().to_vec();
        let motion = sample(&p, &x, 1.0 / FPS).unwrap();
        assert_eq!(motion.times.len(), 10, "0.3 s at 30 fps: frames 0..=9");
        let bytes = scene(&p, &motion).to_glb().unwrap();
        let crate::io::gltf_read::Loaded {
            document: doc,
            buffers,
        } = crate::io::gltf_read::read_slice(&bytes, None).expect("valid glb");
        assert_eq!(doc.nodes().count(), p.model.links.len() + 1);
        let anim = doc.animations().next().unwrap();
        assert_eq!(anim.channels().count(), 2 * p.model.links.len());
        let head = p.model.links.iter().position(|l| l.name == "head").unwrap();
        let mut checked = 0;
        for ch in anim
            .channels()
            .filter(|c| c.target().node().index() == head)
        {
            let reader = ch.reader(|b| Some(buffers[b.index()].as_slice()));
            let times: Vec<f32> = reader.read_inputs().unwrap().collect();
            assert_eq!(times.len(), motion.times.len());
            assert!((times[3] - 0.1).abs() < 1e-6);
            match reader.read_outputs().unwrap() {
                ReadOutputs::Translations(t) => {
                    for (k, v) in t.enumerate() {
                        let want = motion.poses[k][head].r.0;
                        for i in 0..3 {
                            assert!((v[i] as f64 - want[i]).abs() < 1e-6);
                        }
                    }
                    checked += 1;
                }
                ReadOutputs::Rotations(r) => {
                    // Upright pogo: identity rotation throughout.
                    for q in r.into_f32() {
                        assert!((q[3].abs() - 1.0).abs() < 1e-5, "{q:?}");
                    }
                    checked += 1;
                }
                _ => panic!("unexpected channel"),
            }
        }
        assert_eq!(checked, 2);
        // The head rises during the hand-made push (0.2–0.3 s).
        assert!(motion.poses[9][head].r.0[1] > motion.poses[6][head].r.0[1]);
    }

    /// A rotated link's glTF rotation maps link axes to world axes as the simulation does.
    #[test]
    fn link_rotation_matches_world_points() {
        let p = problem("luxo_leap");
        let parameters = p.model.actuators.len() * p.knot_grid().per_actuator();
        let motion = sample(&p, &vec![0.0; parameters], 0.1).unwrap();
        for frame in &motion.poses {
            for x in frame {
                let (q, r) = pose(x);
                let local = nalgebra::Vector3::new(0.1, 0.2, -0.05);
                let by_quat = q * local + nalgebra::Vector3::from(r);
                let by_xform = world_point(x, [0.1, 0.2, -0.05]);
                for i in 0..3 {
                    assert!((by_quat[i] - by_xform[i]).abs() < 1e-12);
                }
            }
        }
    }

    /// The filmstrip has one frame every 1/4 s and the CSVs one row per 30 fps sample.
    #[test]
    fn filmstrip_and_csvs_have_one_entry_per_frame() {
        let p = problem("pogo_crouch");
        let x = crate::gait::formulation::Formulation::new(&p)
            .hand_made_start()
            .to_vec();
        let strip = sample(&p, &x, FILMSTRIP_INTERVAL).unwrap();
        let motion = sample(&p, &x, 1.0 / FPS).unwrap();
        assert_eq!(
            flight_events(&p, &motion),
            None,
            "the crouch stays on the ground"
        );
        let svg = filmstrip(&p, &strip, &motion, "pogo_crouch: caption");
        assert_eq!(svg.matches("t = ").count(), 5, "frames at 0, 0.25, …, 1 s");
        assert!(svg.contains("pogo_crouch: caption"));
        assert!(svg.contains("grid 10 cm; ground at y = 0.00 m"), "{svg}");
        let forces = forces_csv(&p, &motion);
        let text = String::from_utf8(forces.bytes).unwrap();
        assert_eq!(text.lines().count(), 1 + 31);
        assert!(text.starts_with("t_s,leg"));
    }

    /// A pogo stick pushed off at full force leaves the ground: the filmstrip gains a take-off
    /// frame (every contact more than 5 mm up, the sample before not) and an apex frame after it.
    #[test]
    fn a_jump_gets_take_off_and_apex_frames() {
        let p = problem("pogo_jump");
        let f = crate::gait::formulation::Formulation::new(&p);
        let (_, hi) = f.physical_bounds();
        let x: Vec<f64> = hi[..p.spline_parameters()]
            .iter()
            .enumerate()
            .map(|(j, &v)| if j < p.knots { v } else { 0.0 })
            .collect();
        let motion = sample(&p, &x, 1.0 / FPS).unwrap();
        let (off, apex) = flight_events(&p, &motion).expect("a flight");
        let low = lowest_contact(&p, &motion);
        assert!(low[off] > CLEAR && low[off - 1] <= CLEAR);
        assert!(apex >= off && low[apex] >= low[off]);
        let strip = sample(&p, &x, FILMSTRIP_INTERVAL).unwrap();
        let svg = filmstrip(&p, &strip, &motion, "");
        assert_eq!(svg.matches("take-off").count(), 1);
        assert_eq!(
            svg.matches("t = ").count(),
            5 + 1 + usize::from(apex != off)
        );
    }

    /// An event at a strip frame's time names that frame instead of drawing it twice; an
    /// event between strip frames is a frame of its own.
    #[test]
    fn an_event_at_a_strip_frame_names_it() {
        let pose = Vec::new();
        let mut frames = vec![(0.25, &pose, ""), (0.5, &pose, "")];
        add_event(&mut frames, 0.5 + 0.1 / FPS, &pose, "apex");
        add_event(&mut frames, 0.4, &pose, "take-off");
        let labels: Vec<(f64, &str)> = frames.iter().map(|f| (f.0, f.2)).collect();
        assert_eq!(labels, vec![(0.25, ""), (0.5, "apex"), (0.4, "take-off")]);
    }
}
