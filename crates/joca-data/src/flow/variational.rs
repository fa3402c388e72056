//! Variational refinement of a flow field, the last stage of DIS at each scale (Brox et al.,
//! "High accuracy optical flow estimation based on a theory for warping", ECCV 2004, with the
//! data normalisation of Zimmer et al. and DIS's weights, as OpenCV's `VariationalRefinement`).
//!
//! `I1` is warped by the incoming flow `u` once; an increment `(du, dv)` then minimises
//! `E = Σ δ Ψ(E_I) + γ Ψ(E_G) + α Ψ(E_S)` with the robust penaliser `Ψ(s²) = √(s² + ε²)`:
//! - colour constancy `E_I = (I_z + I_x du + I_y dv)² / (I_x² + I_y² + ζ²)`,
//!   `I_z = I1(x + u) − I0(x)` (normalised by the local gradient, so that the term weighs
//!   textured and flat regions alike);
//! - gradient constancy `E_G = (I_xz + I_xx du + I_xy dv)² / (I_xx² + I_xy² + ζ²)
//!   + (I_yz + I_xy du + I_yy dv)² / (I_yy² + I_xy² + ζ²)`, `I_xz = ∂_x I_z`, `I_yz = ∂_y I_z`;
//! - smoothness `E_S = |∇(u + du)|² + |∇(v + dv)|²` (forward differences; the pair of a pixel
//!   and its right or lower neighbour is weighted by the pixel's own penaliser weight).
//!
//! Spatial derivatives are taken on the average of `I0` and the warped `I1`, in 8-bit intensity
//! units. Each fixed-point iteration evaluates the penaliser's derivative `Ψ'(s²) = 1 / (2√(s² +
//! ε²))` of every term at the current increment (lazy iteratively reweighted least squares) and
//! runs red–black SOR sweeps on the resulting linear system, each pixel's `du` and `dv` solved in
//! turn; a small `ζ²` on the diagonal keeps the system regular where the image is flat.

use super::{Flow, Gray};
use rayon::prelude::*;

/// Weights of the refinement energy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefineParams {
    /// Colour-constancy weight δ.
    pub delta: f32,
    /// Gradient-constancy weight γ.
    pub gamma: f32,
    /// Smoothness weight α.
    pub alpha: f32,
    /// The penaliser's ε.
    pub epsilon: f32,
    /// The data terms' normalisation ζ (intensity units per pixel).
    pub zeta: f32,
    /// SOR sweeps per fixed-point iteration.
    pub sweeps: usize,
    /// SOR relaxation factor ω.
    pub omega: f32,
}

impl Default for RefineParams {
    /// DIS's weights (the defaults of OpenCV's `DISOpticalFlow`): δ 5, γ 10, α 20, ε 0.001,
    /// ζ 0.1, 5 sweeps, ω 1.6.
    fn default() -> Self {
        Self {
            delta: 5.0,
            gamma: 10.0,
            alpha: 20.0,
            epsilon: 0.001,
            zeta: 0.1,
            sweeps: 5,
            omega: 1.6,
        }
    }
}

/// One pixel's linear system from the data terms: `A = [a11 a12; a12 a22]`, `b`.
#[derive(Debug, Clone, Copy, Default)]
struct System {
    a11: f32,
    a12: f32,
    a22: f32,
    b1: f32,
    b2: f32,
}

/// The linearised data terms at one pixel.
#[derive(Debug, Clone, Copy, Default)]
struct Terms {
    ix: f32,
    iy: f32,
    iz: f32,
    ixx: f32,
    ixy: f32,
    iyy: f32,
    ixz: f32,
    iyz: f32,
}

impl Terms {
    /// The data terms' system at increment `(du, dv)`.
    fn system(&self, [du, dv]: [f32; 2], p: &RefineParams) -> System {
        let (e2, z2) = (p.epsilon * p.epsilon, p.zeta * p.zeta);
        let t = self;
        // Colour constancy, normalised by the gradient.
        let n = t.ix * t.ix + t.iy * t.iy + z2;
        let r = t.iz + t.ix * du + t.iy * dv;
        let wc = 0.5 * p.delta / (r * r / n + e2).sqrt() / n;
        // Gradient constancy, each component normalised by its own gradient.
        let (n1, n2) = (t.ixx * t.ixx + t.ixy * t.ixy + z2, t.iyy * t.iyy + t.ixy * t.ixy + z2);
        let rx = t.ixz + t.ixx * du + t.ixy * dv;
        let ry = t.iyz + t.ixy * du + t.iyy * dv;
        let wg = 0.5 * p.gamma / (rx * rx / n1 + ry * ry / n2 + e2).sqrt();
        System {
            a11: wc * t.ix * t.ix + wg * (t.ixx * t.ixx / n1 + t.ixy * t.ixy / n2) + z2,
            a12: wc * t.ix * t.iy + wg * (t.ixx * t.ixy / n1 + t.ixy * t.iyy / n2),
            a22: wc * t.iy * t.iy + wg * (t.ixy * t.ixy / n1 + t.iyy * t.iyy / n2) + z2,
            b1: -wc * t.iz * t.ix - wg * (t.ixx * t.ixz / n1 + t.ixy * t.iyz / n2),
            b2: -wc * t.iz * t.iy - wg * (t.ixy * t.ixz / n1 + t.iyy * t.iyz / n2),
        }
    }
}

/// Adds neighbour `m`'s smoothness pull on pixel `k` with weight `wkm`: `w (u_m + du_m − u_k)`
/// to the pull, `w` to the weight (`at` = incoming flow, increments, `k`). A function rather
/// than a closure so that it is always inlined into the sweep.
#[inline(always)]
fn pull_towards(
    (pull, weight): &mut ([f32; 2], f32),
    (base, du, k): (&[[f32; 2]], &[[f32; 2]], usize),
    m: usize,
    wkm: f32,
) {
    pull[0] += wkm * (base[m][0] + du[m][0] - base[k][0]);
    pull[1] += wkm * (base[m][1] + du[m][1] - base[k][1]);
    *weight += wkm;
}

/// Refines `flow` (from `i0` to `i1`, same size as both) in place with `iterations`
/// fixed-point iterations.
pub fn refine(i0: &Gray, i1: &Gray, flow: &mut Flow, p: &RefineParams, iterations: usize) {
    let (w, h) = (i0.width(), i0.height());
    if w < 2 || h < 2 {
        return;
    }
    let n = w * h;
    let base: Vec<[f32; 2]> = flow.data.clone();
    // I1 warped by the incoming flow, the average image, the temporal difference.
    let warped: Vec<f32> = (0..n)
        .into_par_iter()
        .map(|k| {
            let u = base[k];
            i1.sample((k % w) as f32 + u[0], (k / w) as f32 + u[1])
        })
        .collect();
    let average = Gray::new(w, h, (0..n).map(|k| 0.5 * (i0.data()[k] + warped[k])).collect());
    let iz = Gray::new(w, h, (0..n).map(|k| warped[k] - i0.data()[k]).collect());
    let (ix, iy) = average.gradients();
    let ((ixx, ixy), (_, iyy)) = (ix.gradients(), iy.gradients());
    let (ixz, iyz) = iz.gradients();
    let terms: Vec<Terms> = (0..n)
        .map(|k| Terms {
            ix: ix.data()[k],
            iy: iy.data()[k],
            iz: iz.data()[k],
            ixx: ixx.data()[k],
            ixy: ixy.data()[k],
            iyy: iyy.data()[k],
            ixz: ixz.data()[k],
            iyz: iyz.data()[k],
        })
        .collect();
    let mut du = vec![[0.0f32; 2]; n];
    let mut systems = vec![System::default(); n];
    let mut smooth = vec![0.0f32; n];
    let e2 = p.epsilon * p.epsilon;
    for _ in 0..iterations {
        (systems.par_iter_mut(), smooth.par_iter_mut()).into_par_iter().enumerate().for_each(
            |(k, (system, smooth))| {
                *system = terms[k].system(du[k], p);
                let (x, y) = (k % w, k / w);
                let f = |m: usize| [base[m][0] + du[m][0], base[m][1] + du[m][1]];
                let here = f(k);
                let right = if x + 1 < w { f(k + 1) } else { here };
                let down = if y + 1 < h { f(k + w) } else { here };
                let g2 = (right[0] - here[0]).powi(2)
                    + (right[1] - here[1]).powi(2)
                    + (down[0] - here[0]).powi(2)
                    + (down[1] - here[1]).powi(2);
                *smooth = 0.5 * p.alpha / (g2 + e2).sqrt();
            },
        );
        for _ in 0..p.sweeps {
            for colour in 0..2 {
                // A pixel of one colour reads only pixels of the other, which this half-sweep
                // does not write: rows update in parallel from a copy, with the same bits as
                // the sequential sweep.
                let other = du.clone();
                du.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
                    let start = (y + colour) % 2;
                    for x in (start..w).step_by(2) {
                        let k = y * w + x;
                        // Σ_m w_km (u_m + du_m − u_k) and Σ_m w_km over the 4-neighbours.
                        let mut sums = ([0.0f32; 2], 0.0f32);
                        let at = (&base[..], &other[..], k);
                        if x > 0 {
                            pull_towards(&mut sums, at, k - 1, smooth[k - 1]);
                        }
                        if x + 1 < w {
                            pull_towards(&mut sums, at, k + 1, smooth[k]);
                        }
                        if y > 0 {
                            pull_towards(&mut sums, at, k - w, smooth[k - w]);
                        }
                        if y + 1 < h {
                            pull_towards(&mut sums, at, k + w, smooth[k]);
                        }
                        let (pull, weight) = sums;
                        let s = systems[k];
                        let d = &mut row[x];
                        let new_u = (s.b1 + pull[0] - s.a12 * d[1]) / (s.a11 + weight);
                        d[0] += p.omega * (new_u - d[0]);
                        let new_v = (s.b2 + pull[1] - s.a12 * d[0]) / (s.a22 + weight);
                        d[1] += p.omega * (new_v - d[1]);
                    }
                });
            }
        }
    }
    for k in 0..n {
        flow.data[k] = [base[k][0] + du[k][0], base[k][1] + du[k][1]];
    }
}
