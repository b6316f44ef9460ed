//! The statistics of a merged render: the parts' `photondiff/stats` attributes joined into
//! the whole run's (counts and times summed, what every part traced alike counted once).

use super::Part;
use serde_json::Value;

/// The statistics of the whole: every count and time summed over the parts (stage times are
/// then the seconds of all processes together, not wall-clock time); the light tracer's noise
/// from the first part; the photon maps' figures from the first part where the parts are
/// tiles (each traced the same maps), summed over the pass ranges of one tile where they are
/// pass ranges (each traced its own passes' maps, every tile the same: `merge_range_maps`;
/// the first part's alone said 20,000 or 40,000 caustic photons of a 60,000-photon render, by
/// the order the parts were named, and summed over two tiles' ranges 120,000); the scene's
/// memory and mesh repairs as `merge_memory` says; the progressive report as
/// `merge_progressive` says.
pub fn merge_stats(parts: &[Part]) -> Result<Value, String> {
    let mut total: Option<Value> = None;
    let mut reports = Vec::new();
    let mut range_maps = Vec::new();
    let mut memories = Vec::new();
    let tile = |part: &Part| part.metadata.get("photondiff/tile").cloned();
    for part in parts {
        let Some(text) = part.metadata.get("photondiff/stats") else {
            continue;
        };
        let value: Value = serde_json::from_str(text).map_err(|e| {
            format!(
                "{}: bad photondiff/stats attribute: {e}",
                part.path.display()
            )
        })?;
        reports.extend(value.get("progressive").filter(|p| p.is_object()).cloned());
        if let Some(passes) = range_passes(&value["progressive"]) {
            range_maps.push((tile(part), value["photon_maps"].clone(), passes));
        }
        memories.extend(value.get("memory").filter(|m| m.is_object()).cloned());
        total = Some(match total {
            None => value,
            Some(mut t) => {
                add(&mut t, &value, "");
                t
            }
        });
    }
    if let Some(t) = total.as_mut().filter(|_| !reports.is_empty()) {
        t["progressive"] = merge_progressive(&reports);
    }
    if let Some(t) = total.as_mut().filter(|_| range_maps.len() == parts.len()) {
        // Every tile traced the same maps for its ranges: one tile's ranges hold them all.
        let first = range_maps[0].0.clone();
        let one_tile: Vec<(Value, u64)> = range_maps
            .into_iter()
            .filter(|(tile, _, _)| *tile == first)
            .map(|(_, maps, passes)| (maps, passes))
            .collect();
        t["photon_maps"] = merge_range_maps(&one_tile);
    }
    if let Some(t) = total.as_mut().filter(|_| !memories.is_empty()) {
        t["memory"] = merge_memory(&memories);
    }
    Ok(total.unwrap_or(Value::Null))
}

/// The memory of the whole from the parts' `memories`: each part loaded the same scene and
/// built the same BVH, so its sizes (triangles, mesh and BVH bytes, the BVH's settings) are the
/// first part's, not their sum (four tiles read four times the triangles); the peaks (the BVH
/// build's, the process's resident memory) and what the build kept resident (measured, so not
/// quite alike) the largest part's, the most one machine needed.
fn merge_memory(memories: &[Value]) -> Value {
    let mut memory = memories[0].clone();
    for key in [
        "bvh_build_peak_bytes",
        "peak_resident_bytes",
        "bvh_resident_bytes",
    ] {
        let most = memories.iter().filter_map(|m| m[key].as_u64()).max();
        memory[key] = most.unwrap_or(0).into();
    }
    // Unknown (null) in a part where the kernel's peak could not be restarted: the largest
    // known, null where none is.
    let key = "bvh_build_resident_peak_bytes";
    memory[key] = memories.iter().filter_map(|m| m[key].as_u64()).max().into();
    let (peak, triangles) = (
        memory["peak_resident_bytes"].as_u64(),
        memory["triangles"].as_u64(),
    );
    if let (Some(peak), Some(triangles)) = (peak, triangles.filter(|&t| t > 0)) {
        memory["peak_bytes_per_triangle"] = (peak as f64 / triangles as f64).into();
    }
    memory
}

/// The number of passes of a pass-range part, from its progressive report's `pass_range`
/// `[A, B]`; `None` for a part that is not a range.
fn range_passes(report: &Value) -> Option<u64> {
    match report["pass_range"].as_array()?.as_slice() {
        [a, b] => Some(b.as_u64()?.saturating_sub(a.as_u64()?)),
        _ => None,
    }
}

/// The photon maps' figures of pass-range parts (each part's maps with its number of passes),
/// as one process rendering all their passes reports them: counts summed over the passes
/// (emitted, stored, rays, asked, guards), a cap reached in any pass reached, and the power
/// the mean over the passes (each part's is the mean of its own).
fn merge_range_maps(parts: &[(Value, u64)]) -> Value {
    let mut maps: Vec<Value> = Vec::new();
    let mut weighted_power: Vec<f64> = Vec::new();
    for (part_maps, passes) in parts {
        for map in part_maps.as_array().into_iter().flatten() {
            let power = map["power"].as_f64().unwrap_or(0.0) * *passes as f64;
            match maps.iter().position(|m| m["class"] == map["class"]) {
                Some(k) => {
                    add(&mut maps[k], map, "");
                    let reached = maps[k]["cap_reached"].as_bool().unwrap_or(false)
                        || map["cap_reached"].as_bool().unwrap_or(false);
                    maps[k]["cap_reached"] = reached.into();
                    weighted_power[k] += power;
                }
                None => {
                    maps.push(map.clone());
                    weighted_power.push(power);
                }
            }
        }
    }
    let passes: u64 = parts.iter().map(|(_, n)| n).sum();
    for (map, power) in maps.iter_mut().zip(weighted_power) {
        map["power"] = (power / passes.max(1) as f64).into();
    }
    Value::Array(maps)
}

/// The progressive report of the parts' `reports`. It describes the run, not a count: every
/// part carries the whole render's pass count and schedule (summed, two ranges of a 3-pass
/// render read 6 passes and an alpha of 1.0), so they come from the first part; the last
/// pass's footprint factor is the smallest of the parts', the seconds per pass their mean
/// (weighed by their passes, for ranges);
/// and the noise, which the parts' own estimates do not give (a range's is of its passes, a
/// tile's of its pixels), is left out (`null`); [`super::merge`] computes it again from the
/// merged sums where they are the whole image's.
fn merge_progressive(reports: &[Value]) -> Value {
    let mut report = reports[0].clone();
    let numbers = |key: &'static str| reports.iter().filter_map(move |r| r.get(key)?.as_f64());
    if let Some(least) = numbers("last_area_factor").reduce(f64::min) {
        report["last_area_factor"] = least.into();
    }
    // Weighed by each part's passes where the parts are ranges (1 pass of 0.2 s and 3 of 0.8 s
    // are 0.65 s a pass, not 0.5); tiles all render every pass.
    let weights: Vec<f64> = reports
        .iter()
        .map(|r| range_passes(r).map_or(1.0, |n| n as f64))
        .collect();
    let seconds: Vec<(f64, f64)> = reports
        .iter()
        .zip(&weights)
        .filter_map(|(r, w)| Some((r.get("seconds_per_pass")?.as_f64()?, *w)))
        .collect();
    let weight: f64 = seconds.iter().map(|(_, w)| w).sum();
    if weight > 0.0 {
        report["seconds_per_pass"] =
            (seconds.iter().map(|(s, w)| s * w).sum::<f64>() / weight).into();
    }
    report["noise"] = Value::Null;
    // The merged image holds the parts' passes together: no one part's range.
    if let Some(fields) = report.as_object_mut() {
        fields.remove("pass_range");
    }
    report
}

/// Adds the numbers of `b` into `a`, field by field; stages are added by name.
fn add(a: &mut Value, b: &Value, key: &str) {
    // Not counts of work: each has its own rule (above), or describes the one scene every
    // part loaded (its mesh repairs: four tiles did not repair four times the triangles).
    if matches!(
        key,
        "photon_maps" | "reference_noise" | "progressive" | "memory" | "mesh_repairs"
    ) {
        return;
    }
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            *x = match (x.as_u64(), y.as_u64()) {
                (Some(p), Some(q)) => p.saturating_add(q).into(),
                _ => serde_json::Number::from_f64(
                    x.as_f64().unwrap_or(0.0) + y.as_f64().unwrap_or(0.0),
                )
                .unwrap_or_else(|| 0.into()),
            }
        }
        (Value::Object(x), Value::Object(y)) => {
            for (k, v) in y {
                match x.get_mut(k) {
                    Some(slot) => add(slot, v, k),
                    None => {
                        x.insert(k.clone(), v.clone());
                    }
                }
            }
        }
        (Value::Array(x), Value::Array(y)) if key == "stages" => {
            for stage in y {
                let name = stage.get("name");
                match x.iter_mut().find(|s| s.get("name") == name) {
                    Some(slot) => add(slot, stage, ""),
                    None => x.push(stage.clone()),
                }
            }
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::part;
    use super::*;

    /// Counts and times are summed; the progressive report is the run's (two ranges of a
    /// 3-pass render summed read 6 passes, alpha 1.0 and the noises added).
    #[test]
    fn merged_statistics_sum_counts_but_not_the_progressive_report() {
        let stats = |rays: u64, factor: f64, seconds: f64| {
            serde_json::json!({
                "rays": {"camera": rays},
                "threads": 1,
                "progressive": {
                    "passes": 3, "pass_range": [0, 1], "alpha": 0.5, "global_alpha": 0.667,
                    "last_area_factor": factor, "stop": "passes", "seconds_per_pass": seconds,
                    "noise": {"whole": 0.1, "caustic": 0.2, "caustic_pixels": 40}
                }
            })
            .to_string()
        };
        let a = part("a.exr", &[("stats", &stats(100, 1.0, 0.2))]);
        let b = part("b.exr", &[("stats", &stats(200, 0.625, 0.4))]);
        let merged = merge_stats(&[a, b]).unwrap();
        assert_eq!(merged["rays"]["camera"], 300);
        assert_eq!(merged["threads"], 2);
        let p = &merged["progressive"];
        assert_eq!(
            (&p["passes"], &p["alpha"], &p["global_alpha"]),
            (&3.into(), &0.5.into(), &0.667.into())
        );
        assert_eq!(p["last_area_factor"], 0.625);
        assert!((p["seconds_per_pass"].as_f64().unwrap() - 0.3).abs() < 1e-12);
        assert_eq!(p["stop"], "passes");
        assert!(p["noise"].is_null());
        assert!(p.get("pass_range").is_none(), "{p}");
    }

    /// Two tiles, each rendered as two pass ranges: the scene's memory and repairs are one
    /// part's (not four times the triangles), the peaks the largest, and the photon maps the sum
    /// over one tile's ranges (every tile traced the same maps: not twice them).
    #[test]
    fn merged_statistics_of_tiles_in_ranges_count_the_scene_and_the_maps_once() {
        let stats = |range: [u64; 2], stored: u64, peak: u64| {
            serde_json::json!({
                "rays": {"camera": 10},
                "memory": {"triangles": 100, "mesh_bytes": 2400, "bvh_bytes": 5000,
                           "bvh_build_peak_bytes": peak / 2, "peak_resident_bytes": peak,
                           "bvh_resident_bytes": peak / 4,
                           "bvh_build_resident_peak_bytes":
                               (peak != 3000).then_some(peak / 3),
                           "peak_bytes_per_triangle": peak as f64 / 100.0},
                "mesh_repairs": {"degenerate_triangles": 3},
                "photon_maps": [{"class": "Caustic", "stored": stored, "power": 1.0}],
                "progressive": {"passes": 3, "pass_range": range}
            })
            .to_string()
        };
        let parts = [
            ("0/2", [0, 1], 10, 1000),
            ("0/2", [1, 3], 20, 3000),
            ("1/2", [0, 1], 10, 2000),
            ("1/2", [1, 3], 20, 1000),
        ]
        .map(|(tile, range, stored, peak)| {
            let stats = stats(range, stored, peak);
            part("p.exr", &[("tile", tile), ("stats", &stats)])
        });
        let merged = merge_stats(&parts).unwrap();
        assert_eq!(merged["rays"]["camera"], 40);
        let m = &merged["memory"];
        assert_eq!(
            (&m["triangles"], &m["mesh_bytes"]),
            (&100.into(), &2400.into())
        );
        assert_eq!(m["bvh_bytes"], 5000);
        assert_eq!(m["peak_resident_bytes"], 3000);
        assert_eq!(m["bvh_build_peak_bytes"], 1500);
        assert_eq!(m["bvh_resident_bytes"], 750);
        // The part of peak 3000 could not measure it (null): the largest of the others.
        assert_eq!(m["bvh_build_resident_peak_bytes"], 666);
        assert_eq!(m["peak_bytes_per_triangle"], 30.0);
        assert_eq!(merged["mesh_repairs"]["degenerate_triangles"], 3);
        assert_eq!(merged["photon_maps"][0]["stored"], 30);
    }
}
