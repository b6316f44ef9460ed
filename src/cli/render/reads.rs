//! Which of `render`'s settings a render reads: one table that [`super::checks`] (an option
//! given where nothing reads it is refused) and [`super::metadata`] (an image's attributes
//! name the settings its estimator read, no more) both ask, so that the two cannot disagree.

use super::RenderArgs;
use photondiff::estimate::EstimatorKind;
use photondiff::render::defaults::RenderDefaults;

/// What decides whether a render reads a setting.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Run {
    pub kind: EstimatorKind,
    /// Final-gather rays (`--gather-rays`).
    pub gather_rays: u32,
    /// Whether photons probe for walls (`--probe-walls`, or the estimator's default): the
    /// mirror photons beyond a wall depend on the footprints then, even for `jensen`.
    pub probe_walls: bool,
    /// Whether the render is one pass (`--passes 1`, or the estimator's default without a
    /// budget or target).
    pub one_pass: bool,
    /// Whether `--passes` was given.
    pub passes_given: bool,
}

impl Run {
    /// The run `args` asks for, of `passes` (`None`: as many as a budget or target take).
    pub fn of(args: &RenderArgs, kind: EstimatorKind, passes: Option<u64>) -> Self {
        Run {
            kind,
            gather_rays: args.gather_rays,
            probe_walls: args
                .photons
                .probe_walls
                .unwrap_or(RenderDefaults::for_estimator(kind).probe_walls),
            one_pass: passes == Some(1),
            passes_given: args.passes.is_some(),
        }
    }
}

/// What reads a setting that only some renders read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Reader {
    /// Every estimator with photon maps (not `direct`, not `lighttrace`).
    PhotonMaps,
    /// The global map's aimed emissions: estimators with photon maps, without final gathering
    /// (whose map is never aimed: the same image to the bit with any `--global-aim`).
    AimedGlobalMap,
    /// The photons' footprints: estimators with photon maps, `jensen` only with final gathering
    /// (its k nearest photons have none; its radiance map sizes its points by them) or probed
    /// walls (a wall is found within a photon's footprint, and its mirror photon added).
    Footprints,
    /// The footprints' schedule from pass to pass (`--alpha`): photon maps, more than one pass.
    Schedule,
    /// The global map's schedule (`--global-alpha`): footprints, more than one pass.
    GlobalSchedule,
    /// Final gathering (`--gather-rays` above 0).
    FinalGathering,
    /// One estimator alone.
    Estimator(EstimatorKind),
    /// Estimators that trace camera rays (all but `lighttrace`).
    CameraRays,
    /// The light tracer (`lighttrace`).
    LightTracer,
}

/// A setting only some renders read: its id (clap's), its option, its EXR attribute's name
/// (where the image names it), and what reads it. The settings not listed are read by every
/// render.
struct Setting {
    id: &'static str,
    option: &'static str,
    attribute: Option<&'static str>,
    reader: Reader,
}

const fn setting(
    id: &'static str,
    option: &'static str,
    attribute: &'static str,
    reader: Reader,
) -> Setting {
    Setting {
        id,
        option,
        attribute: Some(attribute),
        reader,
    }
}

/// In the order `render` checks them.
const SETTINGS: &[Setting] = &[
    setting("k", "--k", "k", Reader::Estimator(EstimatorKind::Jensen)),
    setting(
        "ms_grid",
        "--ms-grid",
        "ms_grid",
        Reader::Estimator(EstimatorKind::Multisampled),
    ),
    setting(
        "coplanar_vertices",
        "--coplanar-vertices",
        "coplanar_vertices",
        Reader::Estimator(EstimatorKind::Coplanar),
    ),
    setting("global_photons", "--photons", "photons", Reader::PhotonMaps),
    setting(
        "caustic_photons",
        "--caustic-photons",
        "caustic_photons",
        Reader::PhotonMaps,
    ),
    setting("overlap", "--overlap", "overlap", Reader::Footprints),
    setting(
        "global_aim",
        "--global-aim",
        "global_aim",
        Reader::AimedGlobalMap,
    ),
    setting(
        "probe_walls",
        "--probe-walls",
        "probe_walls",
        Reader::PhotonMaps,
    ),
    setting("alpha", "--alpha", "alpha", Reader::Schedule),
    setting(
        "global_alpha",
        "--global-alpha",
        "global_alpha",
        Reader::GlobalSchedule,
    ),
    setting(
        "gather_rays",
        "--gather-rays",
        "gather_rays",
        Reader::PhotonMaps,
    ),
    setting("view_grid", "--view-grid", "view_grid", Reader::CameraRays),
    setting("edge_grid", "--edge-grid", "edge_grid", Reader::CameraRays),
    setting("max_depth", "--max-depth", "max_depth", Reader::CameraRays),
    setting(
        "split_depth",
        "--split-depth",
        "split_depth",
        Reader::CameraRays,
    ),
    setting(
        "area_samples",
        "--area-samples",
        "area_samples",
        Reader::CameraRays,
    ),
    setting(
        "footprint_shadow_rays",
        "--footprint-shadow-rays",
        "footprint_shadow_rays",
        Reader::CameraRays,
    ),
    setting(
        "light_paths",
        "--light-paths",
        "light_paths",
        Reader::LightTracer,
    ),
    setting(
        "gather_near",
        "--gather-near",
        "gather_near",
        Reader::FinalGathering,
    ),
    Setting {
        id: "photon_maps",
        option: "--photon-maps",
        attribute: None,
        reader: Reader::PhotonMaps,
    },
];

impl Reader {
    fn reads(self, run: &Run) -> bool {
        use EstimatorKind::*;
        let maps = run.kind.reads_maps();
        let footprints =
            run.kind.reads_footprints() || (maps && (run.gather_rays > 0 || run.probe_walls));
        match self {
            Reader::PhotonMaps => maps,
            Reader::AimedGlobalMap => maps && run.gather_rays == 0,
            Reader::Footprints => footprints,
            Reader::Schedule => maps && !run.one_pass,
            Reader::GlobalSchedule => footprints && !run.one_pass,
            Reader::FinalGathering => maps && run.gather_rays > 0,
            Reader::Estimator(owner) => run.kind == owner,
            Reader::CameraRays => run.kind != Lighttrace,
            Reader::LightTracer => run.kind == Lighttrace,
        }
    }

    /// Why `option` does nothing in `run`.
    fn refusal(self, option: &str, run: &Run) -> String {
        let name = run.kind.name();
        let of_maps = !matches!(
            self,
            Reader::Estimator(_) | Reader::CameraRays | Reader::LightTracer
        );
        if of_maps && !run.kind.reads_maps() {
            return format!(
                "{option} does not apply to --estimator {name} (it uses no photon maps)"
            );
        }
        match self {
            Reader::AimedGlobalMap => format!(
                "{option} does not apply with --gather-rays (final gathering's map is not aimed)"
            ),
            Reader::Schedule | Reader::GlobalSchedule if run.one_pass => {
                let why = if run.passes_given {
                    "--passes 1".to_string()
                } else {
                    format!("one pass is the default of --estimator {name}")
                };
                format!(
                    "{option} does not apply to a one-pass render ({why}): it shrinks the \
                     footprints from one pass to the next; give --passes, --time-budget or \
                     --target-noise for more"
                )
            }
            Reader::Footprints | Reader::GlobalSchedule => format!(
                "{option} does not apply to --estimator jensen without --gather-rays or \
                 --probe-walls (its k nearest photons have no footprints)"
            ),
            Reader::FinalGathering => {
                format!("{option} applies with --gather-rays only (final gathering)")
            }
            Reader::Estimator(owner) => {
                format!("{option} applies to --estimator {} only", owner.name())
            }
            Reader::CameraRays => format!(
                "{option} does not apply to --estimator lighttrace (its paths reach the camera \
                 from the lights: it traces no camera rays)"
            ),
            Reader::LightTracer => format!("{option} applies to --estimator lighttrace only"),
            Reader::PhotonMaps | Reader::Schedule => {
                unreachable!("read by every estimator with photon maps in a run of passes")
            }
        }
    }
}

/// The first setting among `given` (clap's ids of the options given on the command line) that
/// `run` does not read, refused with why.
pub(super) fn refuse_unread(given: &[String], run: &Run) -> Result<(), String> {
    match SETTINGS
        .iter()
        .find(|s| given.iter().any(|g| g == s.id) && !s.reader.reads(run))
    {
        Some(s) => Err(s.reader.refusal(s.option, run)),
        None => Ok(()),
    }
}

/// Whether `run` reads the setting of clap's id `id` (`photons` asks what the render that
/// reads its maps will read).
pub(crate) fn reads_id(run: &Run, id: &str) -> bool {
    SETTINGS
        .iter()
        .find(|s| s.id == id)
        .is_none_or(|s| s.reader.reads(run))
}

/// Whether `run` reads the setting its EXR attribute `attribute` names (the attributes of
/// settings every render reads: yes).
pub(super) fn reads_attribute(run: &Run, attribute: &str) -> bool {
    SETTINGS
        .iter()
        .find(|s| s.attribute == Some(attribute))
        .is_none_or(|s| s.reader.reads(run))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every setting of the table is one of `render`'s options, under its id and its long
    /// name: a misspelt id would never be refused, whatever was given.
    #[test]
    fn the_table_names_renders_options() {
        let command = crate::command();
        let render = command.find_subcommand("render").unwrap();
        for s in SETTINGS {
            let arg = render
                .get_arguments()
                .find(|a| a.get_id() == s.id)
                .unwrap_or_else(|| panic!("no render option with id {}", s.id));
            assert_eq!(
                arg.get_long().map(|l| format!("--{l}")).as_deref(),
                Some(s.option)
            );
        }
    }

    /// An option is refused exactly where the image would not name it, and with the reason
    /// of what reads it; `--gather-rays 0` with `direct` too (it was let through: only a
    /// count above 0 was checked).
    #[test]
    fn refused_where_not_read() {
        use EstimatorKind::*;
        let run = |kind, gather_rays| Run {
            kind,
            gather_rays,
            probe_walls: false,
            one_pass: false,
            passes_given: false,
        };
        let refused = |kind, gather_rays, id: &str| {
            refuse_unread(&[id.to_string()], &run(kind, gather_rays)).err()
        };
        assert_eq!(
            refused(Direct, 0, "gather_rays").as_deref(),
            Some("--gather-rays does not apply to --estimator direct (it uses no photon maps)")
        );
        assert_eq!(refused(Pd, 0, "gather_rays"), None);
        assert_eq!(
            refused(Pd, 0, "gather_near").as_deref(),
            Some("--gather-near applies with --gather-rays only (final gathering)")
        );
        assert_eq!(refused(Pd, 8, "gather_near"), None);
        // Final gathering's map is not aimed (the same image with any --global-aim).
        assert_eq!(refused(Pd, 0, "global_aim"), None);
        assert_eq!(
            refused(Integrated, 8, "global_aim").as_deref(),
            Some("--global-aim does not apply with --gather-rays (final gathering's map is not aimed)")
        );
        // Jensen's mirror photons beyond walls are found by the footprints.
        let jensen = |probe_walls, one_pass, id: &str| {
            let run = Run {
                probe_walls,
                one_pass,
                ..run(Jensen, 0)
            };
            refuse_unread(&[id.to_string()], &run).err()
        };
        assert!(jensen(false, false, "overlap").is_some());
        assert_eq!(jensen(true, false, "overlap"), None);
        // A one-pass render has no schedule to shrink its footprints by.
        assert_eq!(jensen(false, false, "alpha"), None);
        assert_eq!(
            jensen(true, true, "alpha").as_deref(),
            Some(
                "--alpha does not apply to a one-pass render (one pass is the default of \
                 --estimator jensen): it shrinks the footprints from one pass to the next; give \
                 --passes, --time-budget or --target-noise for more"
            )
        );
        // Every kind the command line takes: a new one is checked without being named here.
        for &kind in <EstimatorKind as clap::ValueEnum>::value_variants() {
            for gather_rays in [0, 8] {
                for s in SETTINGS.iter().filter(|s| s.attribute.is_some()) {
                    assert_eq!(
                        refused(kind, gather_rays, s.id).is_none(),
                        reads_attribute(&run(kind, gather_rays), s.attribute.unwrap()),
                        "{kind:?} {gather_rays} {}",
                        s.id
                    );
                }
            }
        }
    }
}
