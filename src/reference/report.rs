//! The HTML report: renders beside a reference with synchronized zoom and pan, their error
//! maps, crops of the regions of interest, figures per region, tables and charts; one folder
//! (`index.html`, `img/`), no network access needed (style and scripts inline).

use super::channels::ChannelImage;
use super::compare::{measure, relative_error_per_pixel, ErrorScale};
use super::error_map;
use super::metrics::Regions;
use super::report_assets::{BODY_SCRIPT, HEAD_SCRIPT, STYLE};
pub use super::report_table::Table;
use crate::render::film::{linear_to_srgb, Film};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// One image of the report.
pub struct Render {
    /// Its caption.
    pub label: String,
    /// Linear radiance.
    pub film: Film,
}

/// A region of interest: the pixels where `mask` is true.
pub struct Region {
    /// Its name.
    pub name: String,
    /// Row-major, the reference's size.
    pub mask: Vec<bool>,
}

impl Region {
    /// The region `name` of the pixels `pixels` (row-major indices) of an image of `n` pixels.
    pub fn of_pixels(name: &str, pixels: &[usize], n: usize) -> Region {
        let mut mask = vec![false; n];
        for &i in pixels {
            mask[i] = true;
        }
        Region {
            name: name.to_string(),
            mask,
        }
    }
}

/// How [`scene_regions`] chooses its pixels, for a report's notes.
pub const REGIONS_NOTE: &str = "Regions: floor = pixels whose every camera ray of a 9 x 9 lattice over the pixel first hits a diffuse surface; caustic = floor pixels where the reference exceeds 1.5 x the unblocked direct light; contour = the tenth of the caustic with the largest reference gradient; shadow = floor pixels outside the caustic where every point and spot light is blocked (though some would light them unblocked).";

/// A scene's regions of interest (an image of `n` pixels) as the benchmarks and `photondiff
/// report --scene` show them: floor, caustic, contour and shadow (a region may be empty).
pub fn scene_regions(regions: &Regions, n: usize) -> Vec<Region> {
    [
        ("floor", &regions.diffuse),
        ("caustic", &regions.caustic),
        ("contour", &regions.contour),
        ("shadow", &regions.shadow),
    ]
    .into_iter()
    .map(|(name, pixels)| Region::of_pixels(name, pixels, n))
    .collect()
}

/// A chart: an existing image file copied into the report, or SVG text written into it.
pub enum Chart {
    /// An SVG or PNG file.
    File(PathBuf),
    /// SVG text and the chart's name (its heading).
    Svg { name: String, svg: String },
}

/// Everything a report shows.
pub struct Report {
    /// The page's title.
    pub title: String,
    /// Paragraphs under the title (how the images were made).
    pub notes: Vec<String>,
    /// The reference every render is judged against.
    pub reference: Render,
    /// The renders.
    pub renders: Vec<Render>,
    /// Regions of interest (the whole image is always measured too).
    pub regions: Vec<Region>,
    /// Tables, in order.
    pub tables: Vec<Table>,
    /// Charts, in order.
    pub charts: Vec<Chart>,
    /// Exposure of the tone-mapped images, in stops (radiance times 2^exposure, then sRGB).
    pub exposure: f64,
}

/// Escapes text for HTML.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// sRGB bytes of `film` times `2^exposure`, clamped.
fn tone_map(film: &Film, exposure: f64) -> Vec<u8> {
    let k = exposure.exp2();
    film.pixels
        .iter()
        .flat_map(|p| p.to_array())
        .map(|c| (linear_to_srgb(c * k) * 255.0 + 0.5) as u8)
        .collect()
}

fn save(path: &Path, rgb: &[u8], w: usize, h: usize) -> Result<(), String> {
    crate::util::atomic::write_png(path, rgb, w as u32, h as u32)
}

/// The bounding box `(x, y, w, h)` of a mask's pixels, padded by 4 pixels.
fn bounds(mask: &[bool], w: usize, h: usize) -> Option<(usize, usize, usize, usize)> {
    let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
    for (i, _) in mask.iter().enumerate().filter(|m| *m.1) {
        let (x, y) = (i % w, i / w);
        (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
    }
    if x0 == usize::MAX {
        return None;
    }
    let (x0, y0) = (x0.saturating_sub(4), y0.saturating_sub(4));
    let (x1, y1) = ((x1 + 4).min(w - 1), (y1 + 4).min(h - 1));
    Some((x0, y0, x1 - x0 + 1, y1 - y0 + 1))
}

fn crop(rgb: &[u8], w: usize, (x0, y0, cw, ch): (usize, usize, usize, usize)) -> Vec<u8> {
    (y0..y0 + ch)
        .flat_map(|y| rgb[3 * (y * w + x0)..3 * (y * w + x0 + cw)].iter().copied())
        .collect()
}

fn cell(v: Option<f64>) -> String {
    v.map_or("-".into(), |v| format!("{v:.4}"))
}

/// [`write`](fn@write), and each table beside the page as JSON for `photondiff report --table`:
/// `table.json`, then `table-2.json` and on.
pub fn write_with_tables(report: &Report, dir: &Path) -> Result<PathBuf, String> {
    let page = write(report, dir)?;
    for (k, table) in report.tables.iter().enumerate() {
        let name = match k {
            0 => "table.json".to_string(),
            k => format!("table-{}.json", k + 1),
        };
        table.write(&dir.join(name))?;
    }
    Ok(page)
}

/// Writes the report into `dir` (created if needed): `index.html` and its images under `img/`.
/// Returns the page's path.
pub fn write(report: &Report, dir: &Path) -> Result<PathBuf, String> {
    let reference = &report.reference.film;
    let (w, h) = (reference.width as usize, reference.height as usize);
    for r in &report.renders {
        if (r.film.width, r.film.height) != (reference.width, reference.height) {
            return Err(format!(
                "{} is {} x {} pixels but the reference is {w} x {h}",
                r.label, r.film.width, r.film.height
            ));
        }
    }
    for region in &report.regions {
        if region.mask.len() != w * h {
            return Err(format!(
                "region {} does not match the reference's {w} x {h} pixels",
                region.name
            ));
        }
    }
    // The chart files are read before anything is written: a chart may be one a report
    // wrote into this folder before (`img/chart-0.svg`), which copying emptied.
    let chart_files = report
        .charts
        .iter()
        .map(|c| match c {
            Chart::File(path) => std::fs::read(path)
                .map(Some)
                .map_err(|e| format!("{}: cannot read chart: {e}", path.display())),
            Chart::Svg { .. } => Ok(None),
        })
        .collect::<Result<Vec<_>, _>>()?;
    let img = dir.join("img");
    std::fs::create_dir_all(&img)
        .map_err(|e| format!("{}: cannot create folder: {e}", img.display()))?;

    // Tone-mapped images and error maps, all maps on one colour scale.
    let reference_channels = ChannelImage::from_film(reference);
    let mut images = vec![(
        report.reference.label.clone(),
        tone_map(reference, report.exposure),
    )];
    let mut errors = Vec::new();
    let mut scale = ErrorScale::Relative;
    for r in &report.renders {
        images.push((r.label.clone(), tone_map(&r.film, report.exposure)));
        let (e, s) =
            relative_error_per_pixel(&ChannelImage::from_film(&r.film), &reference_channels);
        errors.push(e);
        scale = s;
    }
    let max = errors
        .iter()
        .map(|e| error_map::default_max(e, None))
        .fold(0.0, f64::max);
    let max = if max > 0.0 { max } else { 1.0 };
    let clipped = errors.iter().flatten().any(|&e| e > max);
    let maps: Vec<Vec<u8>> = errors
        .iter()
        .map(|e| error_map::render_plain(e, w, h, max, None).rgb)
        .collect();
    for (k, (_, rgb)) in images.iter().enumerate() {
        save(&img.join(format!("image-{k}.png")), rgb, w, h)?;
    }
    for (k, rgb) in maps.iter().enumerate() {
        save(&img.join(format!("error-{}.png", k + 1)), rgb, w, h)?;
    }
    error_map::colour_bar(max, clipped, h.min(320), scale.title())
        .write_png(&img.join("colour-bar.png"))?;

    // The views share one display size: the image's, scaled to between 256 and 420 pixels wide.
    let display_w = if w < 256 {
        w * 256usize.div_ceil(w)
    } else {
        w.min(420)
    };
    let display_h = (h * display_w).div_ceil(w);
    let view = |src: &str, caption: &str| {
        format!(
            "<figure><div class=\"view\" style=\"width:{display_w}px;height:{display_h}px\"><img src=\"{src}\" alt=\"{c}\" width=\"{display_w}\" height=\"{display_h}\" draggable=\"false\"></div><figcaption>{c}</figcaption></figure>\n",
            c = escape(caption)
        )
    };

    let mut html = String::new();
    let title = escape(&report.title);
    let _ = write!(
        html,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{title}</title>\n<style>{STYLE}</style>\n<script>{HEAD_SCRIPT}</script></head>\n<body>\n<h1>{title}</h1>\n"
    );
    for n in &report.notes {
        let _ = writeln!(html, "<p class=\"note\">{}</p>", escape(n));
    }
    let _ = writeln!(
        html,
        "<p id=\"status\" data-status=\"loading\">Loading images...</p>"
    );

    // Figures per render and region.
    let _ = writeln!(html, "<h2>Error against the reference</h2>\n<p class=\"note\">relRMSE = sqrt(mean over pixels and channels of (I - R)^2) / mean(R); mean ratio = mean(I) / mean(R); SSIM on sRGB luminance, 8 x 8 windows touching the region.</p>\n<table><tr><th>image</th><th>region</th><th>pixels</th><th>relRMSE</th><th>mean ratio</th><th>SSIM</th></tr>");
    for (r, film) in report.renders.iter().map(|r| (r, &r.film)) {
        let channels = ChannelImage::from_film(film);
        let whole = std::iter::once(("whole image", None));
        let regions = report
            .regions
            .iter()
            .map(|g| (g.name.as_str(), Some(g.mask.as_slice())));
        for (name, mask) in whole.chain(regions) {
            let m = measure(name, &channels, &reference_channels, mask);
            let _ = writeln!(
                html,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                escape(&r.label),
                escape(name),
                m.pixels,
                cell(m.rel_rmse),
                cell(m.mean_ratio),
                cell(m.ssim)
            );
        }
    }
    html.push_str("</table>\n");

    // Side by side, then the error maps: one zoom and pan for all.
    let _ = writeln!(html, "<h2>Images</h2>\n<p class=\"note\">Tone-mapped: radiance x 2^{} then sRGB, clamped. Wheel: zoom (every image together, <span id=\"zoom\">1.00x</span>); drag: pan; double-click: reset.</p>\n<div class=\"grid\">", report.exposure);
    for (k, (label, _)) in images.iter().enumerate() {
        html.push_str(&view(&format!("img/image-{k}.png"), label));
    }
    let _ = writeln!(html, "</div>\n<h2>Error maps</h2>\n<p class=\"note\">Per pixel: sqrt(mean over channels of (I - R)^2) / mean(R over the image), one colour scale for all.</p>\n<div class=\"grid\">");
    for (k, r) in report.renders.iter().enumerate() {
        html.push_str(&view(&format!("img/error-{}.png", k + 1), &r.label));
    }
    let _ = writeln!(html, "<figure><img src=\"img/colour-bar.png\" alt=\"colour bar\"><figcaption>colour scale</figcaption></figure></div>");

    // Crops of the regions of interest.
    if !report.regions.is_empty() {
        let _ = writeln!(html, "<h2>Regions of interest</h2>");
    }
    for (g, region) in report.regions.iter().enumerate() {
        let count = region.mask.iter().filter(|&&m| m).count();
        let Some(b) = bounds(&region.mask, w, h) else {
            let _ = writeln!(html, "<h3>{} (no pixel)</h3>", escape(&region.name));
            continue;
        };
        // A crop of most of the image would repeat the images above at their size: say so instead.
        if 2 * b.2 * b.3 > w * h {
            let _ = writeln!(
                html,
                "<h3>{} ({count} px; its box, {} x {} at ({}, {}), is most of the image: see the images above)</h3>",
                escape(&region.name),
                b.2,
                b.3,
                b.0,
                b.1
            );
            continue;
        }
        let scale = (200 / b.2.max(b.3)).clamp(1, 8);
        let _ = writeln!(
            html,
            "<h3>{} ({count} px; crop {} x {} at ({}, {}), shown x{scale})</h3>\n<div class=\"grid\">",
            escape(&region.name),
            b.2,
            b.3,
            b.0,
            b.1
        );
        let crops = images
            .iter()
            .map(|(l, rgb)| (l.clone(), rgb, "image"))
            .chain(
                report
                    .renders
                    .iter()
                    .zip(&maps)
                    .map(|(r, rgb)| (format!("{} error", r.label), rgb, "error")),
            );
        for (k, (label, rgb, kind)) in crops.enumerate() {
            let name = format!("img/crop-{g}-{kind}-{k}.png");
            save(&dir.join(&name), &crop(rgb, w, b), b.2, b.3)?;
            let _ = writeln!(
                html,
                "<figure><img class=\"crop\" src=\"{name}\" alt=\"{l}\" width=\"{}\" height=\"{}\"><figcaption>{l}</figcaption></figure>",
                b.2 * scale,
                b.3 * scale,
                l = escape(&label)
            );
        }
        html.push_str("</div>\n");
    }

    for t in &report.tables {
        let _ = writeln!(html, "<h2>{}</h2>\n<table><tr>", escape(&t.title));
        for c in &t.columns {
            let _ = write!(html, "<th>{}</th>", escape(c));
        }
        html.push_str("</tr>\n");
        for row in &t.rows {
            html.push_str("<tr>");
            for v in row {
                let _ = write!(
                    html,
                    "<td>{}</td>",
                    escape(&super::report_table::cell_text(v))
                );
            }
            html.push_str("</tr>\n");
        }
        html.push_str("</table>\n");
        for n in &t.notes {
            let _ = writeln!(html, "<p class=\"note\">{}</p>", escape(n));
        }
    }

    for (k, (chart, bytes)) in report.charts.iter().zip(&chart_files).enumerate() {
        let (heading, name) = match (chart, bytes) {
            (Chart::File(path), Some(bytes)) => {
                let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("png");
                let name = format!("chart-{k}.{ext}");
                std::fs::write(img.join(&name), bytes)
                    .map_err(|e| format!("{}: cannot copy chart: {e}", path.display()))?;
                let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned());
                (stem.unwrap_or_default(), name)
            }
            (Chart::File(_), None) => unreachable!("every chart file was read"),
            (Chart::Svg { name, svg }, _) => {
                let file = format!("chart-{k}.svg");
                std::fs::write(img.join(&file), svg)
                    .map_err(|e| format!("{}: cannot write: {e}", img.join(&file).display()))?;
                (name.clone(), file)
            }
        };
        let _ = writeln!(
            html,
            "<h2>Chart: {h}</h2>\n<img src=\"img/{name}\" alt=\"{h}\" style=\"max-width:100%\">",
            h = escape(&heading)
        );
    }

    let _ = write!(html, "<script>{BODY_SCRIPT}</script>\n</body></html>\n");
    let page = dir.join("index.html");
    std::fs::write(&page, html).map_err(|e| format!("{}: cannot write: {e}", page.display()))?;
    Ok(page)
}
