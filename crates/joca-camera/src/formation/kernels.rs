//! The per-pixel loops of image formation, kept apart from the readable model in `mod.rs`.
//!
//! The frame is cut into bands of [`TILE_ROWS`] rows. Band `t` draws its normals from its own
//! xoshiro256++ generator seeded from `(frame seed, t)`, so bands can run on any thread in any
//! order and the frame is still bit-identical. Within a band values are visited in memory order
//! and every value consumes exactly one normal, which is what lets
//! [`standard_normals`] reproduce the field.

use super::{FormationParams, NoiseGain, WHITE_LEVEL};
use joca_core::HdrImage;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;

/// Rows per independently seeded band.
pub const TILE_ROWS: usize = 16;

fn band_rng(frame_seed: u64, band: usize) -> Xoshiro256PlusPlus {
    // A SplitMix64-style mix keeps nearby (seed, band) pairs far apart in seed space.
    let mut z = frame_seed ^ (band as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    Xoshiro256PlusPlus::seed_from_u64(z ^ (z >> 31))
}

/// `I + σ(I)·z` for one channel value with that channel's constants; the shared core of every
/// variant below. Plain multiply-adds rather than `mul_add`: without a guaranteed FMA unit the
/// latter is a library call, and plain arithmetic lets the loops below vectorise.
#[inline(always)]
fn noisy(i0: f32, scale: f32, photon_var_per_dn: f32, read_var: f32, z: f32) -> f32 {
    let i = i0 * scale;
    let var = photon_var_per_dn * i + read_var;
    var.max(0.0).sqrt() * z + i
}

/// Values per unrolled group: 4 RGB pixels, so the per-channel constants form a fixed pattern
/// the compiler can keep in vector registers.
const GROUP: usize = 12;

/// Per-channel constants repeated over a [`GROUP`].
struct Pattern {
    scale: f32,
    photon: [f32; GROUP],
    read: [f32; GROUP],
}

impl Pattern {
    fn new(p: &FormationParams) -> Self {
        Self {
            scale: p.intensity_scale,
            photon: std::array::from_fn(|k| p.photon_var_per_dn[k % 3]),
            read: std::array::from_fn(|k| p.read_var[k % 3]),
        }
    }

    /// Applies `emit(k, noisy value)` to every value of a band, `z` holding its normals.
    #[inline(always)]
    fn apply<T>(&self, src: &[f32], z: &[f32], dst: &mut [T], emit: impl Fn(f32) -> T) {
        let groups = src.len() / GROUP * GROUP;
        for ((s, zz), d) in src[..groups]
            .chunks_exact(GROUP)
            .zip(z[..groups].chunks_exact(GROUP))
            .zip(dst[..groups].chunks_exact_mut(GROUP))
        {
            for k in 0..GROUP {
                d[k] = emit(noisy(s[k], self.scale, self.photon[k], self.read[k], zz[k]));
            }
        }
        // A band always holds whole pixels, so the remainder starts at channel 0.
        for k in groups..src.len() {
            let c = k - groups;
            dst[k] = emit(noisy(src[k], self.scale, self.photon[c], self.read[c], z[k]));
        }
    }
}

fn fill_normals(z: &mut [f32], frame_seed: u64, band: usize) {
    let mut rng = band_rng(frame_seed, band);
    z.iter_mut().for_each(|v| *v = rng.sample(StandardNormal));
}

/// The normals of band `t` scaled by the resize's noise gain, where there is one.
fn scale_normals(z: &mut [f32], gain: Option<&NoiseGain>, band: usize) {
    if let Some(g) = gain {
        g.apply(z, band * TILE_ROWS);
    }
}

#[inline(always)]
fn quantise(v: f32) -> u8 {
    // Clamp first, so NaN-free values in [0, 255] round half up; `as` saturates anyway.
    (v.clamp(0.0, WHITE_LEVEL) + 0.5) as u8
}

/// Clipped, quantised formation into `out` (interleaved RGB bytes).
pub(super) fn form_u8(
    i0: &HdrImage,
    p: &FormationParams,
    seed: u64,
    gain: Option<&NoiseGain>,
    out: &mut [u8],
    parallel: bool,
) {
    let band = TILE_ROWS * i0.width() * 3;
    if band == 0 {
        return;
    }
    let pattern = Pattern::new(p);
    // Normals are drawn into a per-band buffer first, so that the arithmetic pass below has no
    // generator calls in its loop and vectorises.
    let work = |z: &mut Vec<f32>, (t, (src, dst)): (usize, (&[f32], &mut [u8]))| {
        z.resize(src.len(), 0.0);
        fill_normals(z, seed, t);
        scale_normals(z, gain, t);
        pattern.apply(src, z, dst, quantise);
    };
    if parallel {
        i0.data()
            .par_chunks(band)
            .zip(out.par_chunks_mut(band))
            .enumerate()
            .for_each_init(|| Vec::with_capacity(band), work);
    } else {
        let mut z = Vec::with_capacity(band);
        for item in i0.data().chunks(band).zip(out.chunks_mut(band)).enumerate() {
            work(&mut z, item);
        }
    }
}

/// [`form_u8`] with the normals given (as [`standard_normals`] draws them), sequentially.
pub(super) fn form_u8_with_normals(i0: &HdrImage, p: &FormationParams, z: &[f32], out: &mut [u8]) {
    let band = TILE_ROWS * i0.width() * 3;
    if band == 0 {
        return;
    }
    let pattern = Pattern::new(p);
    // Band by band, as `form_u8` runs, so the loop is the same one the compiler vectorises.
    for ((src, z), dst) in i0.data().chunks(band).zip(z.chunks(band)).zip(out.chunks_mut(band)) {
        pattern.apply(src, z, dst, quantise);
    }
}

/// Unclipped, unquantised formation into `out` (interleaved RGB floats).
pub(super) fn form_linear(
    i0: &HdrImage,
    p: &FormationParams,
    seed: u64,
    gain: Option<&NoiseGain>,
    out: &mut [f32],
) {
    let band = TILE_ROWS * i0.width() * 3;
    if band == 0 {
        return;
    }
    let pattern = Pattern::new(p);
    let mut z = vec![0.0; band];
    for (t, (src, dst)) in i0.data().chunks(band).zip(out.chunks_mut(band)).enumerate() {
        let z = &mut z[..src.len()];
        fill_normals(z, seed, t);
        scale_normals(z, gain, t);
        pattern.apply(src, z, dst, |v| v);
    }
}

/// The normal field that formation with `seed` draws, in interleaved RGB order, before any
/// noise gain.
pub(super) fn standard_normals(width: usize, height: usize, seed: u64) -> Vec<f32> {
    let band = TILE_ROWS * width * 3;
    let mut out = vec![0.0f32; width * height * 3];
    if band == 0 {
        return out;
    }
    for (t, dst) in out.chunks_mut(band).enumerate() {
        fill_normals(dst, seed, t);
    }
    out
}
