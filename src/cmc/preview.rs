//! An SVG preview of a mesh: orthographic view from above-front-right (y up), triangles drawn
//! back to front (painter's algorithm) in a colour per surface, shaded by the angle between the
//! triangle normal and a light direction (two-sided, since films have no outside).

use std::fmt::Write;

use super::area::area_vector;
use super::mesh::{Mesh, Point};
use crate::io::svg::escape;

/// Base colours (RGB) cycled over surfaces.
const PALETTE: [(f64, f64, f64); 8] = [
    (0.30, 0.55, 0.85),
    (0.90, 0.55, 0.25),
    (0.40, 0.75, 0.40),
    (0.80, 0.35, 0.45),
    (0.60, 0.45, 0.80),
    (0.85, 0.75, 0.30),
    (0.35, 0.70, 0.75),
    (0.65, 0.65, 0.65),
];

/// Renders `mesh` as an SVG document `width` pixels wide with a caption.
pub fn svg(mesh: &Mesh, width: f64, caption: &str) -> String {
    let view = Point::new(1.0, 0.8, 1.4).normalize();
    let right = Point::y().cross(&view).normalize();
    let up = view.cross(&right);
    let light = Point::new(0.4, 1.0, 0.6).normalize();
    let project = |p: &Point| (p.dot(&right), -p.dot(&up), p.dot(&view));
    let pts: Vec<(f64, f64, f64)> = mesh.positions().iter().map(project).collect();
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y, _) in &pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    let margin = 20.0;
    let span = (x1 - x0).max(y1 - y0).max(1e-300);
    let s = (width - 2.0 * margin) / span;
    let height = (y1 - y0) * s + 2.0 * margin + 24.0;
    let depth: Vec<f64> = mesh
        .triangles()
        .iter()
        .map(|tri| tri.iter().map(|&v| pts[v].2).sum::<f64>())
        .collect();
    let mut order: Vec<usize> = (0..mesh.triangles().len()).collect();
    order.sort_by(|&a, &b| depth[a].total_cmp(&depth[b]));
    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}">"#
    );
    let _ = writeln!(out, r#"<rect width="100%" height="100%" fill="white"/>"#);
    // The triangles' common stroke and opacity once, on their group.
    let _ = writeln!(
        out,
        r#"<g stroke="rgb(40,40,40)" stroke-width="0.2" fill-opacity="0.85">"#
    );
    for t in order {
        let n = area_vector(&mesh.corners(t)).normalize();
        let shade = 0.35 + 0.65 * n.dot(&light).abs();
        let (r, g, b) = PALETTE[mesh.triangle_surface()[t] % PALETTE.len()];
        let colour = |c: f64| (255.0 * (c * shade).clamp(0.0, 1.0)).round() as u8;
        out.push_str(r#"<polygon points=""#);
        for (k, &v) in mesh.triangles()[t].iter().enumerate() {
            let (x, y, _) = pts[v];
            if k > 0 {
                out.push(' ');
            }
            push_tenths(&mut out, (x - x0) * s + margin);
            out.push(',');
            push_tenths(&mut out, (y - y0) * s + margin);
        }
        out.push_str(r##"" fill="#"##);
        for c in [r, g, b] {
            let byte = colour(c);
            out.push(HEX[usize::from(byte >> 4)]);
            out.push(HEX[usize::from(byte & 15)]);
        }
        out.push_str("\"/>\n");
    }
    out.push_str("</g>\n");
    let _ = writeln!(
        out,
        r#"<text x="{margin}" y="{:.0}" font-family="sans-serif" font-size="14">{}</text>"#,
        height - 8.0,
        escape(caption)
    );
    out.push_str("</svg>\n");
    out
}

/// Hexadecimal digits of the fill colours.
const HEX: [char; 16] = [
    '0', '1', '2', '3', '4', '5', '6', '7', '8', '9', 'a', 'b', 'c', 'd', 'e', 'f',
];

/// Appends `v` (pixels) rounded to tenths, as `123.4` (digits written directly: the preview
/// writes two such numbers per corner).
fn push_tenths(out: &mut String, v: f64) {
    let tenths = (v * 10.0).round();
    if tenths < 0.0 {
        out.push('-');
    }
    let mut rest = tenths.abs() as u64;
    // At most 20 decimal digits in a u64, the last one after the point.
    let mut digits = [0u8; 20];
    let mut count = 0;
    while count < 2 || rest > 0 {
        digits[count] = (rest % 10) as u8;
        rest /= 10;
        count += 1;
    }
    for (k, &d) in digits[..count].iter().enumerate().rev() {
        out.push(char::from(b'0' + d));
        if k == 1 {
            out.push('.');
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_polygon_per_triangle() {
        let mesh = crate::cmc::generators::icosphere(1.0, 1, "s").unwrap();
        let text = svg(&mesh, 400.0, "sphere <test>");
        assert_eq!(text.matches("<polygon").count(), mesh.triangles().len());
        assert!(text.contains("sphere &lt;test&gt;"));
        assert!(text.ends_with("</svg>\n"));
    }

    #[test]
    fn pixels_are_written_in_tenths() {
        let mut out = String::new();
        for v in [0.0, 0.04, 12.34, 12.36, 799.96, -3.25, 1e6] {
            push_tenths(&mut out, v);
            out.push(' ');
        }
        assert_eq!(out, "0.0 0.0 12.3 12.4 800.0 -3.3 1000000.0 ");
    }
}
