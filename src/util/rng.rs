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
        let (state, increment) = seeding(seed, index);
        let mut rng = Rng { state, increment };
        rng.next_u32();
        rng
    }

    /// The next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = step(old, self.increment);
        output(old)
    }

    /// Uniform in `[0, 1)`.
    pub fn uniform(&mut self) -> f64 {
        unit(self.next_u32())
    }

    /// The streams `(seed, first + l)` for `l < N` ([`Rng::new`]), each after its first
    /// [`Rng::uniform`], with those uniforms: the same bits as `N` calls, but in loops over
    /// the streams that compile to vector instructions (each stream's seeding is a chain of
    /// five dependent multiplications, and photon emission seeds one per photon).
    pub fn new_many<const N: usize>(seed: u64, first: u64) -> ([Rng; N], [f64; N]) {
        let (mut state, mut increment, mut uniform) = ([0u64; N], [0u64; N], [0.0; N]);
        for l in 0..N {
            let a;
            (a, increment[l]) = seeding(seed, first.wrapping_add(l as u64));
            // `new`'s discarded draw, then the first uniform.
            let old = step(a, increment[l]);
            state[l] = step(old, increment[l]);
            uniform[l] = unit(output(old));
        }
        let rngs = std::array::from_fn(|l| Rng {
            state: state[l],
            increment: increment[l],
        });
        (rngs, uniform)
    }
}

/// The initial state and the increment of the stream `(seed, index)`.
#[inline(always)]
fn seeding(seed: u64, index: u64) -> (u64, u64) {
    let a = splitmix64(seed ^ splitmix64(index));
    let b = splitmix64(a ^ 0xDA94_2042_E4DD_58B5);
    (a, (b << 1) | 1)
}

/// PCG32's state transition.
#[inline(always)]
fn step(state: u64, increment: u64) -> u64 {
    state
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(increment)
}

/// PCG32's output (XSH RR) for the state `old` it steps from.
#[inline(always)]
fn output(old: u64) -> u32 {
    let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
    let rot = (old >> 59) as u32;
    xorshifted.rotate_right(rot)
}

/// 32 random bits as a uniform in `[0, 1)`: 32 bits are plenty for sampling; the result is
/// strictly below 1.
#[inline(always)]
fn unit(bits: u32) -> f64 {
    bits as f64 * (1.0 / 4_294_967_296.0)
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
        // `new_many` is `new` and `uniform`, stream by stream.
        let (many, first) = Rng::new_many::<5>(9, u64::MAX - 2);
        for (l, mut m) in many.into_iter().enumerate() {
            let mut one = Rng::new(9, (u64::MAX - 2).wrapping_add(l as u64));
            assert_eq!(one.uniform(), first[l]);
            assert_eq!(one.next_u32(), m.next_u32());
        }
        let mut r = Rng::new(7, 0);
        let mean = (0..100_000).map(|_| r.uniform()).sum::<f64>() / 100_000.0;
        assert!((mean - 0.5).abs() < 0.005, "{mean}");
    }
}
