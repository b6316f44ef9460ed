//! What every photon-map estimator promises, whatever it is: one photon on a plane, gathered at
//! the centres of view footprints that tile the plane, gives back its power (the estimate times
//! each footprint's area, summed). The estimators come from the command line's list
//! (`EstimatorKind::over_maps`), so a new one is tested without being named here.

mod common;
use common::floor_photon;

use glam::{DVec2, DVec3};
use photondiff::estimate::{EstimatorKind, EstimatorSettings, GatherCounts, GatherQuery};
use photondiff::photons::footprint::Guards;
use photondiff::photons::map::{PathClass, PhotonMap};
use std::f64::consts::PI;

fn on_floor(v: DVec2) -> DVec3 {
    DVec3::new(v.x, 0.0, v.y)
}

#[test]
fn every_estimator_gives_back_a_photons_power() {
    let (a, b) = (DVec2::new(0.3, 0.05), DVec2::new(-0.02, 0.2));
    let photon = floor_photon(
        on_floor(DVec2::new(0.013, -0.007)),
        on_floor(a),
        on_floor(b),
        2.5,
    );
    let map = PhotonMap::new(PathClass::Caustic, vec![photon], 1, Guards::default());
    let h = 0.004;
    let footprint = [on_floor(DVec2::new(h, 0.0)), on_floor(DVec2::new(0.0, h))];
    let n = (1.0 / h) as i64;
    let mut tested = Vec::new();
    for kind in EstimatorKind::over_maps() {
        let settings = EstimatorSettings::new(kind, f64::from(map.max_radius));
        let estimate = settings
            .estimator_over(&map)
            .expect("an estimate over maps");
        let mut counts = GatherCounts::default();
        let mut power = 0.0;
        for i in -n..=n {
            for j in -n..=n {
                let q = GatherQuery {
                    position: on_floor(DVec2::new(i as f64 * h, j as f64 * h)),
                    normal: DVec3::Y,
                    albedo: DVec3::splat(PI),
                    footprint,
                    exact: None,
                };
                power += estimate.radiance(&q, &mut counts).x * h * h;
            }
        }
        eprintln!("{kind:?}: {power} of 2.5 W");
        tested.push(kind);
        assert!(
            (power - 2.5).abs() <= 0.01 * 2.5,
            "{kind:?}: {power} of 2.5 W"
        );
    }
    assert!(tested.len() >= 5, "{tested:?}");
}
