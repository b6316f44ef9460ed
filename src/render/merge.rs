//! Joining the parts of a split render (`--tile I/N` tiles, `--pass-range A..B` pass ranges, or
//! both) into the whole image, and their statistics into the whole run's.
//!
//! Tiles' pixels are copied, not recomputed, and pass ranges' exact sums added, so the whole is
//! bit-identical to a render in one process. Every check runs before anything is produced:
//! parts must come from the same scene (content hash) and the same settings (every
//! `photondiff/...` attribute but those describing one process: [`PER_PART`]), must not
//! overlap, and must cover the image and the passes; every missing tile and pass range is
//! named.

use super::film::Film;
use super::noise::NoiseEstimate;
use super::part::Part;
use super::pass_part::read_pass_sum;
use super::pass_sum::PassSum;
use super::split::{TileSplit, Window};
use serde_json::Value;
pub use stats::merge_stats;
use std::collections::BTreeSet;
use std::ops::Range;

mod stats;

/// Attributes that describe one process rather than the image: they may differ between parts.
pub const PER_PART: &[&str] = &[
    "photondiff/scene",
    "photondiff/tile",
    "photondiff/pass_range",
    "photondiff/threads",
    "photondiff/render_seconds",
    "photondiff/stats",
    "photondiff/parts",
    // Each file's own pixels' (`render::checksum`).
    "photondiff/rgb_xxh3",
    "photondiff/sums_xxh3",
    // The noise estimate of a progressive render is its part's: the whole's is computed again
    // from the merged sums where they are the whole image's, else it has none.
    "photondiff/passes_stopped_by",
    "photondiff/noise_whole",
    "photondiff/noise_caustic",
    "photondiff/noise_caustic_pixels",
];

/// The whole image and its attributes.
#[derive(Debug)]
pub struct Merged {
    /// The whole image.
    pub film: Film,
    /// Its attributes: the parts' shared settings, `photondiff/parts` (how many) and
    /// `photondiff/stats`, the statistics of the whole.
    pub metadata: Vec<(String, String)>,
    /// The statistics of the whole (see [`merge_stats`]).
    pub stats: Value,
}

/// The tile a part holds: its `photondiff/tile` attribute, or the whole image (`0/1`).
fn tile_of(part: &Part) -> Result<TileSplit, String> {
    match part.metadata.get("photondiff/tile") {
        Some(t) => t.parse().map_err(|e| {
            format!(
                "{}: bad photondiff/tile attribute: {e}",
                part.path.display()
            )
        }),
        None => Ok(TileSplit { index: 0, count: 1 }),
    }
}

/// The passes a part holds: its `photondiff/pass_range` attribute, or all `total`.
fn passes_of(part: &Part, total: u64) -> Result<Range<u64>, String> {
    match part.metadata.get("photondiff/pass_range") {
        Some(r) => parse_range(r).map_err(|e| {
            format!(
                "{}: bad photondiff/pass_range attribute: {e}",
                part.path.display()
            )
        }),
        None => Ok(0..total),
    }
}

/// Parses `A..B` (passes A to B - 1, `A < B`).
pub fn parse_range(text: &str) -> Result<Range<u64>, String> {
    let bad = || format!("expected A..B with A < B (passes A to B - 1, from 0), got {text:?}");
    let (a, b) = text.split_once("..").ok_or_else(bad)?;
    let (a, b): (u64, u64) = (
        a.trim().parse().map_err(|_| bad())?,
        b.trim().parse().map_err(|_| bad())?,
    );
    if a >= b {
        return Err(bad());
    }
    Ok(a..b)
}

/// The gaps of `ranges` (disjoint) in `0..total`.
fn gaps(mut ranges: Vec<Range<u64>>, total: u64) -> Vec<Range<u64>> {
    ranges.sort_by_key(|r| r.start);
    let mut out = Vec::new();
    let mut at = 0;
    for r in ranges {
        if r.start > at {
            out.push(at..r.start);
        }
        at = at.max(r.end);
    }
    if at < total {
        out.push(at..total);
    }
    out
}

/// The attributes compared first, in this order, when parts differ.
const LEADING: [&str; 4] = [
    "photondiff/scene_hash",
    "photondiff/estimator",
    "photondiff/passes",
    "photondiff/seed",
];

/// Merges `parts` (see the module documentation).
pub fn merge(parts: &[Part]) -> Result<Merged, String> {
    let first = parts.first().ok_or("no parts to merge")?;
    let name = |p: &Part| p.path.display().to_string();
    if !first.metadata.contains_key("photondiff/scene_hash") {
        return Err(format!(
            "{}: not written by photondiff render (no photondiff/scene_hash attribute)",
            name(first)
        ));
    }
    // Same scene, same settings, same image size.
    for part in &parts[1..] {
        if part.display != first.display {
            return Err(format!(
                "{} is a {} x {} image but {} is {} x {}",
                name(part),
                part.display.0,
                part.display.1,
                name(first),
                first.display.0,
                first.display.1
            ));
        }
        let keys: BTreeSet<&String> = first.metadata.keys().chain(part.metadata.keys()).collect();
        // The settings a user sets first, then the rest: a part of another pass count also
        // differs in what that count decides (the edge grid of a long run), and naming that
        // instead hid the real difference.
        let rank = |k: &&String| LEADING.iter().position(|l| l == k).unwrap_or(LEADING.len());
        let mut keys: Vec<&String> = keys.into_iter().collect();
        keys.sort_by_key(rank);
        for key in keys {
            if PER_PART.contains(&key.as_str()) || !key.starts_with("photondiff/") {
                continue;
            }
            let (a, b) = (first.metadata.get(key), part.metadata.get(key));
            if a != b {
                let show = |v: Option<&String>| v.map_or("(none)".to_string(), |v| v.clone());
                let what = if key == "photondiff/scene_hash" {
                    "is from another scene"
                } else {
                    "has other settings"
                };
                // Each value with its file: "there" and "here" were easy to read backwards.
                return Err(format!(
                    "{} {what} than {}: {key} is {} in {0}, {} in {1}",
                    name(part),
                    name(first),
                    show(b),
                    show(a)
                ));
            }
        }
    }
    // No overlap: in the image, or in the passes of the same pixels.
    let tiles: Vec<TileSplit> = parts.iter().map(tile_of).collect::<Result<_, _>>()?;
    let total: u64 = match first.metadata.get("photondiff/passes") {
        Some(p) => p
            .parse()
            .map_err(|_| format!("{}: bad photondiff/passes attribute {p:?}", name(first)))?,
        None => 1,
    };
    let ranges: Vec<Range<u64>> = parts
        .iter()
        .map(|p| passes_of(p, total))
        .collect::<Result<_, _>>()?;
    let describe = |k: usize| {
        let p = &parts[k];
        match p.metadata.contains_key("photondiff/pass_range") {
            true => format!("tile {}, passes {:?}, {}", tiles[k], ranges[k], p.window),
            false => format!("tile {}, {}", tiles[k], p.window),
        }
    };
    for (i, a) in parts.iter().enumerate() {
        if ranges[i].end > total {
            return Err(format!(
                "{}: passes {:?} of a {total}-pass render",
                name(a),
                ranges[i]
            ));
        }
        for (j, b) in parts.iter().enumerate().skip(i + 1) {
            let passes_meet = ranges[i].start < ranges[j].end && ranges[j].start < ranges[i].end;
            if a.window.overlaps(&b.window) && passes_meet {
                return Err(format!(
                    "{} ({}) overlaps {} ({})",
                    name(a),
                    describe(i),
                    name(b),
                    describe(j)
                ));
            }
        }
    }
    // One split, complete.
    let count = tiles[0].count;
    if let Some(k) = tiles.iter().position(|t| t.count != count) {
        return Err(format!(
            "{} is tile {} but {} is tile {}: parts of different splits",
            name(&parts[k]),
            tiles[k],
            name(first),
            tiles[0]
        ));
    }
    let present: BTreeSet<u32> = tiles.iter().map(|t| t.index).collect();
    let missing: Vec<String> = (0..count)
        .filter(|i| !present.contains(i))
        .map(|i| format!("{i}/{count}"))
        .collect();
    let mut problems = Vec::new();
    if !missing.is_empty() {
        problems.push(format!("missing tiles: {}", missing.join(", ")));
    }
    for &index in &present {
        let of_tile = (0..parts.len()).filter(|&k| tiles[k].index == index);
        for gap in gaps(of_tile.map(|k| ranges[k].clone()).collect(), total) {
            problems.push(format!("missing passes {gap:?} of tile {index}/{count}"));
        }
    }
    if !problems.is_empty() {
        return Err(problems.join("; "));
    }
    let (width, height) = first.display;
    for (part, tile) in parts.iter().zip(&tiles) {
        let expected = tile.window(width, height)?;
        if part.window != expected {
            return Err(format!(
                "{}: tile {tile} should cover {expected} but covers {}",
                name(part),
                part.window
            ));
        }
    }
    let mut film = Film::new(width, height);
    // The noise of the mean, where the merged sums are the whole image's (pass ranges without
    // tiles): the whole run's estimate from its passes. Tiles' sums are each their pixels'.
    let mut noise = None;
    for &index in &present {
        let of_tile: Vec<usize> = (0..parts.len())
            .filter(|&k| tiles[k].index == index)
            .collect();
        let part = &parts[of_tile[0]];
        if !part.metadata.contains_key("photondiff/pass_range") {
            copy_window(&part.film, part.window, &mut film);
            continue;
        }
        // Pass ranges: their exact sums added (in any order: fixed point), then one division.
        let mut sum: Option<PassSum> = None;
        for &k in &of_tile {
            let part_sum = read_pass_sum(&parts[k].path, ranges[k].end - ranges[k].start)?;
            match &mut sum {
                None => sum = Some(part_sum),
                Some(s) => s.merge(&part_sum),
            }
        }
        let sum = sum.expect("a tile has parts");
        if part.window == Window::full(width, height) {
            noise = Some(NoiseEstimate::of(&sum));
        }
        copy_window(&sum.mean(), part.window, &mut film);
    }
    let mut stats = merge_stats(parts)?;
    if let Some(n) = noise {
        stats["progressive"]["noise"] = serde_json::to_value(n).map_err(|e| e.to_string())?;
    }
    let mut metadata: Vec<(String, String)> = first
        .metadata
        .iter()
        .filter(|(k, _)| !PER_PART.contains(&k.as_str()) || k.as_str() == "photondiff/scene")
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    metadata.push(("photondiff/parts".into(), parts.len().to_string()));
    if let Some(n) = noise {
        metadata.extend(n.attributes());
    }
    metadata.push(("photondiff/stats".into(), stats.to_string()));
    Ok(Merged {
        film,
        metadata,
        stats,
    })
}

/// Copies `part`, the pixels of `window`, into the whole image `film`.
fn copy_window(part: &Film, window: Window, film: &mut Film) {
    for y in window.y0..window.y1 {
        let src = ((y - window.y0) * window.width()) as usize;
        let dst = (y * film.width + window.x0) as usize;
        let n = window.width() as usize;
        film.pixels[dst..dst + n].copy_from_slice(&part.pixels[src..src + n]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(super) fn part(name: &str, settings: &[(&str, &str)]) -> Part {
        Part {
            path: name.into(),
            film: Film::new(2, 2),
            window: Window::full(2, 2),
            display: (2, 2),
            metadata: settings
                .iter()
                .map(|(k, v)| (format!("photondiff/{k}"), v.to_string()))
                .collect(),
        }
    }

    #[test]
    fn parts_of_other_pass_counts_are_told_apart_by_the_pass_count() {
        // A 3-pass render's part also has the edge grid of a long run (8), which sorts first.
        let a = part(
            "a.exr",
            &[("scene_hash", "1"), ("passes", "2"), ("edge_grid", "1")],
        );
        let b = part(
            "b.exr",
            &[("scene_hash", "1"), ("passes", "3"), ("edge_grid", "8")],
        );
        assert_eq!(
            merge(&[a, b]).err().unwrap(),
            "b.exr has other settings than a.exr: photondiff/passes is 3 in b.exr, 2 in a.exr"
        );
    }
}
