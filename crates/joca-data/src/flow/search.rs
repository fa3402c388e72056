//! DIS's patch search at one scale: the inverse-compositional search of each patch (damped as
//! OpenCV's), spatial propagation in fixed stripes, and the bordered image patches are sampled
//! from.

use super::{DisParams, Flow, Gray};
use rayon::prelude::*;

mod padded;
pub(super) use padded::Padded;

/// The fraction of the Gauss–Newton step taken per inverse-search iteration. OpenCV's DIS
/// builds both the structure tensor and the update from 3×3 Sobel responses, which are 8× the
/// derivative, so each of its steps is 1/8 of the Gauss–Newton step: a damped descent that
/// creeps towards the minimum and stops once the patch distance stops falling. Here the
/// derivative is normalised and the damping is explicit. On the motorcycle pair full steps
/// gave a medium end-point error of 3.55 px against OpenCV's 2.63; damped, 2.65
/// (docs/results, 2026-11-24 renderer-and-flow-bench).
const STEP: f32 = 1.0 / 8.0;

/// Smallest determinant of a patch's structure tensor (textureless patches): larger steps are
/// then refused by the distance rule of [`Template::search`].
const MIN_DET: f32 = 1e-9;

/// One patch of `I0`: its mean-normalised template, the centred gradients (the update's) and
/// the structure tensor of the raw gradients (as OpenCV's DIS) for the inverse-compositional
/// search.
pub(super) struct Template {
    /// `I0` over the patch, row-major.
    t: Vec<f32>,
    /// Its raw gradients.
    gx: Vec<f32>,
    gy: Vec<f32>,
    /// Σ gx, Σ gy over the patch.
    g_sum: [f32; 2],
    origin: (f32, f32),
    h: [f32; 3],
    det: f32,
    side: f32,
}

/// Lanes of the patch sums: eight running sums, added in a fixed order at the end, so the loop
/// vectorises and its result does not depend on the machine.
const LANES: usize = 8;

impl Template {
    #[inline(always)]
    fn new(i0: &Gray, gx: &Gray, gy: &Gray, (px, py): (usize, usize), size: usize) -> Self {
        let n = size * size;
        let (w, h) = (i0.width(), i0.height());
        let (mut t, mut tx, mut ty) =
            (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
        for j in 0..size {
            for i in 0..size {
                let (x, y) = ((px + i).min(w - 1), (py + j).min(h - 1));
                t.push(i0.at(x, y));
                tx.push(gx.at(x, y));
                ty.push(gy.at(x, y));
            }
        }
        // The structure tensor of the raw gradients (as OpenCV's).
        let (mut hxx, mut hxy, mut hyy) = (0.0f32, 0.0f32, 0.0f32);
        for (&a, &b) in tx.iter().zip(&ty) {
            hxx += a * a;
            hxy += a * b;
            hyy += b * b;
        }
        let g_sum = [tx.iter().sum(), ty.iter().sum()];
        let det = hxx * hyy - hxy * hxy;
        let det = if det.abs() < MIN_DET { MIN_DET } else { det };
        let origin = (px as f32, py as f32);
        Self { t, gx: tx, gy: ty, g_sum, origin, h: [hxx, hxy, hyy], det, side: size as f32 }
    }

    /// With `d = I1(x + u) − I0(x)` over the patch (`warped` holds `I1(x + u)`): the
    /// mean-normalised distance `Σ d² − (Σ d)²/n` and the update `Σ d ∇I − Σ d · Σ ∇I / n`,
    /// i.e. the sums of the mean-normalised residual.
    #[inline(always)]
    fn distance(&self, warped: &[f32]) -> (f32, [f32; 2]) {
        let mut acc = [[0.0f32; LANES]; 4];
        let chunks = warped.len() / LANES * LANES;
        for base in (0..chunks).step_by(LANES) {
            let (w, t) = (&warped[base..base + LANES], &self.t[base..base + LANES]);
            let (gx, gy) = (&self.gx[base..base + LANES], &self.gy[base..base + LANES]);
            for l in 0..LANES {
                let d = w[l] - t[l];
                acc[0][l] += d;
                acc[1][l] += d * d;
                acc[2][l] += d * gx[l];
                acc[3][l] += d * gy[l];
            }
        }
        let rest = warped[chunks..].iter().zip(&self.t[chunks..]);
        for ((w, t), (gx, gy)) in rest.zip(self.gx[chunks..].iter().zip(&self.gy[chunks..])) {
            let d = w - t;
            acc[0][0] += d;
            acc[1][0] += d * d;
            acc[2][0] += d * gx;
            acc[3][0] += d * gy;
        }
        self.finish(acc, warped.len())
    }

    /// The distance and update from the lane sums of `n` pixels.
    #[inline(always)]
    fn finish(&self, acc: [[f32; LANES]; 4], n: usize) -> (f32, [f32; 2]) {
        let [sd, sd2, sx, sy] = acc.map(|a| a.iter().sum::<f32>());
        let n = n as f32;
        (sd2 - sd * sd / n, [sx - sd * self.g_sum[0] / n, sy - sd * self.g_sum[1] / n])
    }

    /// The warped patch at `u` into `buf` and its [`Template::distance`].
    #[inline(always)]
    fn at(&self, i1: &Padded, u: [f32; 2], buf: &mut Vec<f32>) -> (f32, [f32; 2]) {
        let size = self.side as usize;
        buf.resize(size * size, 0.0);
        i1.patch(self.origin.0 + u[0], self.origin.1 + u[1], size, buf);
        self.distance(buf)
    }

    /// [`Template::at`] for an 8×8 patch in AVX2, sampling and summing a patch row (eight
    /// pixels, the eight lanes) per instruction: the same operations in the same order per
    /// pixel and lane as the portable code, so the same bits.
    ///
    /// # Safety
    /// The CPU must have AVX2, and the template must be 8×8.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[allow(unsafe_code)]
    unsafe fn at8_avx2(&self, i1: &Padded, u: [f32; 2]) -> (f32, [f32; 2]) {
        use std::arch::x86_64::*;
        debug_assert!(self.t.len() == 64 && self.gx.len() == 64 && self.gy.len() == 64);
        let (start, [w00, w01, w10, w11]) =
            i1.place(self.origin.0 + u[0], self.origin.1 + u[1], (8, 8));
        let (w00, w01) = (_mm256_set1_ps(w00), _mm256_set1_ps(w01));
        let (w10, w11) = (_mm256_set1_ps(w10), _mm256_set1_ps(w11));
        let mut acc = [_mm256_setzero_ps(); 4];
        // Rows start..start + 9 · stride, nine samples each, lie inside the padded image
        // (`Padded::place` clamps for it); the template rows are 8 of its 64 values.
        let data = &i1.data[start..start + 8 * i1.stride + 9];
        for j in 0..8 {
            let (top, bottom) = (&data[j * i1.stride..][..9], &data[(j + 1) * i1.stride..][..9]);
            // SAFETY: each load reads 8 floats inside a slice of 9 (offsets 0 and 1), or 8
            // floats of a 64-float template row j.
            let (t0, t1, b0, b1, t, gx, gy) = unsafe {
                (
                    _mm256_loadu_ps(top.as_ptr()),
                    _mm256_loadu_ps(top.as_ptr().add(1)),
                    _mm256_loadu_ps(bottom.as_ptr()),
                    _mm256_loadu_ps(bottom.as_ptr().add(1)),
                    _mm256_loadu_ps(self.t[8 * j..][..8].as_ptr()),
                    _mm256_loadu_ps(self.gx[8 * j..][..8].as_ptr()),
                    _mm256_loadu_ps(self.gy[8 * j..][..8].as_ptr()),
                )
            };
            let warped = _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(w00, t0), _mm256_mul_ps(w01, t1)),
                _mm256_add_ps(_mm256_mul_ps(w10, b0), _mm256_mul_ps(w11, b1)),
            );
            let d = _mm256_sub_ps(warped, t);
            acc[0] = _mm256_add_ps(acc[0], d);
            acc[1] = _mm256_add_ps(acc[1], _mm256_mul_ps(d, d));
            acc[2] = _mm256_add_ps(acc[2], _mm256_mul_ps(d, gx));
            acc[3] = _mm256_add_ps(acc[3], _mm256_mul_ps(d, gy));
        }
        let mut lanes = [[0.0f32; LANES]; 4];
        for (out, a) in lanes.iter_mut().zip(acc) {
            // SAFETY: `out` holds 8 floats.
            unsafe { _mm256_storeu_ps(out.as_mut_ptr(), a) };
        }
        self.finish(lanes, 64)
    }

    /// The patch distance and update at `u`, with the AVX2 kernel when `AVX2` (set only on
    /// the AVX2 path, once the CPU is known to have it) and the patch is 8×8.
    #[inline(always)]
    #[allow(unsafe_code)]
    fn eval<const AVX2: bool>(
        &self,
        i1: &Padded,
        u: [f32; 2],
        buf: &mut Vec<f32>,
    ) -> (f32, [f32; 2]) {
        #[cfg(target_arch = "x86_64")]
        if AVX2 && self.t.len() == 64 {
            // SAFETY: AVX2 is only set by `Stripe::search_avx2`, called after the CPU check;
            // the template is 8×8.
            return unsafe { self.at8_avx2(i1, u) };
        }
        self.at(i1, u, buf)
    }

    /// The best start among `candidates` (least distance, the first on ties), refined by up to
    /// `iterations` damped inverse-compositional steps ([`STEP`]), stopping after the step
    /// taken where the patch distance stopped falling; the start itself if the result moved
    /// more than a patch side from it (OpenCV's rule: such jumps are mostly wrong).
    #[inline(always)]
    fn search<const AVX2: bool>(
        &self,
        i1: &Padded,
        candidates: &[[f32; 2]],
        iterations: usize,
        buf: &mut Vec<f32>,
    ) -> [f32; 2] {
        let mut start = candidates[0];
        let mut start_ssd = self.eval::<AVX2>(i1, start, buf).0;
        for &c in &candidates[1..] {
            let ssd = self.eval::<AVX2>(i1, c, buf).0;
            if ssd < start_ssd {
                (start, start_ssd) = (c, ssd);
            }
        }
        let [hxx, hxy, hyy] = self.h;
        let mut u = start;
        let mut previous = f32::INFINITY;
        for _ in 0..iterations {
            let (ssd, [bx, by]) = self.eval::<AVX2>(i1, u, buf);
            let dx = STEP * (hyy * bx - hxy * by) / self.det;
            let dy = STEP * (hxx * by - hxy * bx) / self.det;
            u = [u[0] - dx, u[1] - dy];
            if ssd >= previous {
                break;
            }
            previous = ssd;
        }
        let moved = (u[0] - start[0]).hypot(u[1] - start[1]);
        if moved <= self.side { u } else { start }
    }
}

/// Patch rows per stripe of the patch search. Spatial propagation runs within a stripe and the
/// stripes run in parallel; the partition is fixed, so the flow does not depend on the thread
/// count.
const STRIPE_ROWS: usize = 8;

/// What the patch search of one stripe reads.
struct Stripe<'a> {
    i0: &'a Gray,
    i1: &'a Padded,
    gx: &'a Gray,
    gy: &'a Gray,
    xs: &'a [usize],
    ys: &'a [usize],
    size: usize,
    /// Search iterations of the forward and the backward pass.
    iterations: (usize, usize),
}

impl Stripe<'_> {
    /// The forward and backward passes over the stripe of patch rows from `row0` (`chunk`: their
    /// flows, updated in place). With AVX2 where the CPU has it: the portable code compiled for
    /// wider vectors, with 8×8 patches through [`Template::at8_avx2`]; the arithmetic per patch
    /// is unchanged (Rust does not fuse or reorder floating-point operations), so both paths
    /// give the same bits.
    #[allow(unsafe_code)] // calling a target-feature function once the CPU is known to have it
    fn search(&self, row0: usize, chunk: &mut [[f32; 2]]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (checked just above).
            return unsafe { self.search_avx2(row0, chunk) };
        }
        self.search_portable::<false>(row0, chunk);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn search_avx2(&self, row0: usize, chunk: &mut [[f32; 2]]) {
        self.search_portable::<true>(row0, chunk);
    }

    #[inline(always)]
    fn search_portable<const AVX2: bool>(&self, row0: usize, chunk: &mut [[f32; 2]]) {
        let (nx, size) = (self.xs.len(), self.size);
        let rows = chunk.len() / nx;
        let (forward_iterations, backward_iterations) = self.iterations;
        let templates: Vec<Template> = (0..rows * nx)
            .map(|k| {
                let origin = (self.xs[k % nx], self.ys[row0 + k / nx]);
                Template::new(self.i0, self.gx, self.gy, origin, size)
            })
            .collect();
        let i1 = self.i1;
        let mut e = Vec::with_capacity(size * size);
        let mut candidates = Vec::with_capacity(3);
        for r in 0..rows {
            for c in 0..nx {
                candidates.clear();
                candidates.push(chunk[r * nx + c]);
                if c > 0 {
                    candidates.push(chunk[r * nx + c - 1]);
                }
                if r > 0 {
                    candidates.push(chunk[(r - 1) * nx + c]);
                }
                chunk[r * nx + c] = templates[r * nx + c].search::<AVX2>(
                    i1,
                    &candidates,
                    forward_iterations,
                    &mut e,
                );
            }
        }
        for r in (0..rows).rev() {
            for c in (0..nx).rev() {
                candidates.clear();
                candidates.push(chunk[r * nx + c]);
                if c + 1 < nx {
                    candidates.push(chunk[r * nx + c + 1]);
                }
                if r + 1 < rows {
                    candidates.push(chunk[(r + 1) * nx + c]);
                }
                chunk[r * nx + c] = templates[r * nx + c].search::<AVX2>(
                    i1,
                    &candidates,
                    backward_iterations,
                    &mut e,
                );
            }
        }
    }
}

/// The patch search of one scale with spatial propagation (as OpenCV's DIS): a forward pass in
/// raster order, each patch starting from the best of its own estimate and its left and upper
/// neighbours', then a backward pass from the right and lower neighbours', each pass with half
/// the iterations.
pub(super) fn search_patches(
    i0: &Gray,
    i1: &Padded,
    (gx, gy): (&Gray, &Gray),
    xs: &[usize],
    ys: &[usize],
    init: &Flow,
    p: &DisParams,
) -> Vec<[f32; 2]> {
    let size = p.patch_size;
    let half = size as f32 / 2.0 - 0.5;
    let nx = xs.len();
    let mut flows: Vec<[f32; 2]> = ys
        .iter()
        .flat_map(|&y| xs.iter().map(move |&x| init.sample(x as f32 + half, y as f32 + half)))
        .collect();
    let stripe = Stripe {
        i0,
        i1,
        gx,
        gy,
        xs,
        ys,
        size,
        iterations: (p.search_iterations / 2, p.search_iterations / 2),
    };
    flows
        .par_chunks_mut(STRIPE_ROWS * nx)
        .enumerate()
        .for_each(|(k, chunk)| stripe.search(k * STRIPE_ROWS, chunk));
    flows
}

#[cfg(test)]
mod tests;
