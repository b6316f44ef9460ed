//! `photondiff compare IMAGE REFERENCE`: relRMSE, RMSE, PSNR, mean ratio and SSIM of an image
//! against a reference, over the whole image or over masks; an error map; a threshold for
//! scripts.

use super::create_parent;
use photondiff::reference::channels::ChannelImage;
use photondiff::reference::compare::{
    check_same_shape, measure, read_mask, relative_error_per_pixel, ErrorScale, RegionMetrics,
};
use photondiff::reference::error_map;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct CompareArgs {
    /// The image to judge (EXR, any channels; the first layer).
    image: PathBuf,
    /// The reference it is judged against (EXR with the same size and channels).
    reference: PathBuf,
    /// Measure over this mask's pixels (an EXR of the same size; a pixel counts when any of its
    /// channels is above 0) instead of the whole image. Repeatable: each mask is reported by
    /// its file name.
    #[arg(long = "mask", value_name = "M.exr")]
    masks: Vec<PathBuf>,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
    /// Write a false-colour map of the per-pixel relative error (RMS over channels of I - R,
    /// over the reference's mean; absolute, and said so, against a reference that is zero
    /// everywhere) with a colour bar to OUT.png.
    #[arg(long, value_name = "OUT.png")]
    error_map: Option<PathBuf>,
    /// Top of the error map's colour scale. Default: the 99th percentile of the per-pixel
    /// relative error (over the masks' pixels, when given).
    #[arg(long, value_name = "X")]
    error_map_max: Option<f64>,
    /// Exit with status 1 when the relRMSE of any measured region (the whole image, or each
    /// mask) exceeds X, naming the region and its value.
    #[arg(long, value_name = "X")]
    max_relrmse: Option<f64>,
}

/// A mask's name in the output: its file name without the extension.
fn mask_name(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

fn cell(v: Option<f64>, digits: usize) -> String {
    v.map_or("-".into(), |v| format!("{v:.digits$}"))
}

fn print_table(args: &CompareArgs, image: &ChannelImage, rows: &[RegionMetrics]) {
    out!(
        "{} against the reference {}: {} x {} pixels, channels {}",
        args.image.display(),
        args.reference.display(),
        image.width,
        image.height,
        image.names.join(",")
    );
    out!(
        "{:<16} {:>9} {:>10} {:>12} {:>9} {:>10} {:>8}",
        "region",
        "pixels",
        "relRMSE",
        "RMSE",
        "PSNR dB",
        "mean ratio",
        "SSIM"
    );
    for r in rows {
        out!(
            "{:<16} {:>9} {:>10} {:>12} {:>9} {:>10} {:>8}",
            r.name,
            r.pixels,
            cell(r.rel_rmse, 5),
            format!("{:.5e}", r.rmse),
            cell(r.psnr_db, 2),
            cell(r.mean_ratio, 5),
            cell(r.ssim, 4)
        );
    }
    out!(
        "relRMSE = sqrt(mean((I - R)^2)) / mean(R) over pixels and channels (alpha excluded); \
         PSNR peak = the reference's largest value in the region; SSIM on sRGB luminance, \
         8 x 8 windows touching the region; '-' = undefined"
    );
}

pub fn run(args: &CompareArgs) -> Result<(), String> {
    if args.error_map_max.is_some() && args.error_map.is_none() {
        // It was read by nothing, without a word.
        return Err("--error-map-max sets the error map's scale: it needs --error-map".into());
    }
    if let Some(path) = &args.error_map {
        let inputs = [
            ("image", args.image.as_path()),
            ("reference", &args.reference),
        ];
        super::check_outputs(&[("--error-map", path)], &inputs)?;
    }
    let image = ChannelImage::read(&args.image)?;
    let reference = ChannelImage::read(&args.reference)?;
    check_same_shape(&image, &args.image, &reference, &args.reference)?;
    // Two tiles of one size but from other places are not the same pixels.
    ChannelImage::check_same_origin(&args.image, &args.reference)?;
    if let Some(warning) = ChannelImage::other_scene(&args.image, &args.reference)? {
        photondiff::stderr_line!("photondiff: warning: {warning}");
    }
    for mask in &args.masks {
        ChannelImage::check_same_origin(mask, &args.image)?;
    }
    image.check_finite(&args.image)?;
    reference.check_finite(&args.reference)?;
    if let Some(x) = args.max_relrmse {
        if !(x >= 0.0 && x.is_finite()) {
            return Err(format!(
                "--max-relrmse {}: must be a finite number >= 0",
                super::shown(x)
            ));
        }
    }
    let masks = args
        .masks
        .iter()
        .map(|path| Ok((mask_name(path), read_mask(path, image.width, image.height)?)))
        .collect::<Result<Vec<_>, String>>()?;
    // Rows of one name could not be told apart (nor by --max-relrmse's message).
    for (k, (name, _)) in masks.iter().enumerate() {
        if masks[..k].iter().any(|(other, _)| other == name) {
            return Err(format!(
                "two masks are named '{name}' (a mask is named by its file name without the \
                 extension): rename one"
            ));
        }
    }
    let rows: Vec<RegionMetrics> = if masks.is_empty() {
        vec![measure("image", &image, &reference, None)]
    } else {
        masks
            .iter()
            .map(|(name, m)| measure(name, &image, &reference, Some(m)))
            .collect()
    };

    if let Some(path) = &args.error_map {
        let (errors, scale) = relative_error_per_pixel(&image, &reference);
        if scale == ErrorScale::Absolute {
            photondiff::stderr_line!(
                "photondiff: note: the reference is zero everywhere: the error map shows \
                 absolute errors (RMS over channels of I - R)"
            );
        }
        let union: Option<Vec<bool>> = (!masks.is_empty()).then(|| {
            (0..errors.len())
                .map(|i| masks.iter().any(|(_, m)| m[i]))
                .collect()
        });
        let max = match args.error_map_max {
            Some(x) if x > 0.0 && x.is_finite() => x,
            Some(x) => return Err(format!("--error-map-max {x}: must be a finite number > 0")),
            None => error_map::default_max(&errors, union.as_deref()),
        };
        create_parent(path)?;
        let (w, h, inside) = (image.width, image.height, union.as_deref());
        error_map::render(&errors, w, h, max, inside, scale.title()).write_png(path)?;
    }

    if args.json {
        let json = serde_json::json!({
            "image": args.image.display().to_string(),
            "reference": args.reference.display().to_string(),
            "width": image.width,
            "height": image.height,
            "channels": image.names,
            "measured_channels": reference.measured_channels().iter()
                .map(|&c| reference.names[c].clone()).collect::<Vec<_>>(),
            "regions": rows,
        });
        out!(
            "{}",
            serde_json::to_string_pretty(&json).map_err(|e| e.to_string())?
        );
    } else {
        print_table(args, &image, &rows);
    }

    if let Some(max) = args.max_relrmse {
        if let Some(r) = rows.iter().find(|r| r.rel_rmse.is_none()) {
            return Err(format!(
                "relRMSE over {} is undefined (the reference's mean is 0) and cannot be checked against --max-relrmse {max}",
                r.name
            ));
        }
        let over: Vec<String> = rows
            .iter()
            .filter_map(|r| {
                let e = r.rel_rmse?;
                (e > max).then(|| format!("{} ({e:.5})", r.name))
            })
            .collect();
        if !over.is_empty() {
            return Err(format!(
                "relRMSE exceeds --max-relrmse {max} over {}",
                over.join(", ")
            ));
        }
    }
    Ok(())
}
