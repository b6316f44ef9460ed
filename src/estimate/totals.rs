//! Per-query totals of the photons a batch of gathers settled together: the estimators that
//! answer a packet of gathers at once ([`super::RadianceEstimator::radiance_batch`]) evaluate
//! their photons in batches and then add each photon's contribution to its query's total.

use glam::Vec3;

/// Adds each `(query, contribution)` of `terms` to `totals[query]`, in order.
///
/// Why not `totals[query] += contribution`: a batch's terms come in runs of one query (a
/// gather's photons are batched together), and added in place each term waits for the store of
/// the one before to be read back. Here a run's sum stays in registers and is stored once the
/// query changes. The additions are the same ones, in the same order, so the totals are bit for
/// bit those of adding in place (tested). With it (and the two batches of `integrated` taken
/// one after the other rather than through one chained iterator) this loop fell from about 5%
/// of `integrated`'s render stage at 1,280,000 caustic photons to about 3% (profile samples,
/// one thread).
#[inline]
pub fn add_in_runs(totals: &mut [Vec3], terms: impl IntoIterator<Item = (u32, Vec3)>) {
    let mut run: Option<(usize, Vec3)> = None;
    for (query, term) in terms {
        let query = query as usize;
        run = Some(match run {
            Some((current, sum)) if current == query => (current, sum + term),
            ended => {
                if let Some((current, sum)) = ended {
                    totals[current] = sum;
                }
                (query, totals[query] + term)
            }
        });
    }
    if let Some((current, sum)) = run {
        totals[current] = sum;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_add_what_adding_in_place_adds() {
        // Runs of every length, queries revisited after others, terms of mixed magnitudes
        // (where the order of the additions shows in the last bits).
        let mut terms = Vec::new();
        for k in 0..2000u32 {
            let query = (k / 7 + k % 3) % 11;
            let x = (k as f32 * 0.37).sin() * 10f32.powi((k % 9) as i32 - 4);
            terms.push((query, Vec3::new(x, 1.0 / (k as f32 + 1.0), x * x)));
        }
        let start: Vec<Vec3> = (0..11).map(|q| Vec3::splat(q as f32 * 0.1)).collect();
        let mut in_place = start.clone();
        for &(query, term) in &terms {
            in_place[query as usize] += term;
        }
        let mut in_runs = start.clone();
        add_in_runs(&mut in_runs, terms.iter().copied());
        for (a, b) in in_place.iter().zip(&in_runs) {
            assert_eq!(
                a.to_array().map(f32::to_bits),
                b.to_array().map(f32::to_bits)
            );
        }
        assert_ne!(in_runs, start);
        // Nothing to add: the totals are untouched.
        add_in_runs(&mut in_runs, std::iter::empty());
        assert_eq!(in_runs, in_place);
    }
}
