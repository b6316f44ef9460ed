//! Which of `render`'s settings a render reads: one table that [`super::checks`] (an option
//! given where nothing reads it is refused) and [`super::metadata`] (an image's attributes
//! name the settings its estimator read, no more) both ask, so that the two cannot disagree.

use super::estimator_name;
use photondiff::estimate::EstimatorKind;

/// What reads a setting that only some renders read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Reader {
    /// Every estimator with photon maps (not `direct`, not `lighttrace`).
    PhotonMaps,
    /// The photons' footprints: estimators with photon maps, `jensen` only with final gathering
    /// (its k nearest photons have none; its radiance map sizes its points by them).
    Footprints,
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
        Reader::PhotonMaps,
    ),
    setting(
        "probe_walls",
        "--probe-walls",
        "probe_walls",
        Reader::PhotonMaps,
    ),
    setting("alpha", "--alpha", "alpha", Reader::PhotonMaps),
    setting(
        "global_alpha",
        "--global-alpha",
        "global_alpha",
        Reader::Footprints,
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
    fn reads(self, kind: EstimatorKind, gather_rays: u32) -> bool {
        use EstimatorKind::*;
        let maps = has_maps(kind);
        match self {
            Reader::PhotonMaps => maps,
            Reader::Footprints => maps && (kind != Jensen || gather_rays > 0),
            Reader::FinalGathering => maps && gather_rays > 0,
            Reader::Estimator(owner) => kind == owner,
            Reader::CameraRays => kind != Lighttrace,
            Reader::LightTracer => kind == Lighttrace,
        }
    }

    /// Why `option` does nothing in a render with estimator `kind`.
    fn refusal(self, option: &str, kind: EstimatorKind) -> String {
        let name = estimator_name(kind);
        match self {
            Reader::PhotonMaps | Reader::Footprints if !has_maps(kind) => {
                format!("{option} does not apply to --estimator {name} (it uses no photon maps)")
            }
            Reader::PhotonMaps => unreachable!("read by every estimator with photon maps"),
            Reader::Footprints => format!(
                "{option} does not apply to --estimator jensen without --gather-rays (its k \
                 nearest photons have no footprints)"
            ),
            Reader::FinalGathering => {
                format!("{option} applies with --gather-rays only (final gathering)")
            }
            Reader::Estimator(owner) => {
                format!(
                    "{option} applies to --estimator {} only",
                    estimator_name(owner)
                )
            }
            Reader::CameraRays => format!(
                "{option} does not apply to --estimator lighttrace (its paths reach the camera \
                 from the lights: it traces no camera rays)"
            ),
            Reader::LightTracer => format!("{option} applies to --estimator lighttrace only"),
        }
    }
}

/// Whether estimator `kind` uses photon maps.
pub(super) fn has_maps(kind: EstimatorKind) -> bool {
    !matches!(kind, EstimatorKind::Direct | EstimatorKind::Lighttrace)
}

/// The first setting among `given` (clap's ids of the options given on the command line) that a
/// render with estimator `kind` and `gather_rays` final-gather rays does not read, refused with
/// why.
pub(super) fn refuse_unread(
    given: &[String],
    kind: EstimatorKind,
    gather_rays: u32,
) -> Result<(), String> {
    match SETTINGS
        .iter()
        .find(|s| given.iter().any(|g| g == s.id) && !s.reader.reads(kind, gather_rays))
    {
        Some(s) => Err(s.reader.refusal(s.option, kind)),
        None => Ok(()),
    }
}

/// Whether a render with estimator `kind` (and `gather_rays` final-gather rays) reads the
/// setting its EXR attribute `attribute` names (the attributes of settings every render reads:
/// yes).
pub(super) fn reads_attribute(kind: EstimatorKind, gather_rays: u32, attribute: &str) -> bool {
    SETTINGS
        .iter()
        .find(|s| s.attribute == Some(attribute))
        .is_none_or(|s| s.reader.reads(kind, gather_rays))
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
        let refused =
            |kind, gather_rays, id: &str| refuse_unread(&[id.to_string()], kind, gather_rays).err();
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
        for kind in [
            Direct,
            Lighttrace,
            Pd,
            Jensen,
            Multisampled,
            Coplanar,
            Integrated,
        ] {
            for gather_rays in [0, 8] {
                for s in SETTINGS.iter().filter(|s| s.attribute.is_some()) {
                    assert_eq!(
                        refused(kind, gather_rays, s.id).is_none(),
                        reads_attribute(kind, gather_rays, s.attribute.unwrap()),
                        "{kind:?} {gather_rays} {}",
                        s.id
                    );
                }
            }
        }
    }
}
