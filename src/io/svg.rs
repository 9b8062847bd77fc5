//! A minimal SVG writer for previews (truss elevations, mesh previews, gait filmstrips).
//!
//! Drawing happens in world units (metres) inside a world-space rectangle; the writer maps it
//! to the picture with y pointing up (SVG's own y points down) and a uniform scale, so shapes
//! are never distorted. Numbers are printed with a fixed precision, so the same drawing gives
//! the same bytes.

use std::fmt::Write;

/// A picture under construction.
#[derive(Debug, Clone)]
pub struct Svg {
    width: f64,
    height: f64,
    scale: f64,
    x0: f64,
    y1: f64,
    body: String,
}

/// Stroke and fill of a shape; colours are any SVG colour string ("#c0392b", "none").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Style<'a> {
    /// Outline colour.
    pub stroke: &'a str,
    /// Outline width in picture pixels.
    pub stroke_width: f64,
    /// Fill colour.
    pub fill: &'a str,
    /// Opacity in [0, 1].
    pub opacity: f64,
}

impl<'a> Style<'a> {
    /// An outline without fill.
    pub fn line(stroke: &'a str, stroke_width: f64) -> Self {
        Style {
            stroke,
            stroke_width,
            fill: "none",
            opacity: 1.0,
        }
    }

    /// A filled shape without outline.
    pub fn fill(fill: &'a str) -> Self {
        Style {
            stroke: "none",
            stroke_width: 0.0,
            fill,
            opacity: 1.0,
        }
    }
}

/// Text safe inside an SVG element (`&`, `<`, `>` escaped).
pub fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

impl Svg {
    /// A picture `width` pixels wide showing the world rectangle `[xmin, xmax] × [ymin, ymax]`
    /// (metres) with a margin of 5%; the height follows from the aspect ratio.
    pub fn new(width: f64, xmin: f64, xmax: f64, ymin: f64, ymax: f64) -> Self {
        let span_x = (xmax - xmin).abs().max(1e-9);
        let span_y = (ymax - ymin).abs().max(1e-9);
        let margin = 0.05 * span_x.max(span_y);
        let (x0, x1) = (xmin - margin, xmax + margin);
        let (y0, y1) = (ymin - margin, ymax + margin);
        let scale = width / (x1 - x0);
        Svg {
            width,
            height: (y1 - y0) * scale,
            scale,
            x0,
            y1,
            body: String::new(),
        }
    }

    /// Picture coordinates of a world point.
    fn map(&self, x: f64, y: f64) -> (f64, f64) {
        ((x - self.x0) * self.scale, (self.y1 - y) * self.scale)
    }

    fn style(s: &Style<'_>) -> String {
        format!(
            "stroke=\"{}\" stroke-width=\"{:.2}\" fill=\"{}\" opacity=\"{:.3}\"",
            s.stroke, s.stroke_width, s.fill, s.opacity
        )
    }

    /// A segment between two world points.
    pub fn line(&mut self, a: [f64; 2], b: [f64; 2], style: &Style<'_>) {
        let (x1, y1) = self.map(a[0], a[1]);
        let (x2, y2) = self.map(b[0], b[1]);
        let st = Self::style(style);
        let _ = writeln!(
            self.body,
            "<line x1=\"{x1:.2}\" y1=\"{y1:.2}\" x2=\"{x2:.2}\" y2=\"{y2:.2}\" {st}/>"
        );
    }

    /// A circle of world radius `r` (at least one pixel).
    pub fn circle(&mut self, c: [f64; 2], r: f64, style: &Style<'_>) {
        let (x, y) = self.map(c[0], c[1]);
        let r = (r * self.scale).max(1.0);
        let st = Self::style(style);
        let _ = writeln!(
            self.body,
            "<circle cx=\"{x:.2}\" cy=\"{y:.2}\" r=\"{r:.2}\" {st}/>"
        );
    }

    /// A closed polygon through world points.
    pub fn polygon(&mut self, points: &[[f64; 2]], style: &Style<'_>) {
        let pts: Vec<String> = points
            .iter()
            .map(|p| {
                let (x, y) = self.map(p[0], p[1]);
                format!("{x:.2},{y:.2}")
            })
            .collect();
        let st = Self::style(style);
        let _ = writeln!(self.body, "<polygon points=\"{}\" {st}/>", pts.join(" "));
    }

    /// Text at a world point, `size` in pixels.
    pub fn text(&mut self, at: [f64; 2], size: f64, text: &str) {
        let (x, y) = self.map(at[0], at[1]);
        let escaped = escape(text);
        let _ = writeln!(
            self.body,
            "<text x=\"{x:.2}\" y=\"{y:.2}\" font-family=\"sans-serif\" font-size=\"{size:.1}\">{escaped}</text>"
        );
    }

    /// A grid of lines every `step` metres over the visible rectangle.
    pub fn grid(&mut self, step: f64, style: &Style<'_>) {
        if step.is_nan() || step <= 0.0 {
            return;
        }
        let (x1, y0) = (
            self.x0 + self.width / self.scale,
            self.y1 - self.height / self.scale,
        );
        let mut x = (self.x0 / step).ceil() * step;
        while x <= x1 {
            self.line([x, y0], [x, self.y1], style);
            x += step;
        }
        let mut y = (y0 / step).ceil() * step;
        while y <= self.y1 {
            self.line([self.x0, y], [x1, y], style);
            y += step;
        }
    }

    /// The finished document.
    pub fn finish(self) -> String {
        format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w:.0}\" height=\"{h:.0}\" viewBox=\"0 0 {w:.2} {h:.2}\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n{}</svg>\n",
            self.body,
            w = self.width,
            h = self.height
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn world_y_points_up_and_scale_is_uniform() {
        let mut svg = Svg::new(200.0, 0.0, 10.0, 0.0, 5.0);
        let (xa, ya) = svg.map(0.0, 0.0);
        let (xb, yb) = svg.map(10.0, 5.0);
        assert!(yb < ya, "higher world y is higher in the picture");
        assert!(((xb - xa) / 10.0 - (ya - yb) / 5.0).abs() < 1e-9);
        svg.line([0.0, 0.0], [1.0, 1.0], &Style::line("black", 1.0));
        svg.text([0.0, 0.0], 10.0, "a<b");
        let doc = svg.finish();
        assert!(doc.starts_with("<svg") && doc.contains("a&lt;b") && doc.ends_with("</svg>\n"));
    }
}
