//! `photondiff report`: an HTML page (one folder, no network) showing renders beside a
//! reference, with error maps, crops of the regions of interest, tables and charts.

use photondiff::embree::Device;
use photondiff::reference::channels::ChannelImage;
use photondiff::reference::compare::read_mask;
use photondiff::reference::metrics::Regions;
use photondiff::reference::report::{self, Chart, Region, Render, Report, Table};
use photondiff::render::film::Film;
use photondiff::scene::file::load_scene;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct ReportArgs {
    /// The renders to show (EXR, RGB), each captioned with its file name without the extension,
    /// or LABEL=FILE.exr to caption it LABEL.
    #[arg(required = true, value_name = "RENDER.exr")]
    renders: Vec<String>,
    /// The reference the renders are judged against (EXR of the same size).
    #[arg(long, value_name = "REF.exr")]
    reference: PathBuf,
    /// Folder to write: index.html and img/ (created; files of the same names replaced).
    #[arg(
        short = 'o',
        long = "output",
        value_name = "DIR",
        default_value = "out/report"
    )]
    output: PathBuf,
    /// Scene file the images were rendered from: its regions of interest (floor = pixels each
    /// of whose camera rays on a 9 x 9 lattice first hits a diffuse surface, caustic, contour,
    /// shadow = floor outside the caustic where every point and spot light is blocked; as in
    /// the timing table; quad lights make neither caustic nor shadow) are measured and cropped.
    /// Its camera must have the reference's size.
    #[arg(long, value_name = "SCENE.toml")]
    scene: Option<PathBuf>,
    /// A region of interest as a mask (EXR of the same size; a pixel counts when any channel is
    /// above 0), named by its file name, or NAME=M.exr. Repeatable; two of one name are
    /// refused.
    #[arg(long = "mask", value_name = "M.exr")]
    masks: Vec<PathBuf>,
    /// A table to show, as JSON: {"title": "...", "columns": [...], "rows": [[...], ...],
    /// "notes": [...]} (cells strings or numbers). Repeatable. The timing-table bench writes one.
    #[arg(long = "table", value_name = "FILE.json")]
    tables: Vec<PathBuf>,
    /// A chart to show (SVG or PNG, copied into the folder), such as the speed-against-error
    /// chart. Repeatable.
    #[arg(long = "chart", value_name = "FILE.svg")]
    charts: Vec<PathBuf>,
    /// The page's title.
    #[arg(long, default_value = "photondiff report")]
    title: String,
    /// Exposure of the tone-mapped images in stops: radiance x 2^EV, then sRGB, clamped.
    #[arg(long, value_name = "EV", default_value_t = 0.0)]
    exposure: f64,
}

/// The largest `--exposure` in stops either way: 2^64 is far past any radiance worth showing.
const MAX_EXPOSURE: f64 = 64.0;

/// Reads an EXR for the report, refusing a non-finite pixel as `compare` does (the page's
/// table showed NaN).
fn read_finite(path: &Path) -> Result<Film, String> {
    let film = Film::read_exr(path)?;
    if let Some(i) = film.pixels.iter().position(|p| !p.is_finite()) {
        let w = film.width as usize;
        return Err(format!(
            "{}: pixel ({}, {}) is not finite ({:?})",
            path.display(),
            i % w,
            i / w,
            film.pixels[i].to_array()
        ));
    }
    Ok(film)
}

/// `LABEL=FILE` or `FILE` (captioned with its stem). A path that exists is never split;
/// `LABEL=` with no file is an error (it was read as the file "", named in the message as
/// nothing at all).
fn parse_render(arg: &str) -> Result<(String, PathBuf), String> {
    if !Path::new(arg).exists() {
        if let Some((label, file)) = arg.split_once('=') {
            if !label.is_empty() {
                if file.is_empty() {
                    return Err(format!("{arg:?}: no file after '=' (LABEL=FILE.exr)"));
                }
                return Ok((label.to_string(), PathBuf::from(file)));
            }
        }
    }
    let path = PathBuf::from(arg);
    let label = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| arg.to_string());
    Ok((label, path))
}

/// A reference that names its scene (`photondiff reference` writes `photondiff/scene_hash`)
/// must be of the scene whose regions are measured; one that does not is taken as it is.
fn check_reference_scene(reference: &Path, scene: &Path) -> Result<(), String> {
    let part = photondiff::render::part::read_part(reference)?;
    let hash = photondiff::scene::hash::hex(photondiff::scene::hash::scene_hash(scene)?);
    match part.metadata.get("photondiff/scene_hash") {
        Some(other) if *other != hash => Err(format!(
            "{}: a reference of another scene than {} (photondiff/scene_hash {other}, the \
             scene's {hash})",
            reference.display(),
            scene.display()
        )),
        _ => Ok(()),
    }
}

/// The scene's regions of interest for `reference`.
fn scene_regions(path: &Path, reference: &Film) -> Result<Vec<Region>, String> {
    let scene = load_scene(path).map_err(|e| e.to_string())?;
    if (scene.camera.width, scene.camera.height) != (reference.width, reference.height) {
        return Err(format!(
            "{}: the camera is {} x {} pixels but the reference is {} x {}",
            path.display(),
            scene.camera.width,
            scene.camera.height,
            reference.width,
            reference.height
        ));
    }
    let device = Device::new().map_err(|e| e.to_string())?;
    let embree = scene.build_embree(&device).map_err(|e| e.to_string())?;
    let regions = Regions::new(&scene, &embree, reference);
    Ok(report::scene_regions(&regions, reference.pixels.len()))
}

pub fn run(args: &ReportArgs) -> Result<(), String> {
    if !(args.exposure.is_finite() && args.exposure.abs() <= MAX_EXPOSURE) {
        return Err(format!(
            "--exposure must be a number of stops in [-{MAX_EXPOSURE}, {MAX_EXPOSURE}], got {}",
            super::shown(args.exposure)
        ));
    }
    let reference = read_finite(&args.reference)?;
    let mut renders = Vec::new();
    let mut scene_warnings = Vec::new();
    for arg in &args.renders {
        let (label, path) = parse_render(arg)?;
        // Two views of one caption could not be told apart on the page.
        if renders.iter().any(|r: &Render| r.label == label) {
            return Err(format!(
                "two renders are captioned '{label}': caption them apart (LABEL=FILE.exr)"
            ));
        }
        let film = read_finite(&path)?;
        if (film.width, film.height) != (reference.width, reference.height) {
            return Err(format!(
                "{} is {} x {} pixels but the reference {} is {} x {}",
                path.display(),
                film.width,
                film.height,
                args.reference.display(),
                reference.width,
                reference.height
            ));
        }
        ChannelImage::check_same_origin(&path, &args.reference)?;
        // Said on the page as well: it is what the figures below would not show.
        if let Some(warning) = ChannelImage::other_scene(&path, &args.reference)? {
            photondiff::stderr_line!("photondiff: warning: {warning}");
            scene_warnings.push(format!("Warning: {warning}."));
        }
        renders.push(Render { label, film });
    }
    let mut regions = match &args.scene {
        Some(scene) => {
            check_reference_scene(&args.reference, scene)?;
            scene_regions(scene, &reference)?
        }
        None => Vec::new(),
    };
    for path in &args.masks {
        let (w, h) = (reference.width as usize, reference.height as usize);
        // `NAME=M.exr` as a render's `LABEL=FILE` (the name was taken so, but the mask was
        // then read from the whole argument, which is no file).
        let (name, path) = parse_render(&path.to_string_lossy())?;
        // Two tables of one name could not be told apart, as two renders of one caption.
        if regions.iter().any(|r| r.name == name) {
            return Err(format!(
                "two regions are named '{name}': name the masks apart (NAME=M.exr)"
            ));
        }
        ChannelImage::check_same_origin(&path, &args.reference)?;
        let mask = read_mask(&path, w, h)?;
        regions.push(Region { name, mask });
    }
    let tables = args
        .tables
        .iter()
        .map(|p| Table::read(p))
        .collect::<Result<Vec<_>, _>>()?;
    for c in &args.charts {
        // The page shows a chart as an image: a browser draws SVG and PNG, not a .toml.
        let ext = c
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        if !matches!(ext.as_deref(), Some("svg" | "png")) {
            return Err(format!(
                "{}: a chart must be an SVG or PNG file (.svg, .png)",
                c.display()
            ));
        }
        std::fs::metadata(c).map_err(|e| format!("{}: cannot open: {e}", c.display()))?;
    }
    let mut notes = vec![format!("Reference: {}.", args.reference.display())];
    notes.extend(scene_warnings);
    if let Some(scene) = &args.scene {
        notes.push(format!(
            "Scene: {}. {}",
            scene.display(),
            report::REGIONS_NOTE
        ));
    }
    let report = Report {
        title: args.title.clone(),
        notes,
        reference: Render {
            label: "reference".into(),
            film: reference,
        },
        renders,
        regions,
        tables,
        charts: args.charts.iter().cloned().map(Chart::File).collect(),
        exposure: args.exposure,
    };
    let page = report::write(&report, &args.output)?;
    out!("report: {}", page.display());
    Ok(())
}
