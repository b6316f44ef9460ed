//! The `photondiff` command line.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod cli;

#[derive(Parser)]
#[command(
    name = "photondiff",
    // The Embree backend build.rs chose (3 or 4) is part of what this binary is.
    version = concat!(env!("CARGO_PKG_VERSION"), " (Embree ", env!("PHOTONDIFF_EMBREE_VERSION"), ")"),
    about = "Photon mapping with photon differentials; ray queries through Intel Embree"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

// Parsed once per run: the size of the largest variant does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand)]
enum Command {
    /// Render a scene file to a linear float EXR and an sRGB PNG preview.
    Render(cli::render::RenderArgs),
    /// Make a scene's reference image: direct light supersampled, the rest light-traced, with
    /// two independent halves for its noise.
    Reference(cli::reference::ReferenceArgs),
    /// Join the parts of a split render (`render --tile I/N`) into the whole image.
    Merge(cli::merge::MergeArgs),
    /// Trace a scene's photon maps once and write them for `render --photon-maps`.
    Photons(cli::photons::PhotonsArgs),
    /// Compare an image with a reference: relRMSE, RMSE, PSNR, mean ratio and SSIM, over the
    /// whole image or masks; optionally an error map and a threshold for scripts.
    Compare(cli::compare::CompareArgs),
    /// Write an HTML report (one folder, no network): renders beside a reference with
    /// synchronized zoom and pan, error maps, crops of the regions of interest, tables, charts.
    Report(cli::report::ReportArgs),
    /// Print what a mesh (.obj, .ply) or scene (.toml) file holds: triangles, bounds, dropped
    /// and repaired elements, and the memory its meshes take.
    Info(cli::info::InfoArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => cli::render::run(&args),
        Command::Reference(args) => cli::reference::run(&args),
        Command::Merge(args) => cli::merge::run(&args),
        Command::Photons(args) => cli::photons::run(&args),
        Command::Compare(args) => cli::compare::run(&args),
        Command::Report(args) => cli::report::run(&args),
        Command::Info(args) => cli::info::run(&args),
    };
    match result {
        // Stopped early by Ctrl-C (the conventional 128 + SIGINT), with what was done written.
        Ok(()) if photondiff::util::interrupt::honoured() => ExitCode::from(130),
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("photondiff: error: {message}");
            ExitCode::FAILURE
        }
    }
}
