//! Photon maps as files: how long `render --photon-maps` takes to load 1.28 million photons
//! (read, checksum, decode, rebuild the kd-trees) beside tracing them, measured in one run
//! (median of 3, alternated) and reported as ratios.
//!
//! Run: `cargo bench --bench photon_file`

use photondiff::photons::file;
use photondiff::photons::map::PhotonMap;
use photondiff::photons::trace::{PhotonOptions, TraceCounts};
use photondiff::render::stats::Stats;
use photondiff::render::trace_photon_maps;
use photondiff::scene::file::load_scene;
use std::path::Path;
use std::time::Instant;

const REPEATS: usize = 3;

fn median(mut t: Vec<f64>) -> f64 {
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

fn seconds<T>(f: impl FnOnce() -> T) -> (f64, T) {
    let start = Instant::now();
    let out = f();
    (start.elapsed().as_secs_f64(), out)
}

fn main() {
    let path = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    ));
    let scene = load_scene(path).expect("canonical scene");
    let hash = photondiff::scene::hash::scene_hash(path).expect("scene hash");
    let device = photondiff::embree::Device::new().expect("Embree device");
    let embree = scene.build_embree(&device).expect("Embree scene");
    let options = PhotonOptions {
        caustic_photons: 1_280_000,
        ..PhotonOptions::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let maps_path = dir.path().join("maps.pdm");
    let (mut trace, mut load, mut read, mut trees) = (vec![], vec![], vec![], vec![]);
    let mut photons = 0;
    let mut bytes = 0;
    for _ in 0..REPEATS {
        let mut stats = Stats::default();
        let (t, maps) =
            seconds(|| trace_photon_maps(&scene, &embree, &options, 0, false, &mut stats));
        let maps = maps.unwrap();
        trace.push(t);
        let counts = [0, 1].map(|i| TraceCounts {
            emitted: stats.photon_maps[i].emitted,
            stored: stats.photon_maps[i].stored,
            rays: stats.photon_maps[i].rays,
        });
        file::write(&maps_path, &maps, &counts, hash, &options).unwrap();
        photons = maps.caustic.len() + maps.global.len();
        bytes = std::fs::metadata(&maps_path).unwrap().len();
        drop(maps);
        let (t, loaded) = seconds(|| file::read(&maps_path, hash, &options).unwrap());
        load.push(t);
        assert_eq!(loaded.0.caustic.len() + loaded.0.global.len(), photons);
        let (t, data) = seconds(|| std::fs::read(&maps_path).unwrap());
        read.push(t);
        let (t, _) = seconds(|| {
            let c = &loaded.0.caustic;
            PhotonMap::new(c.class, c.photons.clone(), c.emitted, c.guards)
        });
        trees.push(t);
        drop(data);
    }
    let (trace, load, read, trees) = (median(trace), median(load), median(read), median(trees));
    println!(
        "Photon-map file, canonical scene, {photons} photons ({:.1} MB), all cores:",
        bytes as f64 / 1e6
    );
    println!("| step | seconds (median of {REPEATS}) | ratio to tracing |");
    println!("|---|---|---|");
    println!("| trace the maps | {trace:.3} | 1.00 |");
    println!(
        "| load the file (`render --photon-maps`) | {load:.3} | {:.3} |",
        load / trace
    );
    println!(
        "| of which: read the bytes | {read:.3} | {:.3} |",
        read / trace
    );
    println!(
        "| of which: rebuild the caustic map's kd-trees | {trees:.3} | {:.3} |",
        trees / trace
    );
}
