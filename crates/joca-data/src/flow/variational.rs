//! Variational refinement of a flow field, the last stage of DIS at each scale.
//!
//! Minimises, over an increment `du` of the flow `u`,
//! `E = Σ ψ(I_z + I_x du + I_y dv) · δ + α Σ_{4-neighbours} |(u + du)(x) − (u + du)(n)|²`,
//! where `I_z = I1(x + u) − I0(x)`, `I_x, I_y` average the gradients of `I0` and of the warped
//! `I1`, intensities are scaled to [0, 1], and `ψ(r) = r² / √(r² + ε²)` (Charbonnier, applied as a
//! weight fixed per outer iteration: lazy iteratively reweighted least squares). Each outer
//! iteration re-warps `I1` and runs red–black SOR sweeps on the linear system.

use super::{Flow, Gray};

/// Weights of the refinement energy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefineParams {
    /// Data-term weight δ.
    pub delta: f32,
    /// Smoothness weight α.
    pub alpha: f32,
    /// Charbonnier ε (intensity units of [0, 1]).
    pub epsilon: f32,
    /// SOR sweeps per outer iteration.
    pub sweeps: usize,
    /// SOR relaxation factor ω.
    pub omega: f32,
}

impl Default for RefineParams {
    fn default() -> Self {
        Self { delta: 5.0, alpha: 20.0, epsilon: 0.001, sweeps: 5, omega: 1.6 }
    }
}

/// Refines `flow` (from `i0` to `i1`, same size as both) in place with `iterations` outer
/// iterations.
pub fn refine(i0: &Gray, i1: &Gray, flow: &mut Flow, p: &RefineParams, iterations: usize) {
    let (w, h) = (i0.width(), i0.height());
    if w < 2 || h < 2 {
        return;
    }
    let scale = 1.0 / 255.0;
    let (g0x, g0y) = i0.gradients();
    let (g1x, g1y) = i1.gradients();
    let n = w * h;
    let mut ix = vec![0.0f32; n];
    let mut iy = vec![0.0f32; n];
    let mut iz = vec![0.0f32; n];
    let mut psi = vec![0.0f32; n];
    let base: Vec<[f32; 2]> = flow.data.clone();
    for _ in 0..iterations {
        // Linearise the data term around the current flow.
        for y in 0..h {
            for x in 0..w {
                let k = y * w + x;
                let u = flow.data[k];
                let (sx, sy) = (x as f32 + u[0], y as f32 + u[1]);
                ix[k] = 0.5 * (g0x.at(x, y) + g1x.sample(sx, sy)) * scale;
                iy[k] = 0.5 * (g0y.at(x, y) + g1y.sample(sx, sy)) * scale;
                iz[k] = (i1.sample(sx, sy) - i0.at(x, y)) * scale;
            }
        }
        let current: Vec<[f32; 2]> = flow.data.clone();
        let mut du = vec![[0.0f32; 2]; n];
        for _ in 0..p.sweeps {
            // Robust weight of the data term at the current increment.
            for k in 0..n {
                let r = iz[k] + ix[k] * du[k][0] + iy[k] * du[k][1];
                psi[k] = p.delta / (r * r + p.epsilon * p.epsilon).sqrt();
            }
            for colour in 0..2 {
                for y in 0..h {
                    let start = (y + colour) % 2;
                    for x in (start..w).step_by(2) {
                        let k = y * w + x;
                        let mut sum = [0.0f32; 2];
                        let mut count = 0.0f32;
                        let mut visit = |m: usize| {
                            sum[0] += current[m][0] + du[m][0];
                            sum[1] += current[m][1] + du[m][1];
                            count += 1.0;
                        };
                        if x > 0 {
                            visit(k - 1);
                        }
                        if x + 1 < w {
                            visit(k + 1);
                        }
                        if y > 0 {
                            visit(k - w);
                        }
                        if y + 1 < h {
                            visit(k + w);
                        }
                        let (a, u) = (p.alpha, current[k]);
                        let d = psi[k];
                        // ∂E/∂du = 0 and ∂E/∂dv = 0, each solved for its own unknown.
                        let rhs_u =
                            -d * ix[k] * (iz[k] + iy[k] * du[k][1]) + a * (sum[0] - count * u[0]);
                        let new_u = rhs_u / (d * ix[k] * ix[k] + a * count);
                        du[k][0] += p.omega * (new_u - du[k][0]);
                        let rhs_v =
                            -d * iy[k] * (iz[k] + ix[k] * du[k][0]) + a * (sum[1] - count * u[1]);
                        let new_v = rhs_v / (d * iy[k] * iy[k] + a * count);
                        du[k][1] += p.omega * (new_v - du[k][1]);
                    }
                }
            }
        }
        for k in 0..n {
            flow.data[k][0] = current[k][0] + du[k][0];
            flow.data[k][1] = current[k][1] + du[k][1];
        }
    }
    // A refinement that made the flow worse photometrically (rare, at occlusions) is undone.
    let error = |f: &[[f32; 2]]| -> f64 {
        (0..n)
            .map(|k| {
                let (x, y) = ((k % w) as f32, (k / w) as f32);
                f64::from((i1.sample(x + f[k][0], y + f[k][1]) - i0.at(k % w, k / w)).abs())
            })
            .sum()
    };
    if error(&flow.data) > error(&base) {
        flow.data = base;
    }
}
