//! A small, fast, seedable random number generator (PCG32 seeded through SplitMix64), so that
//! every pixel or photon can own an independent stream and results do not depend on threads.

/// PCG32 (XSH RR), one stream per seed.
#[derive(Debug, Clone)]
pub struct Rng {
    state: u64,
    increment: u64,
}

fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The seed of sub-run `index` of a run seeded `seed` (e.g. a progressive pass): `seed` itself
/// for index 0, so that a one-pass run is the run it always was, and a well-mixed function of
/// both otherwise.
pub fn derive_seed(seed: u64, index: u64) -> u64 {
    if index == 0 {
        seed
    } else {
        splitmix64(splitmix64(seed ^ 0x005E_ED0F_9A55) ^ splitmix64(index))
    }
}

impl Rng {
    /// The stream for `(seed, index)`: e.g. a run's seed and a pixel or photon number.
    pub fn new(seed: u64, index: u64) -> Self {
        let a = splitmix64(seed ^ splitmix64(index));
        let b = splitmix64(a ^ 0xDA94_2042_E4DD_58B5);
        let mut rng = Rng {
            state: a,
            increment: (b << 1) | 1,
        };
        rng.next_u32();
        rng
    }

    /// The next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(self.increment);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in `[0, 1)`.
    pub fn uniform(&mut self) -> f64 {
        // 32 bits are plenty for sampling; the result is strictly below 1.
        self.next_u32() as f64 * (1.0 / 4_294_967_296.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<u32> = (0..4).map(|_| Rng::new(1, 2).next_u32()).collect();
        assert!(a.windows(2).all(|w| w[0] == w[1]));
        let mut x = Rng::new(1, 2);
        let mut y = Rng::new(1, 3);
        assert_ne!(
            (0..4).map(|_| x.next_u32()).collect::<Vec<_>>(),
            (0..4).map(|_| y.next_u32()).collect::<Vec<_>>()
        );
        let mut r = Rng::new(7, 0);
        let mean = (0..100_000).map(|_| r.uniform()).sum::<f64>() / 100_000.0;
        assert!((mean - 0.5).abs() < 0.005, "{mean}");
    }
}
