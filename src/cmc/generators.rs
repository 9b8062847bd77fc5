//! Start shapes with a resolution parameter (seed §5.3.2: the start needs the topology of the
//! answer, not its geometry). Lengths in metres, y up.
//!
//! Building blocks: an icosphere; a "fan disk" (a polygon split into triangles around a centre
//! point, each split regularly into `levels²` triangles, so ring k holds `sides·k` vertices); a
//! Coons grid patch bounded by four vertex paths. Patches share boundary vertices, which is how
//! films meet along wires and junction lines.
//!
//! Shapes:
//! - [`icosphere`]: sphere, outward normals.
//! - [`double_bubble`]: the standard double bubble of two given volumes: three spherical caps on
//!   one junction circle, meeting at 120° (the exact minimizer, so its analytic area is known).
//! - [`triple_bubble`]: the symmetric standard triple bubble of the total volume (three lunes
//!   on spheres and three flat walls meeting on the axis, all at 120°).
//! - [`cube_frame`]: a wire cube (fixed edges) with a central cubical bubble joined to every wire
//!   by a trapezoidal film (seed Fig. 5.8).
//! - octahedral frames: see [`super::octahedron`].
//! - [`u_wires`]: two U-shaped wires meeting at their tips, spanned by one film (seed Fig. 5.3).
//! - [`tents`]: membranes over boundary polygons with fixed rims; poles lift small caps of
//!   vertices (never one point, which has no well-posed minimum).
//! - [`cells`]: pneumatic cells: domes over ground footprints, rims fixed on y = 0.

use std::collections::BTreeMap;
use std::f64::consts::PI;

use super::mesh::{Mesh, MeshBuilder, MeshError, Point};
use super::volume::Region;

/// A generated mesh with the regions whose volumes the shape constrains.
#[derive(Debug, Clone)]
pub struct Shape {
    /// The mesh.
    pub mesh: Mesh,
    /// Regions with their target volumes (m³).
    pub volumes: Vec<(String, Region, f64)>,
}

/// An icosphere of radius `radius` (m), subdivided `level` times (20·4^level triangles).
pub fn icosphere(radius: f64, level: usize, name: &str) -> Result<Mesh, MeshError> {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut pos: Vec<Point> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Point::new(x, y, z).normalize())
    .collect();
    let mut tris: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid: BTreeMap<(usize, usize), usize> = BTreeMap::new();
        let mut midpoint = |a: usize, b: usize, pos: &mut Vec<Point>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                pos.push(((pos[a] + pos[b]) / 2.0).normalize());
                pos.len() - 1
            })
        };
        let mut next = Vec::with_capacity(tris.len() * 4);
        for [a, b, c] in tris {
            let ab = midpoint(a, b, &mut pos);
            let bc = midpoint(b, c, &mut pos);
            let ca = midpoint(c, a, &mut pos);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    let mut b = MeshBuilder::new();
    let s = b.surface(name);
    for p in pos {
        b.vertex(p * radius);
    }
    for tri in tris {
        b.triangle(s, tri);
    }
    b.build()
}

/// The triangles of a fan disk over a polygon of `sides` corners with `levels` rings, in terms of
/// `(ring k, index g)` vertex keys; ring k has `sides·k` vertices (ring 0: the centre), index 0
/// at polygon corner 0, counter-clockwise in the polygon's plane.
fn fan_disk(sides: usize, levels: usize) -> Vec<[(usize, usize); 3]> {
    let key = |k: usize, g: usize| if k == 0 { (0, 0) } else { (k, g % (sides * k)) };
    let mut tris = Vec::new();
    for p in 0..sides {
        for k in 0..levels {
            for j in 0..=k {
                tris.push([
                    key(k, p * k + j),
                    key(k + 1, p * (k + 1) + j),
                    key(k + 1, p * (k + 1) + j + 1),
                ]);
                if j < k {
                    tris.push([
                        key(k, p * k + j),
                        key(k + 1, p * (k + 1) + j + 1),
                        key(k, p * k + j + 1),
                    ]);
                }
            }
        }
    }
    tris
}

/// Position parameter of fan-disk vertex `(k, g)`: radial fraction `k/levels` and the polygon
/// side `p` with the fraction `f` along it.
fn fan_coords(sides: usize, levels: usize, k: usize, g: usize) -> (f64, usize, f64) {
    if k == 0 {
        return (0.0, 0, 0.0);
    }
    let (p, j) = (g / k % sides, g % k);
    (k as f64 / levels as f64, p, j as f64 / k as f64)
}

/// Adds a fan disk to surface `s`: `rim` (if given) supplies the `sides·levels` rim vertices,
/// `place(ρ, side, fraction)` positions the others. Triangles are flipped so that the first
/// one's normal agrees with `up`. Returns the rim vertices.
fn add_fan_disk(
    b: &mut MeshBuilder,
    s: usize,
    sides: usize,
    levels: usize,
    rim: Option<&[usize]>,
    place: impl Fn(f64, usize, f64) -> Point,
    up: Point,
) -> Vec<usize> {
    // The vertex of fan-disk key (k, g) (g < sides·k on level k ≥ 1), levels in order.
    let slot = |k: usize, g: usize| {
        if k == 0 {
            0
        } else {
            1 + sides * k * (k - 1) / 2 + g
        }
    };
    let mut ids: Vec<Option<usize>> = vec![None; slot(levels + 1, 0)];
    if let Some(rim) = rim {
        for (g, &v) in rim.iter().enumerate() {
            ids[slot(levels, g)] = Some(v);
        }
    }
    let tris: Vec<[usize; 3]> = fan_disk(sides, levels)
        .into_iter()
        .map(|tri| {
            tri.map(|(k, g)| {
                *ids[slot(k, g)].get_or_insert_with(|| {
                    let (rho, p, f) = fan_coords(sides, levels, k, g);
                    b.vertex(place(rho, p, f))
                })
            })
        })
        .collect();
    add_oriented(b, s, tris, up);
    (0..sides * levels)
        .map(|g| ids[slot(levels, g)].expect("every rim vertex is a fan-disk corner"))
        .collect()
}

/// Adds triangles to surface `s`, all flipped if the first one's normal disagrees with `up`.
fn add_oriented(b: &mut MeshBuilder, s: usize, tris: Vec<[usize; 3]>, up: Point) {
    let flip = tris.first().is_some_and(|t| {
        let p = t.map(|v| b.position(v));
        (p[1] - p[0]).cross(&(p[2] - p[0])).dot(&up) < 0.0
    });
    for [a, c, d] in tris {
        b.triangle(s, if flip { [a, d, c] } else { [a, c, d] });
    }
}

/// A Coons grid patch bounded by four vertex paths: `bottom` from corner 00 to 10, `top` from
/// 01 to 11 (same length), `left` from 00 to 01, `right` from 10 to 11 (same length). Interior
/// vertices are free, at the Coons point plus `offset(u, v)`. Orientation as in
/// [`add_oriented`], or along `∂/∂u × ∂/∂v` when `up` is `None`.
#[allow(clippy::too_many_arguments)]
fn add_grid_patch(
    b: &mut MeshBuilder,
    s: usize,
    bottom: &[usize],
    top: &[usize],
    left: &[usize],
    right: &[usize],
    up: Option<Point>,
    offset: impl Fn(f64, f64) -> Point,
) {
    let (n, m) = (bottom.len() - 1, left.len() - 1);
    let pos = |b: &MeshBuilder, v: usize| b.position(v);
    let (p00, p10, p01, p11) = (
        pos(b, bottom[0]),
        pos(b, bottom[n]),
        pos(b, top[0]),
        pos(b, top[n]),
    );
    let mut grid = vec![vec![0usize; m + 1]; n + 1];
    for i in 0..=n {
        for j in 0..=m {
            grid[i][j] = if j == 0 {
                bottom[i]
            } else if j == m {
                top[i]
            } else if i == 0 {
                left[j]
            } else if i == n {
                right[j]
            } else {
                let (u, v) = (i as f64 / n as f64, j as f64 / m as f64);
                let p = (1.0 - v) * pos(b, bottom[i])
                    + v * pos(b, top[i])
                    + (1.0 - u) * pos(b, left[j])
                    + u * pos(b, right[j])
                    - ((1.0 - u) * (1.0 - v) * p00
                        + u * (1.0 - v) * p10
                        + (1.0 - u) * v * p01
                        + u * v * p11);
                b.vertex(p + offset(u, v))
            };
        }
    }
    let mut tris = Vec::with_capacity(2 * n * m);
    for i in 0..n {
        for j in 0..m {
            let (a, c, d, e) = (
                grid[i][j],
                grid[i + 1][j],
                grid[i + 1][j + 1],
                grid[i][j + 1],
            );
            // Alternate the diagonal so the grid has no preferred direction.
            if (i + j) % 2 == 0 {
                tris.push([a, c, d]);
                tris.push([a, d, e]);
            } else {
                tris.push([a, c, e]);
                tris.push([c, d, e]);
            }
        }
    }
    match up {
        Some(up) => add_oriented(b, s, tris, up),
        None => {
            for t in tris {
                b.triangle(s, t);
            }
        }
    }
}

/// A straight path of `count` segments between two existing vertices; the `count − 1` new
/// vertices between them are fixed or free.
pub(super) fn add_path(
    b: &mut MeshBuilder,
    ends: (usize, usize),
    count: usize,
    fixed: bool,
) -> Vec<usize> {
    let (pa, pb) = (b.position(ends.0), b.position(ends.1));
    let mut path = vec![ends.0];
    for i in 1..count {
        let p = pa + (pb - pa) * (i as f64 / count as f64);
        path.push(if fixed { b.fixed(p) } else { b.vertex(p) });
    }
    path.push(ends.1);
    path
}

/// Volume of a spherical segment with rim radius `a` and height `h` (m³).
fn segment_volume(a: f64, h: f64) -> f64 {
    PI * h.abs() * (3.0 * a * a + h * h) / 6.0
}

/// Height along the axis from the junction plane to the apex of the spherical cap that leaves
/// a junction circle of radius `a` with meridian tangent `t = (axial, radial)`.
fn cap_height(a: f64, t: (f64, f64)) -> f64 {
    if t.0.abs() < 1e-15 {
        return 0.0;
    }
    let c = a * t.1 / t.0;
    c + (c * c + a * a).sqrt() * t.0.signum()
}

/// The standard double bubble's three cap heights `(left, wall, right)` for rim radius `a` and
/// wall tilt `beta` (rad): the films leave the junction circle at 120° to each other.
fn double_bubble_heights(a: f64, beta: f64) -> (f64, f64, f64) {
    let rotate = |(x, y): (f64, f64), ang: f64| {
        (x * ang.cos() - y * ang.sin(), x * ang.sin() + y * ang.cos())
    };
    let wall = (beta.sin(), -beta.cos());
    let right = rotate(wall, 2.0 * PI / 3.0);
    let left = rotate(wall, -2.0 * PI / 3.0);
    (
        cap_height(a, left),
        cap_height(a, wall),
        cap_height(a, right),
    )
}

/// Volumes `(left, right)` of the standard double bubble with rim radius `a`, wall tilt `beta`.
fn double_bubble_volumes(a: f64, beta: f64) -> (f64, f64) {
    let (hl, hw, hr) = double_bubble_heights(a, beta);
    let wall = hw.signum() * segment_volume(a, hw);
    (segment_volume(a, hl) + wall, segment_volume(a, hr) - wall)
}

/// The exact standard double bubble for volumes `v_left ≤ v_right` (m³): rim radius, wall
/// tilt, and the total area of the three caps (m²).
pub fn standard_double_bubble(v_left: f64, v_right: f64) -> (f64, f64, f64) {
    let ratio = v_right / v_left;
    let (mut lo, mut hi) = (0.0, PI / 3.0 - 1e-9);
    // Bisection until a step leaves the bracket as it was (adjacent floats: every later step
    // would repeat it), at most 200 steps.
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        let (l, r) = double_bubble_volumes(1.0, mid);
        let before = (lo, hi);
        if r / l < ratio {
            lo = mid;
        } else {
            hi = mid;
        }
        if (lo, hi) == before {
            break;
        }
    }
    let beta = 0.5 * (lo + hi);
    let a = (v_left / double_bubble_volumes(1.0, beta).0).cbrt();
    let (hl, hw, hr) = double_bubble_heights(a, beta);
    let area = [hl, hw, hr].iter().map(|h| PI * (a * a + h * h)).sum();
    (a, beta, area)
}

/// Adds a spherical cap (or a flat disk when `h = 0`) bounded by the junction circle `rim`
/// (radius `a` around the x axis at x = 0), with apex at x = `h`; normals along `up` at the apex.
fn add_cap(
    b: &mut MeshBuilder,
    s: usize,
    levels: usize,
    rim: &[usize],
    (a, h): (f64, f64),
    up: Point,
) {
    let sides = 6;
    let place = move |rho: f64, p: usize, f: f64| {
        let phi = 2.0 * PI * (p as f64 + f) / sides as f64;
        let radial = Point::new(0.0, phi.cos(), phi.sin());
        if h == 0.0 {
            return radial * (rho * a);
        }
        let r = (a * a + h * h) / (2.0 * h.abs());
        let theta = rho * (1.0 - h.abs() / r).clamp(-1.0, 1.0).acos();
        let centre = Point::new(h - h.signum() * r, 0.0, 0.0);
        centre + r * (theta.cos() * h.signum() * Point::x() + theta.sin() * radial)
    };
    add_fan_disk(b, s, sides, levels, Some(rim), place, up);
}

/// The standard double bubble of volumes `volumes` (m³) with `6·levels` vertices on the
/// junction circle. Surfaces `left`, `wall`, `right`; the wall's normal points to +x. The
/// bubble with the larger volume is on the right.
pub fn double_bubble(volumes: [f64; 2], levels: usize) -> Result<Shape, MeshError> {
    let (small, large) = (volumes[0].min(volumes[1]), volumes[0].max(volumes[1]));
    let (a, beta, _) = standard_double_bubble(small, large);
    let (hl, hw, hr) = double_bubble_heights(a, beta);
    let mut b = MeshBuilder::new();
    let (left, wall, right) = (b.surface("left"), b.surface("wall"), b.surface("right"));
    let n = 6 * levels;
    let rim: Vec<usize> = (0..n)
        .map(|g| {
            let phi = 2.0 * PI * g as f64 / n as f64;
            b.vertex(Point::new(0.0, a * phi.cos(), a * phi.sin()))
        })
        .collect();
    add_cap(&mut b, left, levels, &rim, (a, hl), -Point::x());
    add_cap(&mut b, wall, levels, &rim, (a, hw), Point::x());
    add_cap(&mut b, right, levels, &rim, (a, hr), Point::x());
    let mesh = b.build()?;
    let region = |boundary| Region {
        boundary,
        reference: Point::zeros(),
    };
    Ok(Shape {
        mesh,
        volumes: vec![
            ("left".into(), region(vec![(left, 1.0), (wall, 1.0)]), small),
            (
                "right".into(),
                region(vec![(right, 1.0), (wall, -1.0)]),
                large,
            ),
        ],
    })
}

/// Three bubbles of volumes `volumes` (m³) started as the symmetric standard triple bubble of
/// their total volume (three equal cells about the y axis, every film meeting the others at
/// 120°), `2·levels` rows from pole to pole. Surfaces `outer_k` (outward) and `wall_k` (normal
/// towards increasing azimuth, i.e. into cell k). Each film is a digon between two junction
/// lines, triangulated as two subdivided triangles with apexes at the poles (`add_digon`;
/// the lunes, twice as wide as high, with two segments more per row, the walls with one):
/// `18·levels²` triangles.
///
/// Geometry, for outer radius R: cell k is the ball of radius R about `c_k = (R/√3)·d_k`
/// (`d_k` the unit direction at azimuth 120°k + 60°) cut by the two wall half-planes at
/// azimuths 120°k and 120°(k+1). A sphere whose centre is `R sin 60°/√3 = R/2` from a plane
/// meets it at 90° + asin(½) = 120° inside the cell, mirror cells share each wall's circle,
/// and the three spheres and the axis meet at the poles `y = ±R√(2/3)` (tetrahedral points).
/// The walls are flat (equal pressures). Lune vertices are the ball-wedge directions projected
/// from the origin (inside every cell's ball) onto their cell's sphere; wall vertices
/// interpolate between the axis and the wall's circle; the mesh is then scaled to the total
/// volume. Unequal volumes are reached by the optimization.
pub fn triple_bubble(volumes: [f64; 3], levels: usize) -> Result<Shape, MeshError> {
    let total: f64 = volumes.iter().sum();
    let rows = 2 * levels.max(1);
    let mut b = MeshBuilder::new();
    let pole = (2.0f64 / 3.0).sqrt();
    let north = b.vertex(Point::new(0.0, pole, 0.0));
    let south = b.vertex(Point::new(0.0, -pole, 0.0));
    let theta = |i: usize| PI * i as f64 / rows as f64;
    let dir = |phi: f64| Point::new(phi.cos(), 0.0, phi.sin());
    // Unit sphere about the centre of cell k, reached from the origin along the ball direction.
    let centre = |k: usize| dir(2.0 * PI * k as f64 / 3.0 + PI / 3.0) / 3f64.sqrt();
    let sphere = |i: usize, phi: f64, k: usize| {
        let u = theta(i).cos() * Point::y() + theta(i).sin() * dir(phi);
        let c = centre(k % 3);
        let uc = u.dot(&c);
        (uc + (uc * uc - c.norm_squared() + 1.0).sqrt()) * u
    };
    // Axis vertices evenly spaced (not at the meridians' heights), so the wall rows slant
    // and the fans at the poles are not slivers.
    let axis_point = |i: usize| Point::new(0.0, pole * (1.0 - 2.0 * i as f64 / rows as f64), 0.0);
    let axis: Vec<usize> = (1..rows).map(|i| b.vertex(axis_point(i))).collect();
    let meridians: Vec<Vec<usize>> = (0..3)
        .map(|k| {
            let phi = 2.0 * PI * k as f64 / 3.0;
            (1..rows).map(|i| b.vertex(sphere(i, phi, k))).collect()
        })
        .collect();
    // Full pole-to-pole column of vertex ids for a row-indexed path.
    let column = |inner: &[usize]| {
        let mut c = vec![north];
        c.extend_from_slice(inner);
        c.push(south);
        c
    };
    let mut regions = Vec::new();
    let outer: Vec<usize> = (0..3).map(|k| b.surface(&format!("outer_{k}"))).collect();
    let walls: Vec<usize> = (0..3).map(|k| b.surface(&format!("wall_{k}"))).collect();
    for k in 0..3 {
        // Lune k between meridians k and k+1.
        let phi0 = 2.0 * PI * k as f64 / 3.0;
        let (left, right) = (column(&meridians[k]), column(&meridians[(k + 1) % 3]));
        let lune = |i: usize, f: f64| sphere(i, phi0 + 2.0 * PI / 3.0 * f, k);
        add_digon(
            &mut b,
            outer[k],
            (&left, &right),
            (lune, 2),
            dir(phi0 + PI / 3.0),
        );
        // Wall k at azimuth phi0 between the axis and meridian k.
        let wall = |i: usize, f: f64| axis_point(i) * (1.0 - f) + sphere(i, phi0, k) * f;
        let normal = Point::new(-phi0.sin(), 0.0, phi0.cos());
        add_digon(&mut b, walls[k], (&column(&axis), &left), (wall, 1), normal);
    }
    let mut mesh = b.build()?;
    for k in 0..3 {
        regions.push((
            format!("cell_{k}"),
            Region {
                boundary: vec![(outer[k], 1.0), (walls[k], -1.0), (walls[(k + 1) % 3], 1.0)],
                reference: Point::zeros(),
            },
            volumes[k],
        ));
    }
    let unit: f64 = regions.iter().map(|(_, r, _)| r.volume(&mesh)).sum();
    let scale = (total / unit).cbrt();
    let scaled = mesh.positions().iter().map(|p| p * scale).collect();
    mesh.set_positions(scaled)?;
    Ok(Shape {
        mesh,
        volumes: regions,
    })
}

/// Triangulates the digon between two pole-to-pole vertex paths (`left` and `right`, the same
/// north and south pole, `2L + 1` vertices each) as two subdivided triangles with their apexes
/// at the poles, meeting on the middle row: row `i` (0 at the north pole) has
/// `growth·min(i, 2L − i)` segments, its interior vertices at `inner(i, f)`, `f` the fraction
/// of the way from `left` to `right`; consecutive rows are zipped into triangles by those
/// fractions ([`zip_rows`]). Each pole gets `growth` triangles of the digon, which share its
/// angle there. Oriented along `up` (tested on a triangle next to the middle row).
///
/// Why not a grid of `L` columns with fans at the poles: at the triple bubble's poles, where
/// four junction lines meet, such fans are `L` triangles of ~109°/L each, and from resolution
/// 10 on the solves collapsed them (0.0–0.8° triangles, one ending Degenerate at 11, one at
/// the iteration limit at 13; docs/notes/cmc.md).
fn add_digon(
    b: &mut MeshBuilder,
    s: usize,
    (left, right): (&[usize], &[usize]),
    (inner, growth): (impl Fn(usize, f64) -> Point, usize),
    up: Point,
) {
    let rows = left.len() - 1;
    let row = |b: &mut MeshBuilder, i: usize| -> Vec<usize> {
        let segments = growth * i.min(rows - i);
        if segments == 0 {
            return vec![left[i]];
        }
        let mut r = vec![left[i]];
        r.extend((1..segments).map(|j| b.vertex(inner(i, j as f64 / segments as f64))));
        r.push(right[i]);
        r
    };
    let grid: Vec<Vec<usize>> = (0..=rows).map(|i| row(b, i)).collect();
    // The strip above the middle row first, a triangle from its middle at the front: the
    // orientation test then sees a triangle away from the junction lines, where the lunes'
    // normals are square to `up`.
    let middle = rows / 2 - 1;
    let mut tris = zip_rows(&grid[middle], &grid[middle + 1]);
    let centre = tris.len() / 2;
    tris.swap(0, centre);
    for i in (0..rows).filter(|&i| i != middle) {
        tris.extend(zip_rows(&grid[i], &grid[i + 1]));
    }
    add_oriented(b, s, tris, up);
}

/// The triangles between two rows of vertices `a` and `c` that run the same way (each at
/// fractions `j / segments` along its row): advancing along whichever row's next vertex comes
/// first (`c` on ties), every triangle `[a_i, c_j, ·]` with the same orientation. Equal
/// counts give a quad grid cut by diagonals; counts differing by one, the rows of a regularly
/// subdivided triangle.
fn zip_rows(a: &[usize], c: &[usize]) -> Vec<[usize; 3]> {
    let (m, n) = (a.len() - 1, c.len() - 1);
    let fraction = |j: usize, segments: usize| {
        if segments == 0 {
            0.0
        } else {
            j as f64 / segments as f64
        }
    };
    let (mut i, mut j) = (0, 0);
    let mut tris = Vec::with_capacity(m + n);
    while i < m || j < n {
        if j < n && (i == m || fraction(j + 1, n) <= fraction(i + 1, m)) {
            tris.push([a[i], c[j], c[j + 1]]);
            j += 1;
        } else {
            tris.push([a[i], c[j], a[i + 1]]);
            i += 1;
        }
    }
    tris
}

/// A wire cube of edge `edge` (m, centred at the origin, fixed wires), `levels` segments along
/// each wire. With `Some(bubble_volume)` (m³) it holds a central cubical bubble joined to each
/// wire by a trapezoidal film (seed Fig. 5.8); surfaces `films` and `bubble` (outward). With
/// `None` it is the bubble-free cube film: the inner cube flattened along z into a central square
/// (side 0.3·edge) joined by trapezoids to the eight horizontal wires and by triangles to the
/// four vertical ones (the stable film a wire cube holds); one surface `films`.
pub fn cube_frame(
    edge: f64,
    bubble_volume: Option<f64>,
    levels: usize,
) -> Result<Shape, MeshError> {
    let n = levels.max(1);
    let inner = bubble_volume.map_or(0.3 * edge, f64::cbrt);
    let flat = bubble_volume.is_none();
    let mut b = MeshBuilder::new();
    let films = b.surface("films");
    let bubble = if flat {
        None
    } else {
        Some(b.surface("bubble"))
    };
    let corner = |i: usize, size: f64| {
        Point::new(
            (i & 1) as f64 - 0.5,
            ((i >> 1) & 1) as f64 - 0.5,
            ((i >> 2) & 1) as f64 - 0.5,
        ) * size
    };
    let outer_c: Vec<usize> = (0..8).map(|i| b.fixed(corner(i, edge))).collect();
    // Flattened: corners i and i|4 share the square corner at z = 0.
    let mut inner_c: Vec<usize> = Vec::with_capacity(8);
    for i in 0..8 {
        let v = if flat && i & 4 != 0 {
            inner_c[i & 3]
        } else {
            let mut p = corner(i, inner);
            if flat {
                p.z = 0.0;
            }
            b.vertex(p)
        };
        inner_c.push(v);
    }
    let diagonal_segments = if flat {
        n
    } else {
        ((edge - inner) / 2.0 * 3f64.sqrt() / (inner / n as f64))
            .round()
            .clamp(1.0, n as f64) as usize
    };
    let diagonals: Vec<Vec<usize>> = (0..8)
        .map(|i| add_path(&mut b, (outer_c[i], inner_c[i]), diagonal_segments, false))
        .collect();
    let mut outer_e = BTreeMap::new();
    let mut inner_e = BTreeMap::new();
    for i in 0..8 {
        for bit in [1, 2, 4] {
            if i & bit == 0 {
                let j = i | bit;
                outer_e.insert((i, j), add_path(&mut b, (outer_c[i], outer_c[j]), n, true));
                if !(flat && bit == 4) {
                    let path = match inner_e.get(&(i & 3, j & 3)) {
                        Some(p) if flat => Vec::clone(p),
                        _ => add_path(&mut b, (inner_c[i], inner_c[j]), n, false),
                    };
                    inner_e.insert((i, j), path);
                }
            }
        }
    }
    for (&(i, j), wire) in &outer_e {
        match inner_e.get(&(i, j)) {
            Some(inner_path) => add_grid_patch(
                &mut b,
                films,
                wire,
                inner_path,
                &diagonals[i],
                &diagonals[j],
                None,
                |_, _| Point::zeros(),
            ),
            None => {
                // A vertical wire of the flattened cube: a triangle to the square's corner.
                let apex_to = |d: &Vec<usize>| d.iter().rev().copied().collect::<Vec<_>>();
                add_triangle_patch(
                    &mut b,
                    films,
                    &apex_to(&diagonals[i]),
                    &apex_to(&diagonals[j]),
                    wire,
                );
            }
        }
    }
    // Bubble faces (or the central square): for each axis bit and side, corners base,
    // base+u, base+v, base+u+v.
    for bit in [1usize, 2, 4] {
        let others: Vec<usize> = [1usize, 2, 4].into_iter().filter(|&o| o != bit).collect();
        let (u, v) = (others[0], others[1]);
        for side in [0, bit] {
            let normal = if side == 0 {
                -axis_vector(bit)
            } else {
                axis_vector(bit)
            };
            let surface = match bubble {
                Some(s) => s,
                None if bit == 4 && side == 0 => films,
                None => continue,
            };
            let base = side;
            add_grid_patch(
                &mut b,
                surface,
                &inner_e[&(base, base | u)],
                &inner_e[&(base | v, base | u | v)],
                &inner_e[&(base, base | v)],
                &inner_e[&(base | u, base | u | v)],
                Some(normal),
                |_, _| Point::zeros(),
            );
        }
    }
    let mesh = b.build()?;
    let volumes = match (bubble, bubble_volume) {
        (Some(s), Some(v)) => vec![(
            "bubble".into(),
            Region {
                boundary: vec![(s, 1.0)],
                reference: Point::zeros(),
            },
            v,
        )],
        _ => Vec::new(),
    };
    Ok(Shape { mesh, volumes })
}

fn axis_vector(bit: usize) -> Point {
    match bit {
        1 => Point::x(),
        2 => Point::y(),
        _ => Point::z(),
    }
}

/// A triangular patch with corner paths `side_a` (apex → A), `side_b` (apex → B) and `base`
/// (A → B), all with `n` segments: rows parallel to the base, row r holding r + 1 vertices.
pub(super) fn add_triangle_patch(
    b: &mut MeshBuilder,
    s: usize,
    side_a: &[usize],
    side_b: &[usize],
    base: &[usize],
) {
    let n = base.len() - 1;
    let mut rows: Vec<Vec<usize>> = vec![vec![side_a[0]]];
    for r in 1..=n {
        if r == n {
            rows.push(base.to_vec());
            continue;
        }
        let (pa, pb) = (b.position(side_a[r]), b.position(side_b[r]));
        let mut row = vec![side_a[r]];
        for c in 1..r {
            row.push(b.vertex(pa + (pb - pa) * (c as f64 / r as f64)));
        }
        row.push(side_b[r]);
        rows.push(row);
    }
    for r in 0..n {
        for c in 0..=r {
            b.triangle(s, [rows[r][c], rows[r + 1][c], rows[r + 1][c + 1]]);
            if c < r {
                b.triangle(s, [rows[r][c], rows[r + 1][c + 1], rows[r][c + 1]]);
            }
        }
    }
}

/// Two U-shaped wires joined at their tips (m): U1 in the plane z = 0 hangs down by `depth`,
/// U2 in the plane y = 0 reaches out by `depth`, both `width` wide. One film `film` spans the
/// closed loop; `levels` segments across the width.
pub fn u_wires(width: f64, depth: f64, levels: usize) -> Result<Shape, MeshError> {
    let n = levels.max(1);
    let m = 2 * (((depth / width) * n as f64 / 2.0).round() as usize).max(1);
    let a = width / 2.0;
    let mut b = MeshBuilder::new();
    let film = b.surface("film");
    let c = [
        b.fixed(Point::new(-a, -depth, 0.0)),
        b.fixed(Point::new(a, -depth, 0.0)),
        b.fixed(Point::new(-a, 0.0, depth)),
        b.fixed(Point::new(a, 0.0, depth)),
        b.fixed(Point::new(-a, 0.0, 0.0)),
        b.fixed(Point::new(a, 0.0, 0.0)),
    ];
    let bottom = add_path(&mut b, (c[0], c[1]), n, true);
    let top = add_path(&mut b, (c[2], c[3]), n, true);
    let leg = |b: &mut MeshBuilder, from: usize, tip: usize, to: usize| {
        let mut p = add_path(b, (from, tip), m / 2, true);
        p.pop();
        p.extend(add_path(b, (tip, to), m / 2, true));
        p
    };
    let left = leg(&mut b, c[0], c[4], c[2]);
    let right = leg(&mut b, c[1], c[5], c[3]);
    add_grid_patch(&mut b, film, &bottom, &top, &left, &right, None, |_, _| {
        Point::zeros()
    });
    // The grid patch of two straight wires and two L-shaped legs is the L extruded along x: a
    // 90° crease between the tips, where the discrete curvature grows like 1/h. The harmonic
    // interpolation of the wires removes it.
    let mesh = b.build()?;
    let mut pos = mesh.positions().to_vec();
    harmonic(&mesh, &mut pos, &[0, 1, 2]);
    let mut mesh = mesh;
    mesh.set_positions(pos)?;
    Ok(Shape {
        mesh,
        volumes: Vec::new(),
    })
}

/// A tent pole: lifts the vertices within `radius` (horizontal distance, m) of `(x, z)` to
/// `height` (m) and fixes them; at least the nearest vertex and its 1-ring are lifted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pole {
    /// Horizontal position (x, z), m.
    pub at: [f64; 2],
    /// Height of the lifted cap, m.
    pub height: f64,
    /// Radius of the lifted cap, m.
    pub radius: f64,
}

/// A membrane over a polygon.
#[derive(Debug, Clone, PartialEq)]
pub struct TentSpec {
    /// Surface name.
    pub name: String,
    /// Rim corners (x, y, z), m, counter-clockwise seen from above; the rim is fixed.
    pub boundary: Vec<Point>,
    /// Poles.
    pub poles: Vec<Pole>,
}

/// Membranes over polygons (one surface each) with fixed rims and pole caps; `levels` rings from
/// the polygon's centroid to its rim. Normals point up.
pub fn tents(specs: &[TentSpec], levels: usize) -> Result<Shape, MeshError> {
    let levels = levels.max(1);
    let mut b = MeshBuilder::new();
    let mut patches = Vec::new();
    for spec in specs {
        let s = b.surface(&spec.name);
        let first = b.vertex_count();
        add_outline_patch(&mut b, s, &spec.boundary, levels, |r| r, |_| Point::zeros());
        patches.push((first, b.vertex_count()));
    }
    let mut mesh = b.build()?;
    mesh.fix_boundary();
    let mut pos = mesh.positions().to_vec();
    for (spec, &(first, last)) in specs.iter().zip(&patches) {
        for pole in &spec.poles {
            let distances: Vec<f64> = pos
                .iter()
                .map(|p| ((p.x - pole.at[0]).powi(2) + (p.z - pole.at[1]).powi(2)).sqrt())
                .collect();
            let horizontal = |v: usize| distances[v];
            let nearest = (first..last)
                .min_by(|&u, &v| horizontal(u).total_cmp(&horizontal(v)))
                .unwrap_or(first);
            let mut cap: Vec<usize> = (first..last)
                .filter(|&v| horizontal(v) <= pole.radius)
                .collect();
            if cap.len() < 2 {
                cap = vec![nearest];
                cap.extend_from_slice(mesh.neighbours(nearest));
            }
            for v in cap {
                pos[v].y = pole.height;
                let mut f = mesh.flags()[v];
                f.fixed = true;
                mesh.set_flags(v, f)?;
            }
        }
    }
    harmonic(&mesh, &mut pos, &[1]);
    mesh.set_positions(pos)?;
    Ok(Shape {
        mesh,
        volumes: Vec::new(),
    })
}

/// Sets the `axes` coordinates (0 = x, 1 = y, 2 = z) of the free vertices to the discrete
/// harmonic interpolation (uniform weights) of the fixed ones, by over-relaxed Gauss–Seidel
/// sweeps: a smooth start close to a minimal surface, without folds at pole caps or creases.
fn harmonic(mesh: &Mesh, pos: &mut [Point], axes: &[usize]) {
    let free: Vec<usize> = (0..mesh.vertex_count())
        .filter(|&v| !mesh.flags()[v].fixed)
        .collect();
    for &k in axes {
        let (lo, hi) = pos
            .iter()
            .fold((f64::MAX, f64::MIN), |(l, h), p| (l.min(p[k]), h.max(p[k])));
        let tolerance = 1e-9 * (hi - lo).max(1e-300);
        for _ in 0..20_000 {
            let mut change: f64 = 0.0;
            for &v in &free {
                let ring = mesh.neighbours(v);
                let mean = ring.iter().map(|&w| pos[w][k]).sum::<f64>() / ring.len() as f64;
                let step = 1.8 * (mean - pos[v][k]);
                pos[v][k] += step;
                change = change.max(step.abs());
            }
            if change < tolerance {
                break;
            }
        }
    }
}

/// Adds a patch spanning `boundary` (a polygon, counter-clockwise seen from above) to surface
/// `s`, normals up: a Coons grid with near-square cells for quadrilaterals (elongated shapes
/// stay well shaped), a fan disk around the centroid otherwise. Interior points are the linear
/// interpolation of the rim plus `lift(crown)`, where `crown` is 1 at the middle and 0 on the
/// rim (`1 − ρ²` on fan disks, `(1 − (2u−1)²)(1 − (2v−1)²)` on grids). On fan disks ring k
/// sits at the fraction `radial(k/levels)` of the way from the centroid to the rim (`ρ` above
/// is that fraction), so rings can follow a steep crown evenly; grids ignore `radial`.
fn add_outline_patch(
    b: &mut MeshBuilder,
    s: usize,
    boundary: &[Point],
    levels: usize,
    radial: impl Fn(f64) -> f64,
    lift: impl Fn(f64) -> Point,
) {
    let sides = boundary.len();
    if sides == 4 {
        let corners: Vec<usize> = boundary.iter().map(|&p| b.vertex(p)).collect();
        let len = |i: usize, j: usize| (boundary[i] - boundary[j]).norm();
        let (u_len, v_len) = ((len(0, 1) + len(3, 2)) / 2.0, (len(1, 2) + len(0, 3)) / 2.0);
        let short = u_len.min(v_len);
        let count = |l: f64| ((levels as f64 * l / short).round() as usize).max(1);
        let (nu, nv) = (count(u_len), count(v_len));
        let bottom = add_path(b, (corners[0], corners[1]), nu, false);
        let top = add_path(b, (corners[3], corners[2]), nu, false);
        let left = add_path(b, (corners[0], corners[3]), nv, false);
        let right = add_path(b, (corners[1], corners[2]), nv, false);
        add_grid_patch(
            b,
            s,
            &bottom,
            &top,
            &left,
            &right,
            Some(Point::y()),
            |u, v| lift((1.0 - (2.0 * u - 1.0).powi(2)) * (1.0 - (2.0 * v - 1.0).powi(2))),
        );
        return;
    }
    let centre = boundary.iter().sum::<Point>() / sides as f64;
    if sides > RING_DISK_SECTORS {
        // Fan sectors of 360°/sides would give slivers: six sectors, rim on the polygon.
        let start = (centre.z - boundary[0].z).atan2(boundary[0].x - centre.x);
        let place = |rho: f64, p: usize, f: f64| {
            let angle = start + 2.0 * PI * (p as f64 + f) / RING_DISK_SECTORS as f64;
            let rim = ray_to_polygon(boundary, &centre, angle);
            let rho = radial(rho);
            centre + (rim - centre) * rho + lift(1.0 - rho * rho)
        };
        add_fan_disk(b, s, RING_DISK_SECTORS, levels, None, place, Point::y());
        return;
    }
    let place = |rho: f64, p: usize, f: f64| {
        let rim = boundary[p] + (boundary[(p + 1) % sides] - boundary[p]) * f;
        let rho = radial(rho);
        centre + (rim - centre) * rho + lift(1.0 - rho * rho)
    };
    add_fan_disk(b, s, sides, levels, None, place, Point::y());
}

/// Sectors of the disk meshes over polygons of more corners: ring k of a six-sector fan disk
/// holds `6k` vertices at even angles, so its triangles are nearly equilateral.
const RING_DISK_SECTORS: usize = 6;

/// The point of polygon `boundary` (3-D corners, star-shaped about `centre` seen from above)
/// hit by the horizontal ray from `centre` at `angle` (rad, from +x towards −z, the
/// counter-clockwise sense seen from above); its height interpolates the hit edge's ends.
/// Non-finite if the ray misses (then the mesh builder reports the vertex).
fn ray_to_polygon(boundary: &[Point], centre: &Point, angle: f64) -> Point {
    let d = (angle.cos(), -angle.sin());
    let cross = |a: (f64, f64), b: (f64, f64)| a.0 * b.1 - a.1 * b.0;
    let mut best = (f64::INFINITY, Point::repeat(f64::NAN));
    for (i, p) in boundary.iter().enumerate() {
        let q = boundary[(i + 1) % boundary.len()];
        let e = (q.x - p.x, q.z - p.z);
        let w = (p.x - centre.x, p.z - centre.z);
        let denom = cross(d, e);
        if denom.abs() < 1e-300 {
            continue;
        }
        // centre + t·d = p + u·e.
        let t = cross(w, e) / denom;
        let u = cross(w, d) / denom;
        if t > 0.0 && (-1e-12..=1.0 + 1e-12).contains(&u) && t < best.0 {
            best = (t, p + (q - p) * u.clamp(0.0, 1.0));
        }
    }
    best.1
}

/// A pneumatic cell: a footprint polygon on the ground (x, z; m, counter-clockwise seen from
/// above), the start dome height (m) and the enclosed volume (m³).
#[derive(Debug, Clone, PartialEq)]
pub struct CellSpec {
    /// Surface name.
    pub name: String,
    /// Footprint corners (x, z), m.
    pub footprint: Vec<[f64; 2]>,
    /// Crown height of a paraboloid start dome, m; `None`: the start is inflated to `volume`
    /// (see [`cells`]).
    pub height: Option<f64>,
    /// Enclosed volume, m³.
    pub volume: f64,
}

/// Pneumatic cells: start domes over their footprints, rims fixed on the ground (y = 0), each
/// enclosing its own volume (reference point on the ground), normals outward.
///
/// With a given `height` the start is a paraboloid-like crown of that height. Without one it
/// is inflated to the target: the spherical cap over the disk of the footprint's area that
/// encloses `volume` (segment volume `πh(3a² + h²)/6 = V`, solved for the height h), its
/// heights then scaled so that the mesh encloses `volume` exactly (a vertical scaling by s
/// scales the enclosed volume by s, the base being on the reference plane y = 0). The solve
/// then starts volume-feasible and near constant curvature instead of pumping the cells up.
pub fn cells(specs: &[CellSpec], levels: usize) -> Result<Shape, MeshError> {
    let levels = levels.max(1);
    let mut b = MeshBuilder::new();
    let mut regions = Vec::new();
    let mut ranges = Vec::new();
    for spec in specs {
        let s = b.surface(&spec.name);
        let boundary: Vec<Point> = spec
            .footprint
            .iter()
            .map(|&[x, z]| Point::new(x, 0.0, z))
            .collect();
        let first = b.vertex_count();
        match spec.height {
            Some(height) => add_outline_patch(
                &mut b,
                s,
                &boundary,
                levels,
                |r| r,
                |crown| Point::y() * height * crown,
            ),
            None => {
                let radius = (polygon_area(&spec.footprint) / PI).sqrt();
                let cap = SphericalCap::with_volume(radius, spec.volume);
                add_outline_patch(
                    &mut b,
                    s,
                    &boundary,
                    levels,
                    |r| cap.even_rings(r),
                    |crown| Point::y() * cap.height_at(radius * (1.0 - crown).max(0.0).sqrt()),
                );
            }
        }
        ranges.push((first, b.vertex_count()));
        let centre = boundary.iter().sum::<Point>() / boundary.len() as f64;
        regions.push((
            spec.name.clone(),
            Region {
                boundary: vec![(s, 1.0)],
                reference: centre,
            },
            spec.volume,
        ));
    }
    let mut mesh = b.build()?;
    mesh.fix_boundary();
    let mut pos = mesh.positions().to_vec();
    for ((spec, &(first, last)), (_, region, target)) in specs.iter().zip(&ranges).zip(&regions) {
        if spec.height.is_none() {
            let factor = target / region.volume(&mesh);
            for p in &mut pos[first..last] {
                p.y *= factor;
            }
        }
    }
    mesh.set_positions(pos)?;
    Ok(Shape {
        mesh,
        volumes: regions,
    })
}

/// Area of a polygon in the (x, z) plane, m² (either orientation).
fn polygon_area(corners: &[[f64; 2]]) -> f64 {
    let n = corners.len();
    let twice: f64 = (0..n)
        .map(|i| {
            let (a, b) = (corners[i], corners[(i + 1) % n]);
            a[0] * b[1] - a[1] * b[0]
        })
        .sum();
    twice.abs() / 2.0
}

/// A spherical cap over a disk of radius `a` on the ground, crown height `h` (m).
#[derive(Debug, Clone, Copy, PartialEq)]
struct SphericalCap {
    a: f64,
    h: f64,
}

impl SphericalCap {
    /// The cap over radius `a` (m) enclosing `volume` (m³) with the ground: Newton on the
    /// increasing, convex `segment_volume(a, h) − V` from the paraboloid height `2V/(πa²)`, which
    /// lies above the root, so the iterates decrease monotonically onto it.
    fn with_volume(a: f64, volume: f64) -> SphericalCap {
        let mut h = 2.0 * volume / (PI * a * a);
        for _ in 0..100 {
            let step = (segment_volume(a, h) - volume) / (PI * (a * a + h * h) / 2.0);
            h -= step;
            if step.abs() <= 1e-14 * h {
                break;
            }
        }
        SphericalCap { a, h }
    }

    /// Sphere radius, m.
    fn radius(&self) -> f64 {
        (self.a * self.a + self.h * self.h) / (2.0 * self.h)
    }

    /// Horizontal distance (as a fraction of `a`) of the point a fraction `t` of the way along
    /// the meridian from the crown to the rim (up to the equator for caps beyond a hemisphere):
    /// rings at even `t` are evenly spaced on the surface, not only seen from above.
    fn even_rings(&self, t: f64) -> f64 {
        let end = self.a.atan2(self.radius() - self.h).min(PI / 2.0);
        self.radius() * (t * end).sin() / self.a
    }

    /// Height above the ground at horizontal distance `r ≤ a` from the axis, m.
    fn height_at(&self, r: f64) -> f64 {
        let radius = self.radius();
        (radius * radius - r * r).max(0.0).sqrt() - (radius - self.h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::area::{surface_areas, total_area};

    #[test]
    fn icosphere_counts_and_orientation() {
        let m = icosphere(1.0, 2, "s").unwrap();
        assert_eq!(m.vertex_count(), 162);
        assert_eq!(m.triangles().len(), 320);
        let r = Region {
            boundary: vec![(0, 1.0)],
            reference: Point::zeros(),
        };
        assert!(r.volume(&m) > 0.0);
    }

    #[test]
    fn standard_double_bubble_matches_the_known_areas() {
        // Equal volumes 1 and 1: 9.139421678; volumes 1 and 2: 11.854293128.
        let (_, beta, area) = standard_double_bubble(1.0, 1.0);
        assert!(beta.abs() < 1e-9);
        assert!((area - 9.139421678).abs() < 1e-8, "{area}");
        let (_, _, area) = standard_double_bubble(1.0, 2.0);
        assert!((area - 11.854293128).abs() < 1e-8, "{area}");
    }

    #[test]
    fn double_bubble_mesh_converges_to_the_exact_shape() {
        let exact = standard_double_bubble(1.0, 2.0).2;
        let mut errors = Vec::new();
        for levels in [4, 8, 16] {
            let shape = double_bubble([1.0, 2.0], levels).unwrap();
            let area = total_area(&shape.mesh);
            errors.push((exact - area) / exact);
            for (_, region, target) in &shape.volumes {
                let v = region.volume(&shape.mesh);
                assert!(v > 0.0 && (v / target - 1.0).abs() < 0.1, "{v} vs {target}");
            }
            assert_eq!(shape.mesh.junction_vertices().len(), 6 * levels);
        }
        // Inscribed meshes underestimate; the error falls about 4× per halving of the edge.
        assert!(errors.iter().all(|&e| e > 0.0), "{errors:?}");
        for w in errors.windows(2) {
            let rate = w[0] / w[1];
            assert!(rate > 3.0 && rate < 5.0, "{errors:?}");
        }
    }

    #[test]
    fn triple_bubble_starts_as_the_symmetric_standard_triple_bubble() {
        let shape = triple_bubble([1.0, 1.5, 2.0], 8).unwrap();
        let m = &shape.mesh;
        // Three equal cells (the mesh is symmetric under the 120° turn) of the total volume.
        let cells: Vec<f64> = shape.volumes.iter().map(|(_, r, _)| r.volume(m)).collect();
        for v in &cells {
            assert!((v - 1.5).abs() < 1e-9, "{cells:?}");
        }
        let ball = Region {
            boundary: (0..3).map(|k| (k, 1.0)).collect(),
            reference: Point::zeros(),
        };
        assert!((cells.iter().sum::<f64>() - ball.volume(m)).abs() < 1e-12);
        // Every lune vertex is on its cell's sphere: centre R/√3 from the axis, radius R, and
        // the poles at ±R√(2/3) (vertex 0 is the north pole).
        let pole = m.positions()[0].y;
        let radius = pole / (2.0f64 / 3.0).sqrt();
        for k in 0..3 {
            let phi = 2.0 * PI * k as f64 / 3.0 + PI / 3.0;
            let c = Point::new(phi.cos(), 0.0, phi.sin()) * radius / 3f64.sqrt();
            for t in m.surface_triangles(m.surface_index(&format!("outer_{k}")).unwrap()) {
                for p in m.corners(t) {
                    assert!(((p - c).norm() / radius - 1.0).abs() < 1e-12);
                }
            }
        }
        // The walls are flat half-disks in the planes through the axis.
        for k in 0..3 {
            let phi = 2.0 * PI * k as f64 / 3.0;
            let normal = Point::new(-phi.sin(), 0.0, phi.cos());
            for t in m.surface_triangles(m.surface_index(&format!("wall_{k}")).unwrap()) {
                for p in m.corners(t) {
                    assert!(p.dot(&normal).abs() < 1e-12 * radius);
                }
            }
        }
        // The films meet at 120°: the junction-angle estimator (the flat triangles next to
        // each junction edge) reads 112.2°–135.5° on this exact shape, its own discretization
        // error, largest at the poles, where the digons' triangles span a whole lune (the
        // pole-fan grid read 115.6°–124.0°); the old start (a ball cut into wedges) read
        // 90°–180°.
        let j = crate::cmc::figures::junction_angles(m).unwrap();
        assert!(j.min_deg > 110.0 && j.max_deg < 137.0, "{j:?}");
        // Two triangles per lune and one per wall at each pole (the two poles are vertices 0
        // and 1), sharing the film's angle there (~109° at the tetrahedral point).
        for pole in [0, 1] {
            assert_eq!(m.vertex_triangles(pole).len(), 9);
        }
        // Smallest angle 12.5° (measured): walls near the axis, whose rows slant.
        let q = crate::cmc::figures::quality(m);
        assert!(q.min_angle_deg > 12.0, "{q:?}");
    }

    #[test]
    fn cube_frame_bubble_is_closed_and_wires_fixed() {
        let shape = cube_frame(1.0, Some(0.05), 4).unwrap();
        let (_, region, target) = &shape.volumes[0];
        assert!((region.volume(&shape.mesh) - target).abs() < 1e-12);
        let bubble = shape.mesh.surface_index("bubble").unwrap();
        // Every bubble edge is shared by two bubble triangles (closed), some also by a film.
        let fixed = shape.mesh.flags().iter().filter(|f| f.fixed).count();
        assert_eq!(fixed, 8 + 12 * 3);
        assert!(surface_areas(&shape.mesh)[bubble] > 0.0);
    }

    #[test]
    fn bubble_free_cube_film_has_a_central_square_on_triple_lines() {
        let shape = cube_frame(1.0, None, 4).unwrap();
        let m = &shape.mesh;
        assert!(shape.volumes.is_empty());
        assert_eq!(m.surfaces().len(), 1);
        let fixed = m.flags().iter().filter(|f| f.fixed).count();
        assert_eq!(fixed, 8 + 12 * 3);
        // Square edges meet three films (square, upper and lower trapezoid); the eight diagonals
        // from the cube's corners are triple lines too: 4·4 square-edge vertices + 8·3 diagonal
        // interior vertices + the 8 (fixed) cube corners.
        let triple: usize = m.edges().iter().filter(|e| e.triangles.len() == 3).count();
        assert_eq!(triple, 4 * 4 + 8 * 4);
        assert_eq!(m.junction_vertices().len(), 4 * 4 + 8 * 3 + 8);
        // Planar pieces: 8 trapezoids (sides 1 and 0.3, height √(0.35² + 0.5²)), 4 triangles
        // (base 1, height √2·0.35) and the 0.3² square.
        let trapezoid = 0.65 * (0.35f64 * 0.35 + 0.25).sqrt();
        let triangle = 0.5 * 2f64.sqrt() * 0.35;
        let exact = 8.0 * trapezoid + 4.0 * triangle + 0.09;
        assert!((total_area(m) - exact).abs() < 1e-12, "{}", total_area(m));
    }

    #[test]
    fn frames_wires_and_tents_build() {
        let o = crate::cmc::octahedron::octahedron_frame(
            1.0,
            crate::cmc::octahedron::OctahedronTopology::Cone,
            3,
        )
        .unwrap();
        // 12 cone triangles of base 1 and height ½.
        assert!((total_area(&o.mesh) - 3.0).abs() < 1e-12);
        let u = u_wires(1.0, 0.5, 6).unwrap();
        assert!(
            u.mesh
                .curvature_surface(u.mesh.vertex_count() - 1)
                .is_some()
        );
        let t = tents(
            &[TentSpec {
                name: "roof".into(),
                boundary: (0..8)
                    .map(|k| {
                        let a = 2.0 * PI * k as f64 / 8.0;
                        Point::new(5.0 * a.cos(), 1.0, -5.0 * a.sin())
                    })
                    .collect(),
                poles: vec![Pole {
                    at: [0.0, 0.0],
                    height: 4.0,
                    radius: 0.3,
                }],
            }],
            6,
        )
        .unwrap();
        let top = t.mesh.positions().iter().map(|p| p.y).fold(0.0, f64::max);
        assert_eq!(top, 4.0);
        let lifted = t
            .mesh
            .positions()
            .iter()
            .zip(t.mesh.flags())
            .filter(|(p, f)| f.fixed && p.y == 4.0)
            .count();
        assert!(lifted >= 7, "a pole lifts a cap, not a point: {lifted}");
        let c = cells(
            &[CellSpec {
                name: "dome".into(),
                footprint: (0..12)
                    .map(|k| {
                        let a = 2.0 * PI * k as f64 / 12.0;
                        [3.0 * a.cos(), -3.0 * a.sin()]
                    })
                    .collect(),
                height: Some(2.0),
                volume: 30.0,
            }],
            6,
        )
        .unwrap();
        // The paraboloid over a near-disk of radius 3, height 2 encloses about π·9·2/2.
        let v = c.volumes[0].1.volume(&c.mesh);
        assert!((v / (PI * 9.0) - 1.0).abs() < 0.1, "{v}");
    }

    #[test]
    fn inflated_cells_enclose_their_volumes_on_well_shaped_rings() {
        // The cap that encloses V over radius a: πh(3a² + h²)/6 = V, and for a hemisphere
        // (h = a) V = 2πa³/3.
        let cap = SphericalCap::with_volume(2.0, 2.0 * PI * 8.0 / 3.0);
        assert!((cap.h - 2.0).abs() < 1e-12, "{}", cap.h);
        assert!((cap.height_at(0.0) - 2.0).abs() < 1e-12 && cap.height_at(2.0).abs() < 1e-12);
        let cap = SphericalCap::with_volume(20.0, 10_000.0);
        assert!((segment_volume(20.0, cap.h) / 10_000.0 - 1.0).abs() < 1e-12);
        let circle = |r: f64, sides: usize, at: [f64; 2]| -> Vec<[f64; 2]> {
            (0..sides)
                .map(|k| {
                    let a = 2.0 * PI * k as f64 / sides as f64;
                    [at[0] + r * a.cos(), at[1] - r * a.sin()]
                })
                .collect()
        };
        let specs = [
            CellSpec {
                name: "dome".into(),
                footprint: circle(20.0, 24, [0.0, 0.0]),
                height: None,
                volume: 10_000.0,
            },
            CellSpec {
                name: "cell".into(),
                footprint: circle(9.0, 16, [40.0, 0.0]),
                height: None,
                volume: 1_200.0,
            },
        ];
        for levels in [2, 5] {
            let shape = cells(&specs, levels).unwrap();
            let m = &shape.mesh;
            for (_, region, target) in &shape.volumes {
                assert!((region.volume(m) / target - 1.0).abs() < 1e-12);
            }
            // Six-sector rings evenly spaced along the meridians: no slivers (24 fan sectors
            // have angles ≤ 360°/24 = 15° in plan, less on the steep rim), and the rim vertices
            // lie on the footprint's edges.
            let q = crate::cmc::figures::quality(m);
            assert!(q.min_angle_deg > 30.0, "{q:?}");
            let rim: Vec<&Point> = m.fixed_positions().collect();
            assert_eq!(rim.len(), 2 * 6 * levels);
            for p in rim {
                assert!(p.y.abs() < 1e-12);
                let (r, apothem) = if p.x < 30.0 {
                    (p.xz().norm(), 20.0 * (PI / 24.0).cos())
                } else {
                    (
                        (p.xz() - nalgebra::Vector2::new(40.0, 0.0)).norm(),
                        9.0 * (PI / 16.0).cos(),
                    )
                };
                assert!(
                    r >= apothem - 1e-9
                        && r <= apothem / (PI / 24.0).cos().min((PI / 16.0).cos()) + 1e-9
                );
            }
        }
    }
}
