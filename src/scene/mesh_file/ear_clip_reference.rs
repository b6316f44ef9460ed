//! Ear clipping as `triangulate` did it before `ear_clip`'s ring and grid (stop 68): every
//! remaining corner tested against every ear, the remaining corners a vector. Kept only as the
//! reference the faster one must match exactly, ear for ear and in the same order: in
//! `ear_clip`'s tests, and beside it in `benches/ear_clipping.rs`. Quadratic in the corner
//! count (about 0.5 s for a star or a comb of 16,384 corners).

use glam::DVec2;

/// Clips the counter-clockwise polygon `points` into triangles of corner numbers, and whether
/// it was clipped whole (`false`: no ear was left, it crosses itself, and the rest was fanned).
pub fn ear_clip(points: &[DVec2]) -> (Vec<[usize; 3]>, bool) {
    let cross = |a: DVec2, b: DVec2, c: DVec2| (b - a).perp_dot(c - b);
    let mut out = Vec::new();
    let mut ring: Vec<usize> = (0..points.len()).collect();
    let (mut i, mut since_last_clip, mut clipped_whole) = (0, 0, true);
    while ring.len() > 3 {
        let m = ring.len();
        let (ip, inext) = ((i + m - 1) % m, (i + 1) % m);
        let (a, b, c) = (points[ring[ip]], points[ring[i]], points[ring[inext]]);
        let turn = cross(a, b, c);
        let scale = (b - a).length_squared().max((c - b).length_squared());
        let is_ear = turn.abs() <= 1e-12 * scale
            || (turn > 0.0
                && !(0..m).any(|j| {
                    let p = points[ring[j]];
                    let (before, after) =
                        (points[ring[(j + m - 1) % m]], points[ring[(j + 1) % m]]);
                    p != a
                        && p != b
                        && p != c
                        && cross(before, p, after) <= 0.0
                        && cross(a, b, p) >= 0.0
                        && cross(b, c, p) >= 0.0
                        && cross(c, a, p) >= 0.0
                }));
        if is_ear {
            if turn.abs() > 1e-12 * scale {
                out.push([ring[ip], ring[i], ring[inext]]);
            }
            ring.remove(i);
            i = (i + ring.len() - 1) % ring.len();
            since_last_clip = 0;
        } else {
            i = (i + 1) % m;
            since_last_clip += 1;
            if since_last_clip > m {
                clipped_whole = false;
                break;
            }
        }
    }
    for w in ring[1..].windows(2) {
        out.push([ring[0], w[0], w[1]]);
    }
    (out, clipped_whole)
}
