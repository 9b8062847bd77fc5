//! Michell refinement: the layout LP over the fully connected ground structure (member adding,
//! `[connect] full`) on ever finer lattices, against Michell's closed forms, with the CPU time
//! of each LP (one thread).
//!
//! `cargo run --release --example michell_sweep -- [WHICH] [SIZE...]`, WHICH one of
//! `cantilever`, `half_wheel` (square lattices, SIZE = spacing in m), `cantilever_polar`,
//! `half_wheel_polar` (polar grids, SIZE = radial steps k; below), default both polar sweeps.
//!
//! - circle-supported cantilever: a rigid circle of radius r = 1 m (pinned anchors around it,
//!   one per lattice spacing of arc; a sphere obstacle of the same radius keeps members
//!   outside it), a load P = 100 kN at L = 3 m perpendicular to the radius; free joints on a
//!   lattice over [−1.5, 3.5] × [−2, 2] m outside the circle. V* = 2·P·L·ln(L/r)/σ.
//! - half-wheel: supports at (±10, 0) m (west pinned, east a vertical roller), P = 100 kN down
//!   at the origin, free joints on a lattice over [−10, 10] × [0, 10] m. V* = π·P·a/σ.
//!
//! Polar grids follow Michell's fields (log-polar about the circle; polar about the
//! half-wheel's load), so the lattice error is far smaller than on square lattices.
//!
//! σ_T = σ_C = 250 MPa, ρ = 7850 kg/m³, no self-weight: the LP's mass is ρ·V. Each line prints
//! the size, joints, LP members, members added, LP solves, the LP mass and its certified
//! lower bound, the gap to the analytic mass, and the CPU seconds of the layout start; then
//! the whole `optimize truss` run of the same file at default settings on one thread (layout
//! start, geometry optimization, rounds): its status, iterations, mass, gap and CPU seconds.

use std::time::Instant;

use optimize::outcome::{Kind, RunOptions};
use optimize::truss::{load, plastic, start};

const LOAD: f64 = 1e5;
const SIGMA: f64 = 250e6;
const DENSITY: f64 = 7850.0;

const COMMON: &str = r#"planar = true
self_weight = false
max_force = 1e9
min_length = 0.01
[mass]
model = "linear"
sigma_t = 250e6
sigma_c = 250e6
density = 7850.0
[connect]
neighbours = 16
full = true
"#;

/// The circle-supported cantilever's problem file at lattice `spacing`, m.
fn cantilever(spacing: f64) -> String {
    let anchors = ((2.0 * std::f64::consts::PI / spacing).round() as usize).max(16);
    let mut text = format!("name = \"michell_cantilever\"\n{COMMON}");
    for k in 0..anchors {
        let t = 2.0 * std::f64::consts::PI * k as f64 / anchors as f64;
        text += &format!(
            "[[joint]]\nkind = \"anchor\"\nat = [{:?}, {:?}, 0.0]\n",
            t.cos(),
            t.sin()
        );
    }
    text += &format!(
        "[[joint]]\nkind = \"load\"\nat = [3.0, 0.0, 0.0]\nforce = [0.0, {:?}, 0.0]\n",
        -LOAD
    );
    text += &format!(
        "[ground]\nkind = \"lattice\"\nmin = [-1.5, -2.0, 0.0]\nmax = [3.5, 2.0, 0.0]\nspacing = {spacing:?}\n"
    );
    text += "[[obstacle]]\nkind = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n";
    text
}

/// The half-wheel's problem file at lattice `spacing`, m.
fn half_wheel(spacing: f64) -> String {
    format!(
        "name = \"michell_half_wheel\"\n{COMMON}\
         [[joint]]\nkind = \"anchor\"\nat = [-10.0, 0.0, 0.0]\n\
         [[joint]]\nkind = \"anchor\"\nat = [10.0, 0.0, 0.0]\nsupport = \"roller\"\nreactions = [[0.0, 1.0, 0.0]]\n\
         [[joint]]\nkind = \"load\"\nat = [0.0, 0.0, 0.0]\nforce = [0.0, {:?}, 0.0]\n\
         [ground]\nkind = \"lattice\"\nmin = [-10.0, 0.0, 0.0]\nmax = [10.0, 10.0, 0.0]\nspacing = {spacing:?}\n\
         [[obstacle]]\nkind = \"half_space\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\n",
        -LOAD
    )
}

/// `[[joint]]` rows of free joints at `points`, m.
fn free_joints(points: impl Iterator<Item = (f64, f64)>) -> String {
    points
        .map(|(x, y)| format!("[[joint]]\nkind = \"free\"\nat = [{x:?}, {y:?}, 0.0]\n"))
        .collect()
}

/// The cantilever on a log-polar grid of `k` radial steps: radii r_i = e^(i·Δ) with
/// Δ = ln(L/r)/k (so the load sits on the grid), angles j·Δ for |j| ≤ k + 2 (Michell's
/// spirals r = c·e^(±θ) run along the grid's diagonals; his field spans |θ| ≤ ln(L/r)).
/// Anchors on the circle (i = 0), the load at i = k, j = 0.
fn cantilever_polar(k: usize) -> String {
    let step = 3f64.ln() / k as f64;
    let span = k as i64 + 2;
    let polar = |i: usize, j: i64| {
        let (r, t) = ((i as f64 * step).exp(), j as f64 * step);
        (r * t.cos(), r * t.sin())
    };
    let mut text = format!("name = \"michell_cantilever_polar\"\n{COMMON}");
    for j in -span..=span {
        let (x, y) = polar(0, j);
        text += &format!("[[joint]]\nkind = \"anchor\"\nat = [{x:?}, {y:?}, 0.0]\n");
    }
    text += &format!(
        "[[joint]]\nkind = \"load\"\nat = [3.0, 0.0, 0.0]\nforce = [0.0, {:?}, 0.0]\n",
        -LOAD
    );
    let free = (1..=k).flat_map(|i| (-span..=span).map(move |j| (i, j)));
    text += &free_joints(
        free.filter(|&(i, j)| (i, j) != (k, 0))
            .map(|(i, j)| polar(i, j)),
    );
    text += "[ground]\nkind = \"none\"\n";
    text += "[[obstacle]]\nkind = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n";
    text
}

/// The half-wheel on a polar grid about the load: `k` rings (radii a·i/k) and 2k angular
/// steps over [0, π], the supports at the ends of the outer ring.
fn half_wheel_polar(k: usize) -> String {
    let a = 10.0;
    let polar = |i: usize, j: usize| {
        let (r, t) = (
            a * i as f64 / k as f64,
            std::f64::consts::PI * j as f64 / (2 * k) as f64,
        );
        (r * t.cos(), r * t.sin())
    };
    let mut text = format!(
        "name = \"michell_half_wheel_polar\"\n{COMMON}\
         [[joint]]\nkind = \"anchor\"\nat = [-10.0, 0.0, 0.0]\n\
         [[joint]]\nkind = \"anchor\"\nat = [10.0, 0.0, 0.0]\nsupport = \"roller\"\nreactions = [[0.0, 1.0, 0.0]]\n\
         [[joint]]\nkind = \"load\"\nat = [0.0, 0.0, 0.0]\nforce = [0.0, {:?}, 0.0]\n",
        -LOAD
    );
    let free = (1..=k).flat_map(|i| (0..=2 * k).map(move |j| (i, j)));
    let supports = |&(i, j): &(usize, usize)| i == k && (j == 0 || j == 2 * k);
    text += &free_joints(free.filter(|p| !supports(p)).map(|(i, j)| polar(i, j)));
    text += "[ground]\nkind = \"none\"\n";
    text
}

/// CPU seconds of this process (user + system), from /proc/self/stat (Linux); wall time
/// elsewhere.
fn cpu_seconds(wall: &Instant) -> f64 {
    let ticks = std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| {
            let fields: Vec<&str> = s.rsplit(')').next()?.split_whitespace().collect();
            Some(fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?)
        });
    ticks.map_or_else(|| wall.elapsed().as_secs_f64(), |t| t / 100.0)
}

fn sweep(name: &str, file: &dyn Fn(f64) -> String, exact_mass: f64, sizes: &[f64]) {
    println!(
        "{name}: analytic {exact_mass:.4} kg\n  size     joints  members  added  solves  LP kg      bound kg   gap %    CPU s | run: status      it.   kg         gap %    CPU s"
    );
    for &size in sizes {
        let path = std::env::temp_dir().join(format!("{name}_{size}.toml"));
        std::fs::write(&path, file(size)).expect("writes the problem file");
        let problem = load(&path).expect("loads");
        let model = problem.model();
        let wall = Instant::now();
        let before = cpu_seconds(&wall);
        let layout = start::layout_start(
            &model.structure,
            &model.settings,
            model.full.as_ref(),
            &optimize::solver::Interrupt::new(),
        );
        let cpu = cpu_seconds(&wall) - before;
        let gap = |mass: f64| 100.0 * (mass - exact_mass) / exact_mass;
        match layout {
            Ok(l) => print!(
                "  {size:<7} {:>6}  {:>7}  {:>5}  {:>6}  {:<9.4}  {:<9.4}  {:<7.3}  {cpu:<5.2}",
                model.structure.joints.len(),
                l.lp.members,
                l.lp.members_added,
                l.lp.solves,
                l.lp.cost[0],
                l.lp.lower_bound[0],
                gap(l.lp.cost[0]),
            ),
            Err(e) => print!("  {size:<7} LP failed: {e} ({cpu:.2} s)"),
        }
        let options = RunOptions {
            quiet: true,
            threads: Some(1),
            ..RunOptions::default()
        };
        let before = cpu_seconds(&wall);
        match optimize::run::execute(Kind::Truss, &path, &options) {
            Ok((_, outcome)) => {
                let s = &outcome.summary;
                println!(
                    " | {:<12} {:>4}  {:<9.4}  {:<7.3}  {:.2}",
                    s.status,
                    s.iterations,
                    s.headline.value,
                    gap(s.headline.value),
                    cpu_seconds(&wall) - before
                );
            }
            Err(e) => println!(" | run failed: {e}"),
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let which = args.get(1).map_or("all", String::as_str);
    let sizes: Vec<f64> = args.iter().skip(2).filter_map(|s| s.parse().ok()).collect();
    let or = |default: &[f64]| {
        if sizes.is_empty() {
            default.to_vec()
        } else {
            sizes.clone()
        }
    };
    let cantilever_mass = DENSITY * plastic::michell_cantilever_volume(LOAD, 3.0, 1.0, SIGMA);
    let half_wheel_mass = DENSITY * plastic::michell_half_wheel_volume(LOAD, 10.0, SIGMA);
    let polar = |f: fn(usize) -> String| move |k: f64| f(k as usize);
    match which {
        "cantilever" => sweep(
            which,
            &cantilever,
            cantilever_mass,
            &or(&[0.5, 0.25, 0.125]),
        ),
        "half_wheel" => sweep(which, &half_wheel, half_wheel_mass, &or(&[2.0, 1.0, 0.5])),
        "cantilever_polar" => {
            let file = polar(cantilever_polar);
            sweep(which, &file, cantilever_mass, &or(&[4.0, 8.0, 16.0]))
        }
        "half_wheel_polar" => {
            let file = polar(half_wheel_polar);
            sweep(which, &file, half_wheel_mass, &or(&[4.0, 8.0, 16.0]))
        }
        _ => {
            let file = polar(cantilever_polar);
            sweep(
                "cantilever_polar",
                &file,
                cantilever_mass,
                &[4.0, 8.0, 16.0],
            );
            let file = polar(half_wheel_polar);
            sweep(
                "half_wheel_polar",
                &file,
                half_wheel_mass,
                &[4.0, 8.0, 16.0],
            );
        }
    }
}
