//! Pictures of a collocation result: `model.glb` and `filmstrip.svg`, like the other gait runs.
//!
//! The ball is a point in the x–y plane (m, y up, the floor at y = 0); it is drawn as a sphere
//! of radius `max_compression` (the depth its bottom may sink into the floor) whose lowest point
//! is the optimized position. `model.glb`: the ball's node animated through the knots (linear
//! between them), the floor, and the wall when the file has one. `filmstrip.svg`: the caption,
//! the path, the ball at every sixth knot and at every touch-down and take-off (outlined in
//! green), the floor and the wall.

use super::nlp::{Layout, Phase};
use super::spec::Problem;
use crate::io::gltf::{Animation, GltfError, Material, Mesh, Node, Scene, Track};
use crate::io::shapes;
use crate::io::svg::{Style, Svg};

/// The ball's lowest point (m) at every knot.
fn path(l: &Layout, x: &[f64]) -> Vec<[f64; 2]> {
    (0..l.times.len())
        .map(|i| [x[l.var(i, 0, false)], x[l.var(i, 1, false)]])
        .collect()
}

/// `model.glb` bytes: the ball animated over the knot times, the floor and the wall.
pub fn model_glb(problem: &Problem, l: &Layout, x: &[f64]) -> Result<Vec<u8>, GltfError> {
    let r = problem.max_compression;
    let points = path(l, x);
    let (lo, hi) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p[0]), hi.max(p[0]))
        });
    let mut scene = Scene {
        materials: vec![
            Material::matte("ball", [0.8, 0.2, 0.15, 1.0]),
            Material::matte("floor", [0.6, 0.6, 0.6, 1.0]),
        ],
        ..Scene::default()
    };
    let mut ball = Mesh {
        name: "ball".into(),
        ..Mesh::default()
    };
    shapes::append(
        &mut ball,
        &shapes::sphere([0.0, r as f32, 0.0], r as f32, 16),
    );
    let mut floor = Mesh {
        name: "floor".into(),
        material: 1,
        ..Mesh::default()
    };
    let half = (0.5 * (hi - lo) + 1.0) as f32;
    let middle = (0.5 * (lo + hi)) as f32;
    let slab = shapes::cuboid([middle, -0.01, 0.0], [half, 0.01, half.min(2.0)]);
    shapes::append(&mut floor, &slab);
    if let Some(wall) = &problem.wall {
        let h = (0.5 * wall.height) as f32;
        let block = shapes::cuboid([wall.x as f32, h, 0.0], [0.05, h, half.min(2.0)]);
        shapes::append(&mut floor, &block);
    }
    scene.meshes = vec![ball, floor];
    scene.nodes = vec![Node::with_mesh("ball", 0), Node::with_mesh("floor", 1)];
    scene.nodes[0].translation = [points[0][0] as f32, points[0][1] as f32, 0.0];
    scene.roots = vec![0, 1];
    scene.animations = vec![Animation {
        name: problem.name.clone(),
        times: l.times.iter().map(|&t| t as f32).collect(),
        tracks: vec![Track {
            node: 0,
            translations: points
                .iter()
                .map(|p| [p[0] as f32, p[1] as f32, 0.0])
                .collect(),
            rotations: Vec::new(),
        }],
    }];
    scene.to_glb()
}

/// `filmstrip.svg`: the motion in one picture under `caption`.
pub fn filmstrip(problem: &Problem, l: &Layout, x: &[f64], caption: &str) -> String {
    let r = problem.max_compression;
    let points = path(l, x);
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in &points {
        for k in 0..2 {
            (lo[k], hi[k]) = (lo[k].min(p[k]), hi[k].max(p[k] + 2.0 * r));
        }
    }
    let wall_top = problem.wall.as_ref().map_or(0.0, |w| w.height);
    let mut svg = Svg::new(
        960.0,
        lo[0] - r,
        hi[0] + r,
        lo[1].min(0.0),
        hi[1].max(wall_top) + 0.4,
    );
    svg.line(
        [lo[0] - r, 0.0],
        [hi[0] + r, 0.0],
        &Style::line("#555", 2.0),
    );
    if let Some(wall) = &problem.wall {
        let (a, b) = (wall.x - 0.05, wall.x + 0.05);
        let block = [[a, 0.0], [b, 0.0], [b, wall.height], [a, wall.height]];
        svg.polygon(&block, &Style::fill("#888"));
    }
    for pair in points.windows(2) {
        svg.line(pair[0], pair[1], &Style::line("#999", 1.0));
    }
    for (i, p) in points.iter().enumerate() {
        let event = matches!(l.contact[i], Phase::TouchDown | Phase::TakeOff);
        if i % 6 == 0 || event || i + 1 == points.len() {
            let colour = if event { "#2a9d3a" } else { "#c0392b" };
            svg.circle([p[0], p[1] + r], r, &Style::line(colour, 1.5));
        }
    }
    svg.text([lo[0] - r, hi[1].max(wall_top) + 0.3], 16.0, caption);
    svg.finish()
}
