//! Dense Inverse Search optical flow (Kroeger, Timofte, Dai, Van Gool, ECCV 2016), in the form
//! OpenCV's `DISOpticalFlow` popularised, written out in Rust.
//!
//! For a reference image `I0` and a target `I1`, the flow `u(x)` satisfies `I0(x) ≈ I1(x + u(x))`.
//! Coarse to fine over a Gaussian pyramid, at each scale:
//! 1. **Patch grid.** Square patches of `patch_size` pixels every `patch_stride` pixels.
//! 2. **Inverse search.** Each patch's translation is refined by inverse-compositional
//!    Lucas–Kanade: the template's Sobel gradients and 2×2 structure tensor are computed once,
//!    each iteration only samples `I1` at the current estimate, the whole patch at one
//!    sub-pixel offset (`u ← u − s·H⁻¹ Σ ∇T·(I1(x+u) − T)`, damped by `s` = 1/8 as OpenCV's
//!    steps are, by the Sobel scale), until the patch distance stops falling. Patches are
//!    mean-normalised (robust to brightness changes); an estimate that moved more than a patch
//!    side from its start is discarded. **Spatial propagation** (OpenCV's addition to the paper): a forward pass in
//!    raster order starts each patch from the best of its own, its left and its upper
//!    neighbour's estimates, a backward pass from its right and lower neighbours', each pass
//!    with half the iterations, within fixed stripes of patch rows.
//! 3. **Densification.** A pixel's flow is the average of the flows of the patches covering it,
//!    weighted by `1 / max(1, |I1(x + u_i) − I0(x)|)`; the last patch of a row or column also
//!    covers the few pixels past it (OpenCV's grid and rule).
//! 4. **Variational refinement** (optional, [`variational`]): a few fixed-point iterations of a
//!    robust colour-constancy + gradient-constancy + smoothness energy with normalised data
//!    terms (Brox et al., Zimmer et al.; DIS's weights), solved by red–black SOR.
//!
//! The result is computed down to `finest_scale` (1 = half resolution) and upsampled bilinearly.

mod colour;
mod files;
mod image;
mod search;
pub mod variational;

pub use colour::colour_code;
pub use files::{
    FLO_MAGIC, FlowAccuracy, KnownFlow, UNKNOWN_FLOW, accuracy, flo_bytes, read_disparity,
    read_flo, write_flo,
};

pub use image::{Gray, pyramid};
use rayon::prelude::*;
use search::{Padded, search_patches};

/// A dense flow field: `u(x) = (dx, dy)` in pixels with `I0(x) ≈ I1(x + u(x))`.
#[derive(Debug, Clone, PartialEq)]
pub struct Flow {
    width: usize,
    height: usize,
    data: Vec<[f32; 2]>,
}

impl Flow {
    /// A flow field from its vectors, row-major.
    pub fn new(width: usize, height: usize, data: Vec<[f32; 2]>) -> Self {
        assert_eq!(
            data.len(),
            width * height,
            "Flow::new: {width}×{height} needs {} vectors",
            width * height
        );
        Self { width, height, data }
    }

    /// Zero flow.
    pub fn zeros(width: usize, height: usize) -> Self {
        Self::new(width, height, vec![[0.0; 2]; width * height])
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Vectors, row-major.
    pub fn data(&self) -> &[[f32; 2]] {
        &self.data
    }

    /// The vector at (x, y).
    pub fn at(&self, x: usize, y: usize) -> [f32; 2] {
        self.data[y * self.width + x]
    }

    /// Bilinear sample at (x, y), borders replicated.
    pub fn sample(&self, x: f32, y: f32) -> [f32; 2] {
        let ((x0, x1, fx), (y0, y1, fy)) = (tap(x, self.width), tap(y, self.height));
        let mut out = [0.0; 2];
        for (c, o) in out.iter_mut().enumerate() {
            let top = self.at(x0, y0)[c] * (1.0 - fx) + self.at(x1, y0)[c] * fx;
            let bottom = self.at(x0, y1)[c] * (1.0 - fx) + self.at(x1, y1)[c] * fx;
            *o = top * (1.0 - fy) + bottom * fy;
        }
        out
    }

    /// This field resampled to `width × height` (pixel centres aligned), vectors scaled with it:
    /// [`Flow::sample`] at every output pixel's centre, with the source columns and weights of
    /// each output column computed once for all rows.
    pub fn resized(&self, width: usize, height: usize) -> Flow {
        let (sx, sy) = (self.width as f32 / width as f32, self.height as f32 / height as f32);
        // The source taps of a target pixel centre, as `sample` takes them.
        let taps = |t: usize, scale: f32, n: usize| tap((t as f32 + 0.5) * scale - 0.5, n);
        let columns: Vec<(usize, usize, f32)> =
            (0..width).map(|x| taps(x, sx, self.width)).collect();
        let mut data = vec![[0.0f32; 2]; width * height];
        data.par_chunks_mut(width.max(1)).enumerate().for_each(|(y, row)| {
            let (y0, y1, fy) = taps(y, sy, self.height);
            let (top, bottom) = (
                &self.data[y0 * self.width..][..self.width],
                &self.data[y1 * self.width..][..self.width],
            );
            for (out, &(x0, x1, fx)) in row.iter_mut().zip(&columns) {
                for c in 0..2 {
                    let t = top[x0][c] * (1.0 - fx) + top[x1][c] * fx;
                    let b = bottom[x0][c] * (1.0 - fx) + bottom[x1][c] * fx;
                    out[c] = t * (1.0 - fy) + b * fy;
                }
                *out = [out[0] / sx, out[1] / sy];
            }
        });
        Flow::new(width, height, data)
    }

    /// Mean length of the vectors, pixels.
    pub fn mean_magnitude(&self) -> f64 {
        self.data.iter().map(|v| f64::from(v[0].hypot(v[1]))).sum::<f64>()
            / self.data.len().max(1) as f64
    }

    /// Average end-point error against `truth` (same size), pixels.
    pub fn endpoint_error(&self, truth: &Flow) -> f64 {
        assert_eq!((self.width, self.height), (truth.width, truth.height));
        self.data
            .iter()
            .zip(&truth.data)
            .map(|(a, b)| f64::from((a[0] - b[0]).hypot(a[1] - b[1])))
            .sum::<f64>()
            / self.data.len().max(1) as f64
    }
}

/// The two samples a coordinate `v` falls between along an axis of `n` samples (borders
/// replicated) and the weight of the second: `(floor, floor + 1, fraction)`, clamped.
fn tap(v: f32, n: usize) -> (usize, usize, f32) {
    let v = v.clamp(0.0, (n - 1) as f32);
    // Non-negative after the clamp: truncation is the floor.
    let a = v as usize;
    (a, (a + 1).min(n - 1), v - a as f32)
}

joca_core::named_enum! {
    /// OpenCV's presets of `DISOpticalFlow`.
    pub enum DisPreset("flow preset") {
        /// Quarter resolution, 8-pixel patches every 4, 12 search iterations, no refinement.
        UltraFast = "ultrafast",
        /// Quarter resolution, 8-pixel patches every 4, 16 search iterations, 5 refinement
        /// iterations.
        Fast = "fast",
        /// Half resolution, 8-pixel patches every 3, 25 search iterations, 5 refinement
        /// iterations.
        Medium = "medium",
    }
}

/// Parameters of [`dis`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DisParams {
    /// Finest pyramid level computed (0 = full resolution); finer levels are upsampled.
    pub finest_scale: usize,
    /// Patch side, pixels.
    pub patch_size: usize,
    /// Distance between patches, pixels.
    pub patch_stride: usize,
    /// Inverse-search iterations per patch.
    pub search_iterations: usize,
    /// Variational refinement iterations per scale (0: none).
    pub refinement_iterations: usize,
}

impl DisParams {
    /// The parameters of a preset (OpenCV's values).
    pub fn preset(preset: DisPreset) -> Self {
        match preset {
            DisPreset::UltraFast => Self {
                finest_scale: 2,
                patch_size: 8,
                patch_stride: 4,
                search_iterations: 12,
                refinement_iterations: 0,
            },
            DisPreset::Fast => Self {
                finest_scale: 2,
                patch_size: 8,
                patch_stride: 4,
                search_iterations: 16,
                refinement_iterations: 5,
            },
            DisPreset::Medium => Self {
                finest_scale: 1,
                patch_size: 8,
                patch_stride: 3,
                search_iterations: 25,
                refinement_iterations: 5,
            },
        }
    }

    /// Coarsest level for an image of `width × height`: where the image is about four patches
    /// across (OpenCV's rule), but never finer than `finest_scale`.
    pub fn coarsest_scale(&self, width: usize, height: usize) -> usize {
        let ratio = width.max(height) as f64 / (4.0 * self.patch_size as f64);
        let s = if ratio > 1.0 { (ratio.log2() + 0.5) as usize } else { 0 };
        s.max(self.finest_scale)
    }
}

/// Patch origins along an axis of `n` pixels: every `stride` from 0 while a patch fits (OpenCV's
/// grid: `1 + (n − size) / stride` patches). The up to `stride − 1` pixels past the last patch
/// are covered by that patch in the densification.
fn patch_origins(n: usize, size: usize, stride: usize) -> Vec<usize> {
    if n <= size {
        return vec![0];
    }
    (0..=n - size).step_by(stride.max(1)).collect()
}

/// One scale: patch search from `init`, densification, optional refinement.
fn scale_flow(i0: &Gray, i1: &Gray, init: &Flow, p: &DisParams) -> Flow {
    let (w, h) = (i0.width(), i0.height());
    let (gx, gy) = i0.sobel();
    let size = p.patch_size;
    let xs = patch_origins(w, size, p.patch_stride);
    let ys = patch_origins(h, size, p.patch_stride);
    let padded = Padded::new(i1, 2 * size);
    let patch_flows = search_patches(i0, &padded, (&gx, &gy), &xs, &ys, init, p);
    let data = densify(i0, &padded, &xs, &ys, &patch_flows, init, size);
    let mut flow = Flow::new(w, h, data);
    if p.refinement_iterations > 0 {
        variational::refine(
            i0,
            i1,
            &mut flow,
            &variational::RefineParams::default(),
            p.refinement_iterations,
        );
    }
    flow
}

/// Rows of the image per band of the densification.
const BAND: usize = 32;

/// Densification: each pixel's flow is the photometric-error-weighted average of the patches
/// covering it, the last patch of a row or column reaching to the image's edge, so every pixel
/// has one (`init` is only a fallback). Bands of rows in parallel, each visiting the patches
/// that reach into it in the global patch order, so every pixel sums its patches in the same
/// order whatever the thread count. The sums are kept in planes (one per component) so that a
/// patch row is one vector loop; with AVX2 where the CPU has it, the same code compiled for
/// wider vectors (same operations per pixel and order: same bits).
#[allow(unsafe_code)] // calling a target-feature function once the CPU is known to have it
fn densify(
    i0: &Gray,
    i1: &Padded,
    xs: &[usize],
    ys: &[usize],
    patch_flows: &[[f32; 2]],
    init: &Flow,
    size: usize,
) -> Vec<[f32; 2]> {
    let (w, h) = (i0.width(), i0.height());
    let mut sums = [vec![0.0f32; w * h], vec![0.0f32; w * h], vec![0.0f32; w * h]];
    let [su, sv, sw] = &mut sums;
    let chunk = BAND * w;
    su.par_chunks_mut(chunk)
        .zip(sv.par_chunks_mut(chunk))
        .zip(sw.par_chunks_mut(chunk))
        .enumerate()
        .for_each(|(band, ((su, sv), sw))| {
            let band = Band { i0, i1, xs, ys, patch_flows, size, top: band * BAND };
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU has AVX2 (checked just above).
                return unsafe { band.accumulate_avx2([su, sv, sw]) };
            }
            band.accumulate([su, sv, sw]);
        });
    let [su, sv, sw] = &sums;
    (0..w * h)
        .map(|k| if sw[k] > 0.0 { [su[k] / sw[k], sv[k] / sw[k]] } else { init.data()[k] })
        .collect()
}

/// What one band of the densification reads.
struct Band<'a> {
    i0: &'a Gray,
    i1: &'a Padded,
    xs: &'a [usize],
    ys: &'a [usize],
    patch_flows: &'a [[f32; 2]],
    size: usize,
    /// First image row of the band.
    top: usize,
}

impl Band<'_> {
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn accumulate_avx2(&self, sums: [&mut [f32]; 3]) {
        self.accumulate(sums);
    }

    /// Adds the band's patches into `sums` = (Σ weight·u, Σ weight·v, Σ weight), band rows only.
    /// The last patch of each row and column also covers the pixels past it to the image's
    /// edge (fewer than a stride), as OpenCV's densification does.
    #[inline(always)]
    fn accumulate(&self, [su, sv, sw]: [&mut [f32]; 3]) {
        let (w, size) = (self.i0.width(), self.size);
        let h = self.i0.height();
        let bottom = self.top + su.len() / w;
        let (last_x, last_y) = (self.xs.len() - 1, self.ys.len() - 1);
        // Room for the largest patch, the last one of the grid; each patch uses its own prefix.
        let mut buffer = vec![0.0f32; (w - self.xs[last_x]) * (h - self.ys[last_y])];
        for (row, &py) in self.ys.iter().enumerate() {
            let ph = if row == last_y { h - py } else { size };
            if py >= bottom || py + ph <= self.top {
                continue;
            }
            let flows = &self.patch_flows[row * self.xs.len()..][..self.xs.len()];
            for (col, (&px, &u)) in self.xs.iter().zip(flows).enumerate() {
                let pw = if col == last_x { w - px } else { size };
                let warped = &mut buffer[..pw * ph];
                self.i1.rect(px as f32 + u[0], py as f32 + u[1], (pw, ph), warped);
                for y in py.max(self.top)..(py + ph).min(bottom) {
                    let patch_row = &warped[(y - py) * pw..][..pw];
                    let image_row = &self.i0.data()[y * w + px..][..pw];
                    let at = (y - self.top) * w + px;
                    let (a, b, c) =
                        (&mut su[at..at + pw], &mut sv[at..at + pw], &mut sw[at..at + pw]);
                    for ((((&p, &g), a), b), c) in
                        patch_row.iter().zip(image_row).zip(a).zip(b).zip(c)
                    {
                        let weight = 1.0 / (p - g).abs().max(1.0);
                        *a += weight * u[0];
                        *b += weight * u[1];
                        *c += weight;
                    }
                }
            }
        }
    }
}

/// The flow from `i0` to `i1` (same size): `I0(x) ≈ I1(x + u(x))`.
pub fn dis(i0: &Gray, i1: &Gray, params: &DisParams) -> Flow {
    assert_eq!((i0.width(), i0.height()), (i1.width(), i1.height()), "dis: images differ in size");
    let coarsest = params.coarsest_scale(i0.width(), i0.height());
    let p0 = pyramid(i0, coarsest + 1);
    let p1 = pyramid(i1, coarsest + 1);
    let mut flow = Flow::zeros(p0[coarsest].width(), p0[coarsest].height());
    for s in (params.finest_scale..=coarsest).rev() {
        let (w, h) = (p0[s].width(), p0[s].height());
        let init = if flow.width() == w && flow.height() == h { flow } else { flow.resized(w, h) };
        flow = scale_flow(&p0[s], &p1[s], &init, params);
    }
    if params.finest_scale > 0 { flow.resized(i0.width(), i0.height()) } else { flow }
}

#[cfg(test)]
mod tests;
