//! The `photondiff` command line.

// Standard error through `photondiff::stderr_line!` (`util::stderr`): `eprintln!` panics when
// it cannot write, and a closed log pipe ended renders with status 101 and no image.
#![deny(clippy::print_stderr)]

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
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
    /// Join the parts of a split render (`render --tile I/N`, `render --pass-range A..B`) into
    /// the whole image.
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

/// Value names of the options that take numbers (one or a list).
const NUMBER_VALUE_NAMES: [&str; 9] = ["N", "X", "P", "R", "S", "SECONDS", "ALPHA", "EV", "A,B"];

/// The command line, with every option that takes a number taking a negative one as its value:
/// clap would otherwise read `--overlap -1` as an unknown flag `-1` and answer with a tip
/// about `--`, where the option's own check names it and its range.
fn command() -> clap::Command {
    Cli::command().mut_subcommands(|sub| {
        sub.mut_args(|arg| {
            let takes_number = arg.get_value_names().is_some_and(|names| {
                names
                    .iter()
                    .all(|n| NUMBER_VALUE_NAMES.contains(&n.as_str()))
            });
            if takes_number {
                arg.allow_negative_numbers(true)
            } else {
                arg
            }
        })
    })
}

/// The ids of the options `matches` took from the command line (not from their defaults).
fn given(matches: &clap::ArgMatches) -> Vec<String> {
    matches
        .ids()
        .filter(|id| {
            matches.value_source(id.as_str()) == Some(clap::parser::ValueSource::CommandLine)
        })
        .map(|id| id.to_string())
        .collect()
}

fn main() -> ExitCode {
    let matches = command().get_matches();
    let mut cli =
        Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.format(&mut command()).exit());
    if let (Command::Render(args), Some(("render", sub))) = (&mut cli.command, matches.subcommand())
    {
        args.given = given(sub);
    }
    let ran = match cli.command {
        Command::Render(args) => cli::render::run(&args),
        Command::Reference(args) => cli::reference::run(&args),
        Command::Merge(args) => cli::merge::run(&args),
        Command::Photons(args) => cli::photons::run(&args),
        Command::Compare(args) => cli::compare::run(&args),
        Command::Report(args) => cli::report::run(&args),
        Command::Info(args) => cli::info::run(&args),
    };
    // What the command printed is part of its output (`compare > results.txt`).
    let result = ran.and_then(|()| match cli::stdout_failure() {
        Some(e) => Err(e.clone()),
        None => Ok(()),
    });
    match result {
        // Stopped early by Ctrl-C (the conventional 128 + SIGINT; 143 for SIGTERM), with what
        // was done written.
        Ok(()) if photondiff::util::interrupt::honoured() => {
            ExitCode::from(photondiff::util::interrupt::exit_status())
        }
        Ok(()) => {
            // The signal's own line promised to drop the work under way: it came after the
            // last of it had begun (the last pass's last tiles) or during the writing, and cut
            // nothing. Said, or the run's output contradicts itself (a hostile user's sweep).
            if photondiff::util::interrupt::requested() {
                photondiff::stderr_line!(
                    "photondiff: interrupted too late to cut anything: the work asked for was \
                     done and written"
                );
            }
            ExitCode::SUCCESS
        }
        Err(message) => {
            photondiff::stderr_line!("photondiff: error: {message}");
            if let Some(trace) = cli::write_trace_of_failure(&message) {
                photondiff::stderr_line!(
                    "photondiff: the trace of the failed run is in {}",
                    trace.display()
                );
            }
            cli::remove_created_folders();
            // Stopped by a signal before anything could be written: 128 + its number all the
            // same.
            match photondiff::util::interrupt::requested() {
                true => ExitCode::from(photondiff::util::interrupt::exit_status()),
                false => ExitCode::FAILURE,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every option whose value is a number takes `-1` as its value (to be refused by its own
    /// check, or by clap naming the option), never as an unknown flag.
    #[test]
    fn negative_numbers_reach_every_numeric_option() {
        let mut checked = 0;
        for sub in command().get_subcommands() {
            for arg in sub.get_arguments() {
                let (Some(long), Some(names)) = (arg.get_long(), arg.get_value_names()) else {
                    continue;
                };
                if !names
                    .iter()
                    .all(|n| NUMBER_VALUE_NAMES.contains(&n.as_str()))
                {
                    continue;
                }
                let option = format!("--{long}");
                let argv = ["photondiff", sub.get_name(), option.as_str(), "-1"];
                if let Err(e) = command().try_get_matches_from(argv) {
                    assert_ne!(
                        e.kind(),
                        clap::error::ErrorKind::UnknownArgument,
                        "{argv:?}: {e}"
                    );
                }
                checked += 1;
            }
        }
        // render's --overlap, --global-aim, --gather-near, --passes, ...; photons' and
        // reference's counts and seeds; compare's thresholds; report's exposure.
        assert!(checked >= 30, "{checked}");
    }

    /// The unknown-flag reading this guards against: an option of a number left without the
    /// setting reads `-1` as a flag of its own.
    #[test]
    fn without_the_setting_a_negative_number_is_an_unknown_flag() {
        let e = Cli::command()
            .try_get_matches_from(["photondiff", "render", "s.toml", "--overlap", "-1"])
            .unwrap_err();
        assert_eq!(e.kind(), clap::error::ErrorKind::UnknownArgument);
        let m = command()
            .try_get_matches_from(["photondiff", "render", "s.toml", "--overlap", "-1"])
            .unwrap();
        let render = m.subcommand_matches("render").unwrap();
        assert_eq!(render.get_one::<f64>("overlap"), Some(&-1.0));
    }
}
