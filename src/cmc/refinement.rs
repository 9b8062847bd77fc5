//! Refinement studies (`[refine] levels = N`): the problem is solved at its resolution, then
//! its solution is subdivided ×2 (every edge halved, [`super::subdivide`]) and solved again
//! from there, level after level, and the areas are checked for convergence.
//!
//! With the edge length `h` halving per level and an area error `A(h) − A* ≈ C·h^p`, three
//! consecutive levels give the observed order `p = log₂((A₀ − A₁)/(A₁ − A₂))` and two give the
//! Richardson extrapolation `A* ≈ A₁ + (A₁ − A₀)/(2^q − 1)` at the expected order `q` (2 for
//! these meshes: Surface Evolver and the sphere and catenoid references converge at second
//! order in `h`). A study whose last observed order is below `q − 0.5`, whose differences
//! change sign or grow, or any of whose levels does not converge, is reported as not
//! converging: the area is then a property of the mesh (a neck that pinches, a film that does
//! not exist in that topology), not of the surface, and the run says so in the log and in
//! `result.json` instead of a silent success.
//!
//! Fixed vertices: subdivision puts the new vertices of a wire on the chord between two wire
//! vertices; on a curved wire (a ring) that would freeze the coarse polygon. Each fixed vertex
//! of the subdivided mesh therefore takes the position of the nearest fixed vertex of the
//! generator's own start at the doubled resolution when one lies within 0.3 of the median
//! edge length (the wire at the finer resolution); straight wires are unchanged by it. The free
//! vertices then follow the wires' move ([`follow_wires`]), so rows closer to a wire than its
//! move are not folded over it.

use super::mesh::{Mesh, Point};

/// Lowest observed order, below the expected one, still counted as converging.
pub const ORDER_SLACK: f64 = 0.5;

/// One level of a study.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Level {
    /// 1 for the file's resolution, then one per ×2 subdivision.
    pub level: usize,
    /// Triangles of the level's mesh.
    pub facets: usize,
    /// Vertices of the level's mesh.
    pub vertices: usize,
    /// Solver status of the level's last solve.
    pub status: String,
    /// Whether that solve succeeded (Optimal or Acceptable).
    pub solved: bool,
    /// Major iterations of the level.
    pub iterations: usize,
    /// Total area, m².
    pub area: f64,
    /// Observed order from this level and the two before, when defined.
    pub observed_order: Option<f64>,
    /// Richardson extrapolation from this level and the one before at the expected order, m².
    pub extrapolated_area: Option<f64>,
}

/// A whole study: its levels and verdict.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Study {
    /// Expected order of convergence of the area in the edge length.
    pub expected_order: f64,
    /// The levels, coarsest first.
    pub levels: Vec<Level>,
    /// The finest level's observed order.
    pub observed_order: Option<f64>,
    /// The finest level's extrapolated area, m².
    pub extrapolated_area: Option<f64>,
    /// Whether the area converges at the expected order (module header).
    pub converging: bool,
    /// The verdict in one sentence.
    pub verdict: String,
}

/// The observed order from areas at `h`, `h/2`, `h/4`, when their differences shrink without
/// changing sign.
pub fn observed_order(a: [f64; 3]) -> Option<f64> {
    let (d1, d2) = (a[0] - a[1], a[1] - a[2]);
    (d1 * d2 > 0.0).then(|| (d1 / d2).log2())
}

/// Richardson extrapolation of the areas at `h` and `h/2` at order `order`.
pub fn richardson(coarse: f64, fine: f64, order: f64) -> f64 {
    fine + (fine - coarse) / (2f64.powf(order) - 1.0)
}

/// Fills in the orders and extrapolations of `levels` (their areas and statuses given) and
/// judges the study.
pub fn assess(mut levels: Vec<Level>, expected_order: f64) -> Study {
    for k in 0..levels.len() {
        levels[k].extrapolated_area =
            (k >= 1).then(|| richardson(levels[k - 1].area, levels[k].area, expected_order));
        levels[k].observed_order = (k >= 2)
            .then(|| observed_order([levels[k - 2].area, levels[k - 1].area, levels[k].area]))
            .flatten();
    }
    let last = levels.last();
    let observed_order = last.and_then(|l| l.observed_order);
    let extrapolated_area = last.and_then(|l| l.extrapolated_area);
    let failed = levels.iter().find(|l| !l.solved);
    let (converging, verdict) = if let Some(l) = failed {
        (
            false,
            format!(
                "not converging: level {} ended {} (the film may not exist at this refinement)",
                l.level, l.status
            ),
        )
    } else if levels.len() < 3 {
        (
            true,
            format!(
                "{} levels: the order is not observed (3 levels needed)",
                levels.len()
            ),
        )
    } else {
        match observed_order {
            Some(p) if p >= expected_order - ORDER_SLACK => (
                true,
                format!("converging at order {p:.2} (expected {expected_order})"),
            ),
            Some(p) => (
                false,
                format!(
                    "not converging at the expected order: observed {p:.2}, expected \
                     {expected_order} (the area is a property of the mesh, not of the surface)"
                ),
            ),
            None => (
                false,
                "not converging: the area differences between levels change sign or vanish"
                    .to_string(),
            ),
        }
    };
    Study {
        expected_order,
        levels,
        observed_order,
        extrapolated_area,
        converging,
        verdict,
    }
}

/// The study as a table for the log: level, facets, area, observed order, extrapolated area.
pub fn table(study: &Study) -> Vec<String> {
    let mut lines = vec![format!(
        "refinement: {:>5} {:>8} {:>10} {:>18} {:>7} {:>18}",
        "level", "facets", "status", "area [m²]", "order", "extrapolated [m²]"
    )];
    let opt = |v: Option<f64>, digits: usize| {
        v.map_or_else(|| "-".to_string(), |v| format!("{v:.digits$e}"))
    };
    for l in &study.levels {
        lines.push(format!(
            "refinement: {:>5} {:>8} {:>10} {:>18.10e} {:>7} {:>18}",
            l.level,
            l.facets,
            l.status,
            l.area,
            l.observed_order
                .map_or_else(|| "-".to_string(), |p| format!("{p:.2}")),
            opt(l.extrapolated_area, 10),
        ));
    }
    let tag = if study.converging { "" } else { "warning: " };
    lines.push(format!("refinement: {tag}{}", study.verdict));
    lines
}

/// The positions of `refined` with each fixed vertex moved onto the nearest fixed vertex of
/// `wire` (the generator's start at the finer resolution) when one lies within `reach` (m);
/// free vertices keep theirs ([`follow_wires`] moves them along).
pub fn snap_fixed_vertices(refined: &Mesh, wire: &Mesh, reach: f64) -> Vec<Point> {
    let mut positions = refined.positions().to_vec();
    let targets: Vec<Point> = wire.fixed_positions().copied().collect();
    if targets.is_empty() || reach <= 0.0 {
        return positions;
    }
    let cell = |p: &Point| [p.x, p.y, p.z].map(|c| (c / reach).floor() as i64);
    let mut grid: std::collections::HashMap<[i64; 3], Vec<usize>> = Default::default();
    for (k, p) in targets.iter().enumerate() {
        grid.entry(cell(p)).or_default().push(k);
    }
    for (p, f) in positions.iter_mut().zip(refined.flags()) {
        if !f.fixed {
            continue;
        }
        let c = cell(p);
        let mut best: Option<(f64, usize)> = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    for &k in grid
                        .get(&[c[0] + dx, c[1] + dy, c[2] + dz])
                        .into_iter()
                        .flatten()
                    {
                        let d = (targets[k] - *p).norm();
                        if d <= reach && best.is_none_or(|(b, _)| d < b) {
                            best = Some((d, k));
                        }
                    }
                }
            }
        }
        if let Some((_, k)) = best {
            *p = targets[k];
        }
    }
    positions
}

/// Largest number of conjugate-gradient steps of [`follow_wires`].
const FOLLOW_MAX_STEPS: usize = 5_000;

/// Moves the free vertices of `mesh` along with its wires: `moved` holds the positions after
/// [`snap_fixed_vertices`] (fixed vertices moved, the others as in `mesh`). Each free vertex
/// without a guide is displaced by the discrete harmonic extension of the fixed vertices'
/// displacement, `Σⱼ wᵢⱼ (uᵢ − uⱼ) = 0` with edge weights `wᵢⱼ = 1/ℓᵢⱼ²` (ℓ the edge's length
/// in `mesh`, m): a vertex one short edge away from a moved wire vertex moves nearly as far,
/// so a band of rows thinner than the wire's move (a ring close to a square wire, whose new
/// vertices move from the coarse chords onto the circle) is carried along instead of folded.
/// Guided vertices stay (their guide holds them); so does everything when no wire moved.
/// Solved by conjugate gradients with the diagonal as preconditioner, to 1e-10 of the
/// right-hand side's norm (m).
pub fn follow_wires(mesh: &Mesh, mut moved: Vec<Point>) -> Vec<Point> {
    let before = mesh.positions();
    let unknown: Vec<bool> = (mesh.flags().iter())
        .map(|f| !f.fixed && f.guide.is_none())
        .collect();
    let rows: Vec<Vec<(usize, f64)>> = (0..before.len())
        .map(|v| {
            let weight = |u: &usize| (*u, 1.0 / (before[v] - before[*u]).norm_squared());
            mesh.neighbours(v).iter().map(weight).collect()
        })
        .collect();
    let diagonal: Vec<f64> = rows
        .iter()
        .map(|r| r.iter().map(|(_, w)| w).sum())
        .collect();
    // Right-hand side: the known neighbours' displacement, weighted; zero on known rows.
    let rhs: Vec<Point> = (0..before.len())
        .map(|v| match unknown[v] {
            false => Point::zeros(),
            true => (rows[v].iter())
                .filter(|(u, _)| !unknown[*u])
                .map(|&(u, w)| w * (moved[u] - before[u]))
                .sum(),
        })
        .collect();
    let apply = |x: &[Point]| -> Vec<Point> {
        (0..x.len())
            .map(|v| match unknown[v] {
                false => Point::zeros(),
                true => {
                    let off: Point = (rows[v].iter())
                        .filter(|(u, _)| unknown[*u])
                        .map(|&(u, w)| w * x[u])
                        .sum();
                    diagonal[v] * x[v] - off
                }
            })
            .collect()
    };
    let shift = conjugate_gradients(apply, &rhs, &diagonal);
    for (v, d) in shift.iter().enumerate().filter(|(v, _)| unknown[*v]) {
        moved[v] = before[v] + d;
    }
    moved
}

/// Solves `A x = b` for a symmetric positive (semi)definite `A` given as `apply`, with the
/// diagonal `diagonal` as preconditioner, from x = 0 (zero rows of `b` stay zero), to a
/// residual of 1e-10·‖b‖ or [`FOLLOW_MAX_STEPS`] steps.
fn conjugate_gradients(
    apply: impl Fn(&[Point]) -> Vec<Point>,
    b: &[Point],
    diagonal: &[f64],
) -> Vec<Point> {
    let dot = |a: &[Point], c: &[Point]| a.iter().zip(c).map(|(p, q)| p.dot(q)).sum::<f64>();
    let precondition = |r: &[Point]| -> Vec<Point> {
        (r.iter().zip(diagonal))
            .map(|(p, &d)| if d > 0.0 { p / d } else { Point::zeros() })
            .collect()
    };
    let mut x = vec![Point::zeros(); b.len()];
    let mut r = b.to_vec();
    let stop = 1e-20 * dot(b, b);
    let mut z = precondition(&r);
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    for _ in 0..FOLLOW_MAX_STEPS {
        if dot(&r, &r) <= stop {
            break;
        }
        let ap = apply(&p);
        let alpha = rz / dot(&p, &ap);
        for ((xi, ri), (pi, api)) in x.iter_mut().zip(&mut r).zip(p.iter().zip(&ap)) {
            *xi += alpha * pi;
            *ri -= alpha * api;
        }
        z = precondition(&r);
        let next = dot(&r, &z);
        let beta = next / rz;
        rz = next;
        for (pi, zi) in p.iter_mut().zip(&z) {
            *pi = zi + beta * *pi;
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    fn level(level: usize, area: f64, status: &str) -> Level {
        Level {
            level,
            facets: 100 << (2 * level),
            vertices: 0,
            status: status.into(),
            solved: status == "Optimal",
            iterations: 1,
            area,
            observed_order: None,
            extrapolated_area: None,
        }
    }

    #[test]
    fn second_order_areas_are_extrapolated_exactly() {
        // A(h) = 3 + 0.4 h² + 0.1 h⁴ at h = 1, 1/2, 1/4, 1/8.
        let a = |h: f64| 3.0 + 0.4 * h * h + 0.1 * h.powi(4);
        let levels = (0..4).map(|k| level(k + 1, a(0.5f64.powi(k as i32)), "Optimal"));
        let study = assess(levels.collect(), 2.0);
        assert!(study.converging, "{}", study.verdict);
        let p = study.observed_order.unwrap();
        assert!((p - 2.0).abs() < 0.1, "{p}");
        // The h² term cancels; the h⁴ term leaves 0.1·h⁴ + (0.1·h⁴ − 1.6·h⁴)/3 = −0.4·h⁴.
        let extrapolated = study.extrapolated_area.unwrap();
        let h4 = 0.125f64.powi(4);
        assert!(
            (extrapolated - (3.0 - 0.4 * h4)).abs() < 1e-12,
            "{extrapolated}"
        );
    }

    #[test]
    fn stagnating_or_failing_studies_are_not_converging() {
        // Differences that halve (first order) are below the expected second order.
        let first = (0..4).map(|k| level(k + 1, 3.0 + 0.5f64.powi(k as i32), "Optimal"));
        let study = assess(first.collect(), 2.0);
        assert!(!study.converging);
        assert!(study.verdict.contains("observed 1.00"), "{}", study.verdict);
        // Differences that change sign.
        let wobbly = [3.0, 2.9, 2.95, 2.92].iter().enumerate();
        let study = assess(
            wobbly.map(|(k, &a)| level(k + 1, a, "Optimal")).collect(),
            2.0,
        );
        assert!(!study.converging && study.observed_order.is_none());
        // A level that stalls.
        let stalled = assess(
            vec![level(1, 3.0, "Optimal"), level(2, 2.9, "Stalled")],
            2.0,
        );
        assert!(!stalled.converging);
        assert!(stalled.verdict.contains("level 2 ended Stalled"));
        assert!(table(&stalled).last().unwrap().contains("warning"));
    }
}
