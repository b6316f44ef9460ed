//! Emissions drawn a group at a time: each emission's light and point of the unit square one
//! by one (they read its random stream), then the directions of the whole group from their
//! cones at once ([`sample_cones`], vector instructions), then each emission completed as the
//! tracer starts it. The same emissions as [`Emitter::launch`], bit for bit: only the order in
//! which independent emissions' arithmetic is done differs.

use super::{Emitter, Launch};
use crate::geometry::sampling::{r2_many, sample_cones};
use crate::util::rng::Rng;
use glam::DVec3;
use std::ops::Range;

/// Emissions drawn in a group.
const WIDTH: usize = 16;

/// A group of emissions drawn ahead by [`Emitter::draw`], started one at a time by
/// [`Emitter::launch_drawn`].
pub struct Drawn {
    /// Index of the group's first emission.
    first: u64,
    /// Emissions in the group, and how many are started.
    len: usize,
    next: usize,
    /// Each emission's random stream, after its light and square point were drawn.
    rngs: [Rng; WIDTH],
    /// Each emission's source.
    picks: [usize; WIDTH],
    /// Each emission's point of the unit square.
    u: [f64; WIDTH],
    v: [f64; WIDTH],
    /// Each point or spot light emission's direction (unused for quad lights).
    directions: [DVec3; WIDTH],
}

impl Default for Drawn {
    fn default() -> Self {
        Drawn {
            first: 0,
            len: 0,
            next: 0,
            rngs: std::array::from_fn(|_| Rng::new(0, 0)),
            picks: [0; WIDTH],
            u: [0.0; WIDTH],
            v: [0.0; WIDTH],
            directions: [DVec3::ZERO; WIDTH],
        }
    }
}

impl Emitter {
    /// Draws emissions `indices` (at most 16, replacing what `drawn` held), emission `i` with
    /// the random stream `Rng::new(seed, i)`.
    pub fn draw(&self, indices: Range<u64>, seed: u64, drawn: &mut Drawn) {
        let len = (indices.end - indices.start) as usize;
        assert!(len <= WIDTH && !self.sources.is_empty());
        // The streams and the uniforms that pick the lights, for the whole group at once.
        let picks;
        (drawn.rngs, picks) = Rng::new_many(seed, indices.start);
        for (k, &pick) in drawn.picks[..len].iter_mut().zip(&picks) {
            *k = self.pick_from(pick);
        }
        // The squares' points as `square_sample` draws them.
        if self.random {
            for l in 0..len {
                let rng = &mut drawn.rngs[l];
                (drawn.u[l], drawn.v[l]) = (rng.uniform(), rng.uniform());
            }
        } else {
            (drawn.u, drawn.v) = r2_many(indices.start, self.shift);
        }
        // Lanes past the group and quad lights' lanes (whose cones start at each emission's
        // point) sample some point or spot light's cone too, and are not read.
        if let Some(any) = self.sources.iter().find_map(|s| s.cone.as_ref()) {
            let cones = std::array::from_fn(|l| match l < len {
                true => self.sources[drawn.picks[l]].cone.as_ref().unwrap_or(any),
                false => any,
            });
            drawn.directions = sample_cones(cones, &drawn.u, &drawn.v);
        }
        (drawn.first, drawn.len, drawn.next) = (indices.start, len, 0);
    }

    /// Starts the next emission of `drawn`: `rng` is set to its random stream and its launch
    /// handed to `start` (as [`Emitter::launch`] would: `None` where that answers `None`).
    /// Answers the emission's index with `start`'s answer; `None` once the group is used up.
    #[inline]
    pub fn launch_drawn<R>(
        &self,
        drawn: &mut Drawn,
        rng: &mut Rng,
        start: impl FnOnce(&Launch) -> R,
    ) -> Option<(u64, Option<R>)> {
        let l = drawn.next;
        if l >= drawn.len {
            return None;
        }
        drawn.next += 1;
        rng.clone_from(&drawn.rngs[l]);
        let (k, d) = (drawn.picks[l], drawn.directions[l]);
        let launched = self.emit_drawn(k, (drawn.u[l], drawn.v[l]), |_| d, rng, start);
        Some((drawn.first + l as u64, launched))
    }
}
