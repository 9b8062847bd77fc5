use optimize::cmc::octahedron::{OctahedronTopology as T, partition_walls, window_weights};
type P = nalgebra::Vector3<f64>;
fn area(c: &[P]) -> f64 {
    let mut s = P::zeros();
    for i in 1..c.len() - 1 {
        s += (c[i] - c[0]).cross(&(c[i + 1] - c[0]));
    }
    0.5 * s.norm()
}
fn sig(w: &[f64; 8]) -> Vec<(usize, usize, usize)> {
    let h = 1.0 / 2f64.sqrt();
    partition_walls(h, w)
        .iter()
        .map(|(f, g, p)| (*f, *g, p.len()))
        .collect()
}
fn total(w: &[f64; 8]) -> f64 {
    let h = 1.0 / 2f64.sqrt();
    partition_walls(h, w).iter().map(|(_, _, p)| area(p)).sum()
}
fn minedge(w: &[f64; 8]) -> f64 {
    let h = 1.0 / 2f64.sqrt();
    partition_walls(h, w)
        .iter()
        .flat_map(|(_, _, p)| (0..p.len()).map(move |i| (p[i] - p[(i + 1) % p.len()]).norm()))
        .fold(9.0, f64::min)
}
fn main() {
    let minlen: f64 = std::env::args()
        .nth(1)
        .map(|s| s.parse().unwrap())
        .unwrap_or(0.05);
    for t in [
        T::Tetrahedral,
        T::Square,
        T::Quadrilateral,
        T::Pentagon,
        T::Hexagon,
    ] {
        let mut w = window_weights(t).unwrap();
        let s0 = sig(&w);
        println!(
            "{t:?} start area {:.5} minedge {:.3}",
            total(&w),
            minedge(&w)
        );
        let ok = |w: &[f64; 8]| sig(w) == s0 && minedge(w) >= minlen;
        let mut step = 0.2;
        while step > 1e-5 {
            let mut improved = false;
            for k in 0..8 {
                for s in [1.0, -1.0] {
                    let mut v = w;
                    v[k] *= 1.0 + s * step;
                    if ok(&v) && total(&v) < total(&w) - 1e-12 {
                        w = v;
                        improved = true;
                    }
                }
            }
            if !improved {
                step *= 0.5;
            }
        }
        let m = w.iter().cloned().fold(9.0, f64::min);
        let wn: Vec<f64> = w
            .iter()
            .map(|x| (x / m * 1000.0).round() / 1000.0)
            .collect();
        println!(
            "  -> area {:.5} minedge {:.3} weights {:?}",
            total(&w),
            minedge(&w),
            wn
        );
    }
}
