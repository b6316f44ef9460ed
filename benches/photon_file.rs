//! Photon maps as files: how long `render --photon-maps` takes to load 1.28 million photons
//! (read, checksum, decode, rebuild the query structures) beside tracing them, measured in one
//! run (median of 3, alternated) and reported as ratios.
//!
//! Run: `cargo bench --bench photon_file`

use photondiff::photons::file;
use photondiff::photons::map::PhotonMap;
use photondiff::photons::options::PhotonOptions;
use photondiff::photons::trace::TraceCounts;
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
    let (mut trace, mut load, mut read) = (vec![], vec![], vec![]);
    let (mut check, mut trees) = (vec![], vec![]);
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
        // The file's checksum, as `file::read` computes it (everything but its last 8 bytes).
        let (t, sum) = seconds(|| xxhash_rust::xxh3::xxh3_64(&data[..data.len() - 8]));
        check.push(t);
        assert_eq!(sum.to_le_bytes(), data[data.len() - 8..]);
        drop(data);
        // Both maps' query structures, rebuilt from the decoded photons as loading does.
        let copies = [&loaded.0.caustic, &loaded.0.global].map(|m| m.photons());
        let (t, _) = seconds(|| {
            let [c, g] = copies;
            let (mc, mg) = (&loaded.0.caustic, &loaded.0.global);
            (
                PhotonMap::new(mc.class, c, mc.emitted, mc.guards),
                PhotonMap::new(mg.class, g, mg.emitted, mg.guards),
            )
        });
        trees.push(t);
    }
    let (trace, load, read) = (median(trace), median(load), median(read));
    let (check, trees) = (median(check), median(trees));

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
    for (step, t) in [
        ("of which: read the bytes", read),
        ("of which: XXH3 checksum of the file", check),
        ("of which: rebuild both maps' query structures", trees),
    ] {
        println!("| {step} | {t:.3} | {:.3} |", t / trace);
    }
    // Reading, verifying and decoding the photons is what loading spends besides the rebuild
    // (medians of separate timings: a rest computed from them could come out negative).
    println!(
        "read, verify and decode (loading minus the rebuild): {:.3} s, {:.2} of loading; rebuild {:.3} s, {:.2} of loading",
        load - trees,
        (load - trees) / load,
        trees,
        trees / load
    );
}
