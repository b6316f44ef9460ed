//! Photon maps as files: traced once (`photondiff photons`), read by every process of a split
//! render (`render --photon-maps`).
//!
//! Format, version 3 (version 1 counted `--photons` as global emissions, not stored photons;
//! version 2 had no count of photons mirrored at walls; their files are refused), all
//! integers and floats little-endian:
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `PDPHOTON` |
//! | 4 | format version (u32) |
//! | 4 | header length `H` (u32) |
//! | `H` | header: JSON `{"scene_hash": "<16 hex digits>", "settings": {..}, "payload_bytes": P}` |
//! | `P` | payload: the caustic map, then the global map |
//! | 8 | checksum: XXH3-64 of every byte before it |
//!
//! A map is `emitted, stored, rays` (u64: its [`TraceCounts`]), its guard counts
//! (`clamped_min, clamped_max, clamped_anisotropy, fallback, mirrored`, u64), the mirror
//! photons' power (3 f64, as their bits in u64s), the photon count `n` (u64),
//! then `n` photons of 20 f32 each: position, normal, direction, power (3 each), the filter
//! matrix rows `m[0]`, `m[1]` (3 each), `inv_area`, `radius`. The settings are the photon
//! options as the command line spells them (`--photons`, `--caustic-photons`, `--overlap`,
//! `--seed`, `--global-aim`, `--probe-walls`) plus the fixed ones, every value as its exact
//! decimal text, and (since stop 60) `embree`, the Embree the maps were traced with: another
//! build's maps are refused. Kd-trees are not stored: they are rebuilt on loading (see
//! `benches/photon_file.rs` for the cost).

use super::footprint::Guards;
use super::map::{PathClass, Photon, PhotonMap};
use super::options::PhotonOptions;
use super::trace::TraceCounts;
use super::PhotonMaps;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

const MAGIC: &[u8; 8] = b"PDPHOTON";
/// The format version this build writes and reads.
pub const VERSION: u32 = 3;
const PHOTON_BYTES: usize = 20 * 4;
const MAP_HEADER_BYTES: usize = 12 * 8;

/// What a file is for: the scene's content hash and the photon settings.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
struct Header {
    scene_hash: String,
    settings: BTreeMap<String, String>,
    payload_bytes: u64,
}

/// The photon settings as written in the header, keyed by their command-line spelling.
pub fn settings(options: &PhotonOptions) -> BTreeMap<String, String> {
    [
        ("--photons", options.global_photons.to_string()),
        ("--caustic-photons", options.caustic_photons.to_string()),
        ("--overlap", options.overlap.to_string()),
        ("global_area_scale", options.global_area_scale.to_string()),
        ("--seed", options.seed.to_string()),
        ("--global-aim", options.global_aim.to_string()),
        ("--probe-walls", options.probe_walls.to_string()),
        ("max_bounces", options.max_bounces.to_string()),
        (
            "radius_limits",
            format!("{} {}", options.radius_limits.0, options.radius_limits.1),
        ),
        ("max_anisotropy", options.max_anisotropy.to_string()),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect()
}

fn checksum(bytes: &[u8]) -> u64 {
    xxhash_rust::xxh3::xxh3_64(bytes)
}

fn push_map(out: &mut Vec<u8>, map: &PhotonMap, counts: &TraceCounts) {
    let g = &map.guards;
    for v in [
        counts.emitted,
        counts.stored,
        counts.rays,
        g.clamped_min,
        g.clamped_max,
        g.clamped_anisotropy,
        g.fallback,
        g.mirrored,
        map.mirror_power.x.to_bits(),
        map.mirror_power.y.to_bits(),
        map.mirror_power.z.to_bits(),
        map.len() as u64,
    ] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    // The photons' bytes filled in place on the worker threads: one at a time, a number at a
    // time, they took a third of writing 1.28M photons' maps.
    let start = out.len();
    out.resize(start + map.len() * PHOTON_BYTES, 0);
    out[start..]
        .par_chunks_exact_mut(PHOTON_BYTES)
        .enumerate()
        .for_each(|(i, bytes)| {
            let p = map.photon(i);
            let floats = [p.position, p.normal, p.direction, p.power, p.m[0], p.m[1]]
                .into_iter()
                .flat_map(|v| v.to_array())
                .chain([p.inv_area, p.radius]);
            for (b, f) in bytes.chunks_exact_mut(4).zip(floats) {
                b.copy_from_slice(&f.to_le_bytes());
            }
        });
}

/// The bytes [`push_map`] writes for `map`.
fn map_bytes(map: &PhotonMap) -> usize {
    MAP_HEADER_BYTES + map.len() * PHOTON_BYTES
}

/// The bytes of a photon-map file for the scene with content hash `scene_hash`.
pub fn encode(
    maps: &PhotonMaps,
    counts: &[TraceCounts; 2],
    scene_hash: u64,
    options: &PhotonOptions,
) -> Vec<u8> {
    let payload_bytes = map_bytes(&maps.caustic) + map_bytes(&maps.global);
    let mut settings = settings(options);
    settings.insert(BACKEND_KEY.into(), crate::embree::BACKEND.into());
    let header = Header {
        scene_hash: format!("{scene_hash:016x}"),
        settings,
        payload_bytes: payload_bytes as u64,
    };
    let header = serde_json::to_vec(&header).expect("a header is always JSON");
    // The maps written straight after the header: built apart and copied, their bytes were
    // written twice.
    let mut out = Vec::with_capacity(16 + header.len() + payload_bytes + 8);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&(header.len() as u32).to_le_bytes());
    out.extend_from_slice(&header);
    push_map(&mut out, &maps.caustic, &counts[0]);
    push_map(&mut out, &maps.global, &counts[1]);
    let sum = checksum(&out);
    out.extend_from_slice(&sum.to_le_bytes());
    out
}

/// Writes the photon-map file atomically.
pub fn write(
    path: &Path,
    maps: &PhotonMaps,
    counts: &[TraceCounts; 2],
    scene_hash: u64,
    options: &PhotonOptions,
) -> Result<(), String> {
    let bytes = encode(maps, counts, scene_hash, options);
    crate::util::atomic::write_with(path, |out| out.write_all(&bytes))
}

/// Reads a little-endian u64 at `at`.
fn u64_at(bytes: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes"))
}

/// One map as its file holds it: the photons and the map's twelve numbers, before the map's
/// BVH and tables are built.
struct Stored {
    numbers: [u64; 12],
    photons: Vec<Photon>,
}

/// Decodes map `class` from `bytes` starting at `*at`. Its checksum matched, so a problem here
/// is a file written wrongly (or forged), refused all the same: a count beyond the payload, or
/// a photon whose power or area would put a NaN or an infinity into every pixel it covers.
fn take_map(bytes: &[u8], at: &mut usize, class: PathClass) -> Result<Stored, String> {
    let name = class.name();
    if bytes.len() < *at + MAP_HEADER_BYTES {
        return Err(format!(
            "corrupt photon-map file: the payload ends before the {name} map"
        ));
    }
    let numbers: [u64; 12] = std::array::from_fn(|k| u64_at(bytes, *at + 8 * k));
    *at += MAP_HEADER_BYTES;
    let n = numbers[11];
    // Checked whole: a count near 2^64 / 80 wraps an unchecked sum of offsets.
    let size = usize::try_from(n)
        .ok()
        .and_then(|n| n.checked_mul(PHOTON_BYTES))
        .filter(|&s| at.checked_add(s).is_some_and(|end| end <= bytes.len()))
        .ok_or_else(|| {
            format!(
                "corrupt photon-map file: the {name} map counts {n} photons, more than the \
                 payload holds"
            )
        })?;
    // On the worker threads, in order.
    let photons: Vec<Photon> = bytes[*at..*at + size]
        .par_chunks_exact(PHOTON_BYTES)
        .map(|c| {
            let f = |k: usize| f32::from_le_bytes(c[4 * k..4 * k + 4].try_into().expect("4 bytes"));
            let v3 = |k: usize| Vec3::new(f(k), f(k + 1), f(k + 2));
            Photon {
                position: v3(0),
                normal: v3(3),
                direction: v3(6),
                power: v3(9),
                m: [v3(12), v3(15)],
                inv_area: f(18),
                radius: f(19),
            }
        })
        .collect();
    *at += size;
    let bad = |p: &Photon| {
        let finite = |v: Vec3| v.is_finite() && v.min_element() >= 0.0;
        !(finite(p.power) && finite(Vec3::new(p.inv_area, p.radius, 0.0)))
    };
    if let Some(i) = photons.par_iter().position_first(bad) {
        return Err(format!(
            "corrupt photon-map file: the {name} map's photon {i} has a negative or non-finite \
             power, area or radius"
        ));
    }
    // The geometry too: a NaN position or filter row passed into the BVH and the estimates.
    let unit = |v: Vec3| v.is_finite() && (v.length() - 1.0).abs() < 1e-3;
    let misplaced = |p: &Photon| {
        !(p.position.is_finite()
            && unit(p.normal)
            && unit(p.direction)
            && p.m.iter().all(|r| r.is_finite()))
    };
    if let Some(i) = photons.par_iter().position_first(misplaced) {
        return Err(format!(
            "corrupt photon-map file: the {name} map's photon {i} has a non-finite position or \
             filter, or a normal or direction that is not a unit vector"
        ));
    }
    Ok(Stored { numbers, photons })
}

impl Stored {
    /// The map of `class`, and what tracing it cost.
    fn build(self, class: PathClass) -> (PhotonMap, TraceCounts) {
        let v = self.numbers;
        let guards = Guards {
            clamped_min: v[3],
            clamped_max: v[4],
            clamped_anisotropy: v[5],
            fallback: v[6],
            mirrored: v[7],
        };
        let counts = TraceCounts {
            emitted: v[0],
            stored: v[1],
            rays: v[2],
        };
        let mut map = PhotonMap::new(class, self.photons, v[0], guards);
        map.mirror_power = DVec3::new(
            f64::from_bits(v[8]),
            f64::from_bits(v[9]),
            f64::from_bits(v[10]),
        );
        (map, counts)
    }
}

/// The maps of `stored` (caustic, global) built.
fn build([caustic, global]: [Stored; 2]) -> (PhotonMaps, [TraceCounts; 2]) {
    let ((caustic, c), (global, g)) = (
        caustic.build(PathClass::Caustic),
        global.build(PathClass::Global),
    );
    let maps = PhotonMaps {
        caustic,
        global,
        radiance: None,
    };
    (maps, [c, g])
}

/// Reads a photon-map file for the scene with content hash `scene_hash` traced with
/// `options`; every problem (not such a file, another version, truncated, corrupt, another
/// scene, other settings) is a one-line error naming the file.
pub fn read(
    path: &Path,
    scene_hash: u64,
    options: &PhotonOptions,
) -> Result<(PhotonMaps, [TraceCounts; 2]), String> {
    let name = path.display();
    let bytes = crate::util::input::read(path)
        .map_err(|e| format!("{name}: cannot read photon maps: {e}"))?;
    let stored = parse(&bytes, scene_hash, options).map_err(|e| format!("{name}: {e}"))?;
    // The file's bytes freed before the maps are built: held while they were, they were a
    // quarter of the peak memory of a render from 1.28M photons' maps.
    drop(bytes);
    Ok(build(stored))
}

/// Checks the photon-map file at `path` as far as its header goes, without reading its
/// photons: a photon-map file of this version, of the size its header gives, traced with
/// `options`. What [`read`] would refuse of these is refused with the same words; the scene's
/// hash and the checksum are left to [`read`]. A render checks its `--photon-maps` so before
/// it reads the scene, which can take seconds.
pub fn check(path: &Path, options: &PhotonOptions) -> Result<(), String> {
    use std::io::Read;
    let name = path.display();
    let cannot = |e: std::io::Error| format!("{name}: cannot read photon maps: {e}");
    let meta = std::fs::metadata(path).map_err(cannot)?;
    if !meta.is_file() {
        // A named pipe (a shell's `<(...)`) can be opened and read once only: checked whole
        // by [`read`]. A folder or a device is refused now, in [`read`]'s words (it was only
        // once the scene had been read).
        return crate::util::input::refuse(path).map_err(cannot);
    }
    let mut file = crate::util::input::open(path).map_err(cannot)?;
    let len = meta.len();
    // The fixed 16 bytes, then the header they announce (at most what the file holds).
    let mut start = Vec::new();
    (&mut file)
        .take(16)
        .read_to_end(&mut start)
        .map_err(cannot)?;
    let announced = match start.get(12..16) {
        Some(b) => u64::from(u32::from_le_bytes(b.try_into().expect("4 bytes"))),
        None => 0,
    };
    // (A header longer than the file is refused as truncated by `header` without reading.)
    if start.len() == 16 && &start[..8] == MAGIC && 16 + announced <= len {
        (&mut file)
            .take(announced)
            .read_to_end(&mut start)
            .map_err(cannot)?;
    }
    let (header, _) = header(&start, len).map_err(|e| format!("{name}: {e}"))?;
    check_settings(&header, options).map_err(|e| format!("{name}: {e}"))
}

/// The header of a photon-map file whose first bytes are `bytes` (at least up to the header's
/// end) and whose length is `len`, with where its payload ends; the file's size is checked
/// against the header.
fn header(bytes: &[u8], len: u64) -> Result<(Header, usize), String> {
    if bytes.len() < 16 || &bytes[..8] != MAGIC {
        return Err("not a photondiff photon-map file".into());
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if version != VERSION {
        return Err(format!(
            "photon-map file format version {version}; this photondiff reads version {VERSION}"
        ));
    }
    let header_len = u32::from_le_bytes(bytes[12..16].try_into().expect("4 bytes")) as usize;
    let truncated =
        |expected: u64| format!("truncated photon-map file: {len} bytes, expected {expected}");
    if bytes.len() < 16 + header_len {
        return Err(truncated(16 + header_len as u64 + 8));
    }
    let header: Header = serde_json::from_slice(&bytes[16..16 + header_len])
        .map_err(|e| format!("corrupt photon-map file header: {e}"))?;
    let end = (16 + header_len as u64)
        .checked_add(header.payload_bytes)
        .filter(|e| *e < u64::MAX - 8)
        .ok_or("corrupt photon-map file header: impossible payload size")?;
    if len < end + 8 {
        return Err(truncated(end + 8));
    }
    if len > end + 8 {
        return Err(format!(
            "corrupt photon-map file: {len} bytes, expected {}",
            end + 8
        ));
    }
    Ok((header, end as usize))
}

/// The header's setting naming the Embree the maps were traced with (since stop 60).
const BACKEND_KEY: &str = "embree";

/// Refuses maps traced with another Embree than this build's, `backend`: Embree 3 and 4 (and
/// their versions) agree on hits only to rounding, so a render from them would not be the one
/// a single process of this build makes, and `merge` refuses parts of two backends alike.
/// Files written before stop 60 do not say, and are taken.
fn check_backend(file: Option<&str>, backend: &str) -> Result<(), String> {
    match file {
        Some(theirs) if theirs != backend => Err(format!(
            "photon maps traced with another Embree: {theirs} in the file, {backend} in this \
             photondiff (their hits agree only to rounding, so the render would not be the one \
             this build makes alone; trace the maps again with this build's `photondiff photons`)"
        )),
        _ => Ok(()),
    }
}

/// Refuses a header whose settings are not `options'`, or that was traced with another Embree.
fn check_settings(header: &Header, options: &PhotonOptions) -> Result<(), String> {
    let file_backend = header.settings.get(BACKEND_KEY).map(String::as_str);
    check_backend(file_backend, crate::embree::BACKEND)?;
    for (key, value) in &settings(options) {
        let theirs = header.settings.get(key).map_or("(none)", |v| v.as_str());
        if theirs != value && ["max_bounces", "max_anisotropy"].contains(&key.as_str()) {
            // Not options, nor set by the passes (as the radius limits and the global area
            // scale are): settings of photondiff itself, changed since the file was traced.
            return Err(format!(
                "photon maps traced with other settings: {key} is {theirs} in the file, {value} in \
                 this photondiff (not an option: the file is from another version; trace the maps \
                 again with `photondiff photons`)"
            ));
        }
        if theirs != value {
            // The seed has no estimator's default: the bracket below sent a user looking for one.
            let why = match key.as_str() {
                "--seed" => "the render must give the --seed the maps were traced with",
                _ => {
                    "given, or the default of the --estimator: `photons` takes the render's \
                     --estimator and photon options"
                }
            };
            return Err(format!(
                "photon maps traced with other settings: {key} is {theirs} in the file, {value} in \
                 this render ({why})"
            ));
        }
    }
    Ok(())
}

/// Decodes the bytes of a photon-map file (see [`read`]).
pub fn decode(
    bytes: &[u8],
    scene_hash: u64,
    options: &PhotonOptions,
) -> Result<(PhotonMaps, [TraceCounts; 2]), String> {
    parse(bytes, scene_hash, options).map(build)
}

/// Checks the bytes of a photon-map file and decodes its two maps' photons.
fn parse(bytes: &[u8], scene_hash: u64, options: &PhotonOptions) -> Result<[Stored; 2], String> {
    let (header, end) = header(bytes, bytes.len() as u64)?;
    if checksum(&bytes[..end]) != u64_at(bytes, end) {
        return Err("corrupt photon-map file: checksum mismatch".into());
    }
    let hash = format!("{scene_hash:016x}");
    if header.scene_hash != hash {
        return Err(format!(
            "photon maps of another scene (scene hash {}; this scene's is {hash})",
            header.scene_hash
        ));
    }
    check_settings(&header, options)?;
    let header_len = end - header.payload_bytes as usize - 16;
    let payload = &bytes[16 + header_len..end];
    let mut at = 0;
    let caustic = take_map(payload, &mut at, PathClass::Caustic)?;
    let global = take_map(payload, &mut at, PathClass::Global)?;
    if at != payload.len() {
        return Err("corrupt photon-map file: bytes after the maps".into());
    }
    Ok([caustic, global])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(class: PathClass, n: usize) -> PhotonMap {
        let photons = (0..n)
            .map(|i| {
                let f = i as f32;
                Photon {
                    position: Vec3::new(f, -f, 0.5 * f),
                    normal: Vec3::Y,
                    direction: Vec3::new(0.0, -1.0, f.sin()).normalize(),
                    power: Vec3::splat(1e-3 * f),
                    m: [Vec3::new(1.0, 2.0, f), Vec3::new(-f, 3.0, 4.0)],
                    inv_area: 1.0 / (1.0 + f),
                    radius: 0.01 + f,
                }
            })
            .collect();
        let guards = Guards {
            clamped_min: 1,
            clamped_max: 2,
            clamped_anisotropy: 3,
            fallback: 4,
            mirrored: 5,
        };
        let mut map = PhotonMap::new(class, photons, 10 * n as u64, guards);
        map.mirror_power = DVec3::new(0.1, 1.0 / 3.0, 7e-9);
        map
    }

    #[test]
    fn maps_round_trip_exactly() {
        let maps = PhotonMaps {
            caustic: map(PathClass::Caustic, 37),
            global: map(PathClass::Global, 0),
            radiance: None,
        };
        let counts = [
            TraceCounts {
                emitted: 370,
                stored: 37,
                rays: 999,
            },
            TraceCounts {
                emitted: 0,
                stored: 0,
                rays: 5,
            },
        ];
        let options = PhotonOptions::default();
        let bytes = encode(&maps, &counts, 0xabc, &options);
        let (back, back_counts) = decode(&bytes, 0xabc, &options).unwrap();
        assert_eq!(back.caustic.photons(), maps.caustic.photons());
        assert_eq!(back.caustic.guards, maps.caustic.guards);
        assert_eq!(back.caustic.mirror_power, maps.caustic.mirror_power);
        assert_eq!(back.caustic.emitted, 370);
        assert_eq!(back.caustic.max_radius, maps.caustic.max_radius);
        assert!(back.global.is_empty());
        assert_eq!(back_counts, counts);
        let other = PhotonOptions { seed: 3, ..options };
        assert_eq!(
            decode(&bytes, 0xabc, &other).err().unwrap(),
            "photon maps traced with other settings: --seed is 0 in the file, 3 in this render \
             (the render must give the --seed the maps were traced with)"
        );
        let older = PhotonOptions {
            max_bounces: 64,
            ..options
        };
        assert_eq!(
            decode(&encode(&maps, &counts, 0xabc, &older), 0xabc, &options)
                .err()
                .unwrap(),
            "photon maps traced with other settings: max_bounces is 64 in the file, 1024 in this \
             photondiff (not an option: the file is from another version; trace the maps again \
             with `photondiff photons`)"
        );
        // Every truncation is an error naming what is wrong, never a panic: too short for the
        // magic, or a file shorter than its header says.
        for len in 0..bytes.len() {
            let e = decode(&bytes[..len], 0xabc, &options).err().unwrap();
            let expected = if len < 16 {
                "not a photondiff photon-map file".to_string()
            } else {
                format!("truncated photon-map file: {len} bytes, expected ")
            };
            assert!(e.starts_with(&expected), "{len}: {e}");
        }
    }

    /// Maps traced by another Embree are refused with a message naming both; files from
    /// before stop 60, which do not say, are taken; this build's own files say this build's.
    #[test]
    fn maps_of_another_embree_are_refused() {
        assert_eq!(
            check_backend(Some("Embree 3.13.5"), "Embree 4.3.3").unwrap_err(),
            "photon maps traced with another Embree: Embree 3.13.5 in the file, Embree 4.3.3 in \
             this photondiff (their hits agree only to rounding, so the render would not be the \
             one this build makes alone; trace the maps again with this build's `photondiff \
             photons`)"
        );
        assert_eq!(check_backend(None, "Embree 4.3.3"), Ok(()));
        assert_eq!(check_backend(Some("Embree 4.3.3"), "Embree 4.3.3"), Ok(()));
        let maps = PhotonMaps {
            caustic: map(PathClass::Caustic, 3),
            global: map(PathClass::Global, 0),
            radiance: None,
        };
        let options = PhotonOptions::default();
        let bytes = encode(&maps, &[TraceCounts::default(); 2], 0xabc, &options);
        let (header, _) = header(&bytes, bytes.len() as u64).unwrap();
        assert_eq!(header.settings[BACKEND_KEY], crate::embree::BACKEND);
    }

    /// A file whose checksum matches but whose numbers are wrong (written wrongly, or forged)
    /// is an error naming what is wrong: never a panic, and never NaN pixels.
    #[test]
    fn a_file_with_impossible_numbers_is_refused() {
        let maps = PhotonMaps {
            caustic: map(PathClass::Caustic, 5),
            global: map(PathClass::Global, 2),
            radiance: None,
        };
        let counts = [TraceCounts::default(); 2];
        let options = PhotonOptions::default();
        let bytes = encode(&maps, &counts, 1, &options);
        let payload = 16 + u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        // The caustic map's photon count, then its photon 3's power (green) and area.
        let count = payload + 88;
        let photon3 = payload + MAP_HEADER_BYTES + 3 * PHOTON_BYTES;
        let forged = |at: usize, value: &[u8]| {
            let mut b = bytes.clone();
            b[at..at + value.len()].copy_from_slice(value);
            let end = b.len() - 8;
            let sum = checksum(&b[..end]);
            b[end..].copy_from_slice(&sum.to_le_bytes());
            decode(&b, 1, &options).err().unwrap()
        };
        // 2^64 / 80: the photons' end wrapped past the payload's before (a panic).
        for n in [u64::MAX / 80, u64::MAX / 80 + 1, u64::MAX, 1 << 40] {
            assert_eq!(
                forged(count, &n.to_le_bytes()),
                format!(
                    "corrupt photon-map file: the caustic map counts {n} photons, more than the \
                     payload holds"
                )
            );
        }
        // One photon fewer or more misplaces the global map's numbers by a photon.
        assert!(decode(&bytes, 1, &options).is_ok());
        for n in [4u64, 6] {
            let e = forged(count, &n.to_le_bytes());
            assert!(e.starts_with("corrupt photon-map file"), "{n}: {e}");
        }
        for (offset, value) in [
            (40, f32::NAN),
            (40, f32::INFINITY),
            (36, -1.0),
            (72, f32::INFINITY),
            (76, f32::NAN),
        ] {
            assert_eq!(
                forged(photon3 + offset, &value.to_le_bytes()),
                "corrupt photon-map file: the caustic map's photon 3 has a negative or non-finite \
                 power, area or radius",
                "{offset} {value}"
            );
        }
        // Position x, normal y, direction z, the filter's second row.
        for (offset, value) in [(0, f32::NAN), (16, 0.0), (32, 3.0), (60, f32::INFINITY)] {
            assert_eq!(
                forged(photon3 + offset, &value.to_le_bytes()),
                "corrupt photon-map file: the caustic map's photon 3 has a non-finite position or \
                 filter, or a normal or direction that is not a unit vector",
                "{offset} {value}"
            );
        }
    }
}
