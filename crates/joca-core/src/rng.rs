//! Seeded random streams.
//!
//! A run has one seed. Every consumer of randomness asks [`SeedStreams`] for a stream by name
//! (`"hardware-ga"`, `"noise"`, …) and, where it needs many, by name and index (one stream per
//! frame, per image tile, per candidate). Streams with different names or indices are
//! statistically independent ChaCha8 streams of the same key, so adding a new consumer never
//! shifts the numbers another consumer sees, and work can be split across threads without
//! changing any result.
//!
//! The name is hashed with 64-bit FNV-1a, which is fixed by its specification, so the mapping
//! from (seed, name, index) to numbers is stable across Rust versions and platforms.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The random generator every joca stream uses.
pub type StreamRng = ChaCha8Rng;

/// One run seed and the independent named streams derived from it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SeedStreams {
    seed: u64,
}

impl SeedStreams {
    /// Streams derived from the run seed `seed`.
    pub fn new(seed: u64) -> Self {
        Self { seed }
    }

    /// The run seed.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The stream called `name`.
    pub fn stream(&self, name: &str) -> StreamRng {
        self.indexed(name, 0)
    }

    /// Stream number `index` of the family called `name` (e.g. one per frame).
    pub fn indexed(&self, name: &str, index: u64) -> StreamRng {
        // The key mixes the seed with the name; the ChaCha stream id selects the index. Both are
        // fixed-width integer operations, so the result is platform independent.
        let key = splitmix64(self.seed ^ fnv1a64(name.as_bytes()));
        let mut rng = ChaCha8Rng::seed_from_u64(key);
        rng.set_stream(index);
        rng
    }

    /// A child family: streams of `self.child(name)` never coincide with streams of `self`.
    pub fn child(&self, name: &str) -> SeedStreams {
        SeedStreams { seed: splitmix64(self.seed.rotate_left(17) ^ fnv1a64(name.as_bytes())) }
    }
}

/// 64-bit FNV-1a hash (Fowler–Noll–Vo), as specified by its authors.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        hash ^= u64::from(b);
        hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
    }
    hash
}

/// SplitMix64 finaliser: spreads nearby inputs over the whole 64-bit range.
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    #[test]
    fn fnv1a_matches_the_published_test_vectors() {
        // Test vectors from the FNV reference (Landon Curt Noll's fnv test suite).
        assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn same_seed_and_name_repeat_and_others_differ() {
        let s = SeedStreams::new(42);
        let a: Vec<u64> = (0..4).map(|_| 0).scan(s.stream("x"), |r, _| Some(r.random())).collect();
        let b: Vec<u64> = (0..4).map(|_| 0).scan(s.stream("x"), |r, _| Some(r.random())).collect();
        assert_eq!(a, b);
        let first = |mut r: StreamRng| r.random::<u64>();
        assert_ne!(first(s.stream("x")), first(s.stream("y")));
        assert_ne!(first(s.indexed("x", 1)), first(s.indexed("x", 2)));
        assert_ne!(first(s.stream("x")), first(SeedStreams::new(43).stream("x")));
        assert_ne!(first(s.stream("x")), first(s.child("c").stream("x")));
    }

    #[test]
    fn streams_are_uniform_enough() {
        // Mean of U(0,1) over 100k draws is within 5 standard errors of 0.5 (σ = 1/√12).
        let mut r = SeedStreams::new(1).stream("u");
        let n = 100_000;
        let mean: f64 = (0..n).map(|_| r.random::<f64>()).sum::<f64>() / n as f64;
        let se = (1.0 / 12f64).sqrt() / (n as f64).sqrt();
        assert!((mean - 0.5).abs() < 5.0 * se, "mean {mean}");
    }
}
