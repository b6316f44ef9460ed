//! `photondiff merge`: the parts of a split render (`render --tile I/N`, `render --pass-range
//! A..B`) into the whole image.

use super::create_parent;
use photondiff::render::merge::merge;
use photondiff::render::part::{display_pixels, read_part};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct MergeArgs {
    /// The parts: EXR files written by `photondiff render --tile I/N` (one per tile) or
    /// `--pass-range A..B` (ranges that together cover the passes), in any order.
    #[arg(required = true, value_name = "PARTS")]
    parts: Vec<PathBuf>,
    /// The whole image (linear float RGB EXR with the parts' settings and the statistics of the
    /// whole in its attributes).
    #[arg(short = 'o', long = "output", value_name = "OUT.exr")]
    output: PathBuf,
    /// sRGB preview of the whole. Default: the EXR path with a .png extension (none where -o
    /// is a device or pipe, such as /dev/null).
    #[arg(long, value_name = "OUT.png")]
    png: Option<PathBuf>,
    /// Write the statistics of the whole (counts and times summed over the parts) as JSON.
    #[arg(long, value_name = "FILE")]
    stats_json: Option<PathBuf>,
}

/// Runs `photondiff merge`; nothing is written unless every check passes.
/// What a merge of tiles holds per pixel of the whole image at its peak: the parts' films, the
/// merged film and its EXR and PNG. Measured (stop 56): 6.7 GB for 11585 x 11585 (50 bytes a
/// pixel); with some margin. Pass-range parts each hold a whole tile's exact sums besides.
const MERGE_PEAK_BYTES_PER_PIXEL: u64 = 64;

pub fn run(args: &MergeArgs) -> Result<(), String> {
    let png = super::preview_path(&args.output, args.png.as_deref());
    if let Some(png) = &png {
        super::check_image_names(&args.output, png)?;
    }
    let png_flag = if args.png.is_some() {
        "--png"
    } else {
        "the PNG preview (-o with .png)"
    };
    let mut outputs = vec![("-o", args.output.as_path())];
    outputs.extend(png.as_deref().map(|p| (png_flag, p)));
    outputs.extend(args.stats_json.as_deref().map(|p| ("--stats-json", p)));
    let inputs: Vec<_> = args
        .parts
        .iter()
        .map(|p| ("part being merged", p.as_path()))
        .collect();
    super::check_outputs(&outputs, &inputs)?;
    // The whole image's memory, before any part is read: the parts are all held at once
    // beside it (the sixteen tiles of an 11585 x 11585 image, each rendered under a 3 GB
    // limit, aborted the merge under it: "memory allocation of 200188800 bytes failed").
    if let Some(pixels) = args.parts.first().and_then(|p| display_pixels(p)) {
        photondiff::render::film::check_image_memory(
            &format!("the whole image's {pixels} pixels"),
            "to merge",
            pixels,
            MERGE_PEAK_BYTES_PER_PIXEL,
        )?;
    }
    let parts = args
        .parts
        .iter()
        .map(|p| read_part(p))
        .collect::<Result<Vec<_>, _>>()?;
    let merged = merge(&parts)?;
    // Parts stopped by a signal (Ctrl-C, a batch system's time limit) hold the passes they
    // finished: parts of other pass counts are refused, but parts all stopped alike merge.
    let stopped: Vec<String> = parts
        .iter()
        .filter(|p| {
            p.metadata
                .get("photondiff/passes_stopped_by")
                .map(String::as_str)
                == Some("interrupted")
        })
        .map(|p| p.path.display().to_string())
        .collect();
    if let Some(first) = stopped.first() {
        let passes = parts[0]
            .metadata
            .get("photondiff/passes")
            .map_or("?", |p| p.as_str());
        photondiff::stderr_line!(
            "photondiff: warning: {} of the {} parts {} interrupted ({first}{}): the image holds \
             the {passes} passes each finished, not the passes asked for",
            stopped.len(),
            parts.len(),
            if stopped.len() == 1 { "was" } else { "were" },
            if stopped.len() > 1 { ", ..." } else { "" },
        );
    }
    create_parent(&args.output)?;
    if let Some(png) = &png {
        create_parent(png)?;
    }
    merged.film.write_exr(&args.output, &merged.metadata)?;
    if let Some(png) = &png {
        merged.film.write_png(png)?;
    }
    if let Some(path) = &args.stats_json {
        create_parent(path)?;
        let json = serde_json::to_string_pretty(&merged.stats).map_err(|e| e.to_string())?;
        photondiff::util::atomic::write_bytes(path, json.as_bytes())?;
    }
    let preview = png.map_or_else(
        || " (no preview beside a device or pipe: --png for one)".to_string(),
        |png| format!(" and {}", png.display()),
    );
    out!(
        "merged {} part{} into {}{preview}",
        parts.len(),
        if parts.len() == 1 { "" } else { "s" },
        args.output.display(),
    );
    Ok(())
}
