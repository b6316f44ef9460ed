//! False-colour images of the per-pixel relative error (absolute against a reference that is
//! zero everywhere), with a labelled colour bar.

use ab_glyph::{point, Font, FontRef, PxScale, ScaleFont};
use std::path::Path;

/// Width of the panel holding the colour bar, right of the image.
const PANEL: usize = 104;
/// The canvas is at least this tall, so that the bar's labels fit beside small images.
const MIN_HEIGHT: usize = 180;
const BACKGROUND: [u8; 3] = [32, 32, 32];
/// Pixels outside every region of interest.
const OUTSIDE: [u8; 3] = [72, 72, 72];

/// Viridis (perceptually uniform, legible in grey and to colour-blind readers), 9 stops.
const VIRIDIS: [[f64; 3]; 9] = [
    [68.0, 1.0, 84.0],
    [71.0, 44.0, 122.0],
    [59.0, 81.0, 139.0],
    [44.0, 113.0, 142.0],
    [33.0, 144.0, 141.0],
    [39.0, 173.0, 129.0],
    [92.0, 200.0, 99.0],
    [170.0, 220.0, 50.0],
    [253.0, 231.0, 37.0],
];

/// The colour of `t` in [0, 1] (clamped).
pub fn colour(t: f64) -> [u8; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) } * 8.0;
    let k = (t.floor() as usize).min(7);
    let f = t - k as f64;
    let (a, b) = (VIRIDIS[k], VIRIDIS[k + 1]);
    [0, 1, 2].map(|c| (a[c] + (b[c] - a[c]) * f + 0.5) as u8)
}

/// The colour scale's top: the 99th percentile of the errors (of the pixels `inside`, when
/// given), so that a few outliers do not leave the rest of the map dark; never 0.
pub fn default_max(errors: &[f64], inside: Option<&[bool]>) -> f64 {
    let mut v: Vec<f64> = errors
        .iter()
        .enumerate()
        .filter(|&(i, _)| inside.is_none_or(|m| m[i]))
        .map(|(_, &e)| e)
        .filter(|e| e.is_finite())
        .collect();
    if v.is_empty() {
        return 1.0;
    }
    v.sort_by(f64::total_cmp);
    let p = v[((v.len() - 1) as f64 * 0.99).round() as usize];
    if p > 0.0 {
        p
    } else {
        v.last().copied().filter(|&m| m > 0.0).unwrap_or(1.0)
    }
}

/// An RGB8 raster.
pub struct Canvas {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Row-major RGB bytes.
    pub rgb: Vec<u8>,
}

impl Canvas {
    fn new(width: usize, height: usize) -> Self {
        let rgb = BACKGROUND.repeat(width * height);
        Canvas { width, height, rgb }
    }

    fn set(&mut self, x: usize, y: usize, c: [u8; 3]) {
        let i = 3 * (y * self.width + x);
        self.rgb[i..i + 3].copy_from_slice(&c);
    }

    /// Draws white `text` with its baseline's left end at `(x, y)`.
    fn text(&mut self, font: &FontRef, x: f32, y: f32, size: f32, text: &str) {
        let scale = PxScale::from(size);
        let scaled = font.as_scaled(scale);
        let mut caret = x;
        for ch in text.chars() {
            let id = font.glyph_id(ch);
            let glyph = id.with_scale_and_position(scale, point(caret, y));
            caret += scaled.h_advance(id);
            let Some(outline) = font.outline_glyph(glyph) else {
                continue;
            };
            let b = outline.px_bounds();
            outline.draw(|gx, gy, coverage| {
                let (px, py) = (b.min.x as i64 + gx as i64, b.min.y as i64 + gy as i64);
                if px < 0 || py < 0 || px >= self.width as i64 || py >= self.height as i64 {
                    return;
                }
                let i = 3 * (py as usize * self.width + px as usize);
                for c in &mut self.rgb[i..i + 3] {
                    *c = (*c as f32 + (255.0 - *c as f32) * coverage.min(1.0)) as u8;
                }
            });
        }
    }

    /// Writes the canvas as a PNG.
    pub fn write_png(&self, path: &Path) -> Result<(), String> {
        crate::util::atomic::write_png(path, &self.rgb, self.width as u32, self.height as u32)
    }
}

/// A tick label: three significant digits, scientific below 0.001.
pub fn label(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() < 1e-3 || v.abs() >= 1e4 {
        format!("{v:.2e}")
    } else {
        let digits = (2 - v.abs().log10().floor() as i32).max(0) as usize;
        format!("{v:.digits$}")
    }
}

/// The false-colour map of `errors` (a `width` x `height` plane, row-major) from 0 to `max`,
/// values above `max` drawn in the top colour; pixels outside `inside` (when given) grey; a
/// colour bar with five labelled ticks on the right, under `title`.
pub fn render(
    errors: &[f64],
    width: usize,
    height: usize,
    max: f64,
    inside: Option<&[bool]>,
    title: &str,
) -> Canvas {
    let mut canvas = Canvas::new(width + PANEL, height.max(MIN_HEIGHT));
    draw_map(&mut canvas, errors, width, height, max, inside);
    let clipped = errors.iter().any(|&e| e > max);
    draw_bar(&mut canvas, width, max, clipped, title);
    canvas
}

/// The map alone, without the colour bar (the report shows one bar for several maps).
pub fn render_plain(
    errors: &[f64],
    width: usize,
    height: usize,
    max: f64,
    inside: Option<&[bool]>,
) -> Canvas {
    let mut canvas = Canvas::new(width, height);
    draw_map(&mut canvas, errors, width, height, max, inside);
    canvas
}

/// The colour bar alone under `title`, `height` pixels tall (at least 180).
pub fn colour_bar(max: f64, clipped: bool, height: usize, title: &str) -> Canvas {
    let mut canvas = Canvas::new(PANEL, height.max(MIN_HEIGHT));
    draw_bar(&mut canvas, 0, max, clipped, title);
    canvas
}

fn draw_map(
    canvas: &mut Canvas,
    errors: &[f64],
    width: usize,
    height: usize,
    max: f64,
    inside: Option<&[bool]>,
) {
    for y in 0..height {
        for x in 0..width {
            let i = y * width + x;
            let c = if inside.is_none_or(|m| m[i]) {
                colour(errors[i] / max)
            } else {
                OUTSIDE
            };
            canvas.set(x, y, c);
        }
    }
}

/// The bar in the panel starting at column `left`: top = `max`, bottom = 0, five ticks.
fn draw_bar(canvas: &mut Canvas, left: usize, max: f64, clipped: bool, title: &str) {
    let font = FontRef::try_from_slice(dejavu::sans::regular()).expect("DejaVu Sans parses");
    let (bar_x, bar_w, top, bottom) = (left + 12, 16, 28usize, canvas.height - 12);
    for y in top..=bottom {
        let c = colour((bottom - y) as f64 / (bottom - top) as f64);
        for x in bar_x..bar_x + bar_w {
            canvas.set(x, y, c);
        }
    }
    canvas.text(&font, (left + 6) as f32, 16.0, 11.0, title);
    for k in 0..=4 {
        let y = bottom - (bottom - top) * k / 4;
        for x in bar_x + bar_w..bar_x + bar_w + 4 {
            canvas.set(x, y, [255, 255, 255]);
        }
        let value = max * k as f64 / 4.0;
        let text = if k == 4 && clipped {
            format!("\u{2265}{}", label(value))
        } else {
            label(value)
        };
        canvas.text(
            &font,
            (bar_x + bar_w + 6) as f32,
            y as f32 + 4.0,
            11.0,
            &text,
        );
    }
}
