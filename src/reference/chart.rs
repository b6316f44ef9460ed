//! A labelled scatter chart on log-log axes as SVG text (speed against error), written by hand
//! so that the report needs no plotting library and no font file: the SVG's text uses the
//! viewer's sans-serif font.

use super::report::escape;
use std::fmt::Write as _;

/// One point: its label, x (say, seconds) and y (say, relRMSE); both must be > 0.
pub struct Point {
    /// Shown beside the point.
    pub label: String,
    /// Horizontal value, > 0.
    pub x: f64,
    /// Vertical value, > 0.
    pub y: f64,
}

const W: f64 = 780.0;
const H: f64 = 440.0;
const LEFT: f64 = 70.0;
const RIGHT: f64 = 260.0;
const TOP: f64 = 36.0;
const BOTTOM: f64 = 50.0;

/// Powers of ten spanning `[lo, hi]` (log10 values), widened to at least one decade.
fn decades(lo: f64, hi: f64) -> (f64, f64) {
    let (a, b) = (lo.floor(), hi.ceil());
    if b > a {
        (a, b)
    } else {
        (a, a + 1.0)
    }
}

/// The chart's SVG text; points that are not positive and finite are left out.
pub fn scatter_svg(title: &str, x_label: &str, y_label: &str, points: &[Point]) -> String {
    let ok: Vec<&Point> = points
        .iter()
        .filter(|p| p.x > 0.0 && p.y > 0.0 && p.x.is_finite() && p.y.is_finite())
        .collect();
    let lx: Vec<f64> = ok.iter().map(|p| p.x.log10()).collect();
    let ly: Vec<f64> = ok.iter().map(|p| p.y.log10()).collect();
    let fold = |v: &[f64]| {
        v.iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                (a.min(x), b.max(x))
            })
    };
    let ((x0, x1), (y0, y1)) = if ok.is_empty() {
        ((0.0, 1.0), (0.0, 1.0))
    } else {
        let (a, b) = fold(&lx);
        let (c, d) = fold(&ly);
        (decades(a, b), decades(c, d))
    };
    let px = |v: f64| LEFT + (v - x0) / (x1 - x0) * (W - LEFT - RIGHT);
    let py = |v: f64| H - BOTTOM - (v - y0) / (y1 - y0) * (H - TOP - BOTTOM);
    let mut s = String::new();
    let _ = write!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{W}\" height=\"{H}\" viewBox=\"0 0 {W} {H}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"{W}\" height=\"{H}\" fill=\"white\"/>\n<text x=\"{}\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">{}</text>\n",
        W / 2.0,
        escape(title)
    );
    // Grid lines at the decades and 2x, 5x between them.
    for (lo, hi, vertical) in [(x0, x1, true), (y0, y1, false)] {
        let mut d = lo;
        while d <= hi + 1e-9 {
            for m in [1.0f64, 2.0, 5.0] {
                let v = d + m.log10();
                if v > hi + 1e-9 {
                    continue;
                }
                let (colour, label) = if m == 1.0 {
                    ("#bbb", Some(super::error_map::label(10f64.powf(d))))
                } else {
                    ("#eee", None)
                };
                if vertical {
                    let x = px(v);
                    let _ = writeln!(s, "<line x1=\"{x:.1}\" y1=\"{TOP}\" x2=\"{x:.1}\" y2=\"{}\" stroke=\"{colour}\"/>", H - BOTTOM);
                    if let Some(l) = label {
                        let _ = writeln!(
                            s,
                            "<text x=\"{x:.1}\" y=\"{}\" text-anchor=\"middle\">{l}</text>",
                            H - BOTTOM + 16.0
                        );
                    }
                } else {
                    let y = py(v);
                    let _ = writeln!(s, "<line x1=\"{LEFT}\" y1=\"{y:.1}\" x2=\"{}\" y2=\"{y:.1}\" stroke=\"{colour}\"/>", W - RIGHT);
                    if let Some(l) = label {
                        let _ = writeln!(
                            s,
                            "<text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">{l}</text>",
                            LEFT - 6.0,
                            y + 4.0
                        );
                    }
                }
            }
            d += 1.0;
        }
    }
    let _ = writeln!(
        s,
        "<rect x=\"{LEFT}\" y=\"{TOP}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#333\"/>",
        W - LEFT - RIGHT,
        H - TOP - BOTTOM
    );
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
        LEFT + (W - LEFT - RIGHT) / 2.0,
        H - 12.0,
        escape(x_label)
    );
    let _ = writeln!(
        s,
        "<text transform=\"translate(18 {}) rotate(-90)\" text-anchor=\"middle\">{}</text>",
        TOP + (H - TOP - BOTTOM) / 2.0,
        escape(y_label)
    );
    // Points numbered on the chart, named in the legend on the right.
    for (k, p) in ok.iter().enumerate() {
        let (x, y) = (px(lx[k]), py(ly[k]));
        let _ = writeln!(
            s,
            "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"4\" fill=\"#1f5fa8\"/><text x=\"{:.1}\" y=\"{:.1}\" font-size=\"11\">{}</text>",
            x + 6.0,
            y - 4.0,
            k + 1
        );
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{}\" font-size=\"11\">{}. {}</text>",
            W - RIGHT + 12.0,
            TOP + 12.0 + 15.0 * k as f64,
            k + 1,
            escape(&p.label)
        );
    }
    s.push_str("</svg>\n");
    s
}
