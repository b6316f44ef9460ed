//! Every estimator on every stress scene (`scenes/stress/`), at 80 x 60: no NaN, infinite,
//! negative or impossibly bright pixel; the image energy where the reference is lit within a
//! stated tolerance of a light-traced reference's, and the photon light in it near the
//! reference's; guards counted where footprints degenerate.

use photondiff::embree::Device;
use photondiff::estimate::EstimatorKind;
use photondiff::photons::footprint::Guards;
use photondiff::photons::map::{PathClass, PhotonMap};
use photondiff::photons::options::PhotonOptions;
use photondiff::photons::PhotonMaps;
use photondiff::reference::experiment::Method;
use photondiff::reference::light_tracer::{LightTraceOptions, LightTracer};
use photondiff::reference::metrics::Regions;
use photondiff::reference::stability::{bad_pixels, energy_error, radiance_bound};
use photondiff::render::stats::Stats;
use photondiff::render::trace_photon_maps;
use photondiff::scene::file::load_scene;
use photondiff::scene::Scene;
use std::path::Path;

/// Image energy tolerance where the reference is lit: direct light is computed alike, the photon
/// maps differ by noise, blur and guarded footprints.
const ENERGY_TOLERANCE: f64 = 0.15;

fn scene(file: &str) -> Scene {
    let mut scene = load_scene(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("scenes")
            .join(file),
    )
    .unwrap();
    scene.camera = scene.camera.with_resolution(80, 60);
    scene
}

/// Renders `scene` with every method from photon maps of the given counts, checks the promises,
/// and returns the caustic map's guard count.
fn check(name: &str, scene: &Scene, global: usize, caustic: usize) -> u64 {
    check_with(name, scene, global, caustic, ENERGY_TOLERANCE)
}

/// [`check`], with the coplanar estimate's energy held to `coplanar_tolerance`.
fn check_with(
    name: &str,
    scene: &Scene,
    global: usize,
    caustic: usize,
    coplanar_tolerance: f64,
) -> u64 {
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let options = PhotonOptions {
        global_photons: global,
        caustic_photons: caustic,
        ..PhotonOptions::default()
    };
    let mut stats = Stats::default();
    let maps = trace_photon_maps(scene, &embree, &options, 0, false, &mut stats).unwrap();
    let lt = LightTraceOptions {
        paths: 4_000_000,
        ..LightTraceOptions::default()
    };
    let reference = LightTracer::new(scene, &embree, &lt).run(&indicatif::ProgressBar::hidden());
    let regions = Regions::new(scene, &embree, &reference.film);
    let lit = &regions.lit;
    assert!(lit.len() > 500, "{name}: only {} lit pixels", lit.len());
    let bound = radiance_bound(scene, options.limits(scene).min_radius);
    // The image without photon light (empty maps): what a method's photon estimate adds to it
    // must be the photon light's share of the reference's energy, give or take the tolerance,
    // so that an estimate of 0 (or of twice the light) fails where that share is large.
    let empty = |class| PhotonMap::new(class, Vec::new(), 1, Guards::default());
    let no_photons = PhotonMaps {
        caustic: empty(PathClass::Caustic),
        global: empty(PathClass::Global),
        radiance: None,
    };
    let (direct, _) = Method::regular(1)
        .render(scene, &embree, &no_photons, &options, 0)
        .unwrap();
    let direct_energy = energy_error(&direct, &reference.film, lit);
    eprintln!("{name}: without photon light {direct_energy:+.4}");
    // Every estimate over photon maps, unnamed: a new one is held to the same promises.
    for method in EstimatorKind::over_maps().map(Method::of) {
        let (film, _) = method.render(scene, &embree, &maps, &options, 0).unwrap();
        let bad = bad_pixels(&film, bound);
        assert_eq!(
            bad,
            0,
            "{name}, {}: {bad} pixels NaN, infinite, negative or above {bound}",
            method.label()
        );
        let energy = energy_error(&film, &reference.film, lit);
        eprintln!("{name}, {}: energy {energy:+.4}", method.label());
        let tolerance = if method.kind == EstimatorKind::Coplanar {
            coplanar_tolerance
        } else {
            ENERGY_TOLERANCE
        };
        assert!(
            energy.abs() < tolerance,
            "{name}, {}: energy {energy:+.3} against the reference",
            method.label()
        );
        // Photon light added, as shares of the reference's energy: this method's and the
        // reference's (`-direct_energy`).
        // Measured (stop 44, every scene and method here, fixed seeds): 0.43 (the focal
        // caustic, whose reference's energy sits in a few noisy pixels at 80 x 60) to 1.9
        // times (coplanar, whose kernel read at the intersection's centroid counts a photon
        // far smaller than the pixel at twice its mean; README, "Stability where methods
        // fail"). An estimate of nothing, or one counting every photon three times, fails.
        let added = energy - direct_energy;
        let share = -direct_energy;
        eprintln!(
            "{name}, {}: photon light {added:+.4} of {share:+.4}",
            method.label()
        );
        assert!(
            share > 0.04 && added > 0.3 * share && added < 2.5 * share,
            "{name}, {}: photon light {added:+.4} of the reference's energy, where the \
             reference's photon light is {share:+.4}",
            method.label()
        );
    }
    let g = maps.caustic.guards;
    assert_eq!(
        stats.photon_maps[0].guards, g,
        "{name}: guards are reported in the statistics"
    );
    g.total()
}

#[test]
fn grazing_light() {
    let guards = check(
        "grazing light",
        &scene("stress/grazing-light.toml"),
        100_000,
        20_000,
    );
    assert!(guards > 0, "grazing footprints must be guarded");
}

#[test]
fn focal_caustic() {
    let guards = check(
        "focal caustic",
        &scene("stress/focal-caustic.toml"),
        100_000,
        20_000,
    );
    assert!(guards > 0, "collapsed footprints must be guarded");
}

#[test]
fn over_an_edge() {
    check(
        "over an edge",
        &scene("stress/over-an-edge.toml"),
        100_000,
        20_000,
    );
}

#[test]
fn glass_through_glass() {
    check(
        "glass through glass",
        &scene("stress/glass-through-glass.toml"),
        100_000,
        20_000,
    );
}

#[test]
fn quad_light_caustic() {
    // Most of this image's light is the caustic, which the coplanar estimate counts about 1.7
    // times at 80 x 60 (its kernel read at the centroid of a pixel's intersection with a photon
    // far smaller than the pixel is twice the kernel's mean; README, "Stability where methods
    // fail"): +0.26 of the image's energy, where the canonical scene's caustic is a small share.
    check_with(
        "quad light caustic",
        &scene("stress/quad-light-caustic.toml"),
        100_000,
        20_000,
        0.35,
    );
}

#[test]
fn photon_starvation() {
    check("1,000 photons", &scene("caustic-sphere.toml"), 1_000, 1_000);
}

#[test]
fn photon_plenty() {
    check(
        "5,000,000 photons",
        &scene("caustic-sphere.toml"),
        5_000_000,
        5_000_000,
    );
}
