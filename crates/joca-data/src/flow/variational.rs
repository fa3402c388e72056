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

mod derivatives;
mod packed;
use derivatives::Derivatives;
use packed::{Packed, PackedTerms, interior_rows, terms_at, unpack};

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
    /// `1 / (I_x² + I_y² + ζ²)`, `1 / (I_xx² + I_xy² + ζ²)`, `1 / (I_yy² + I_xy² + ζ²)`: the
    /// normalisations, fixed for the refinement (set by [`Terms::normalised`]).
    inv_n: f32,
    inv_n1: f32,
    inv_n2: f32,
}

impl Terms {
    /// These terms with their normalisations for `ζ² = z2` set.
    fn normalised(self, z2: f32) -> Self {
        let t = self;
        Self {
            inv_n: 1.0 / (t.ix * t.ix + t.iy * t.iy + z2),
            inv_n1: 1.0 / (t.ixx * t.ixx + t.ixy * t.ixy + z2),
            inv_n2: 1.0 / (t.iyy * t.iyy + t.ixy * t.ixy + z2),
            ..t
        }
    }

    /// The data terms' system at increment `(du, dv)`.
    #[inline(always)]
    fn system(&self, [du, dv]: [f32; 2], p: &RefineParams) -> System {
        let (e2, z2) = (p.epsilon * p.epsilon, p.zeta * p.zeta);
        let t = self;
        // Colour constancy, normalised by the gradient.
        let r = t.iz + t.ix * du + t.iy * dv;
        let wc = 0.5 * p.delta / (r * r * t.inv_n + e2).sqrt() * t.inv_n;
        // Gradient constancy, each component normalised by its own gradient.
        let rx = t.ixz + t.ixx * du + t.ixy * dv;
        let ry = t.iyz + t.ixy * du + t.iyy * dv;
        let wg = 0.5 * p.gamma / (rx * rx * t.inv_n1 + ry * ry * t.inv_n2 + e2).sqrt();
        let (g1, g2) = (wg * t.inv_n1, wg * t.inv_n2);
        System {
            a11: wc * t.ix * t.ix + g1 * t.ixx * t.ixx + g2 * t.ixy * t.ixy + z2,
            a12: wc * t.ix * t.iy + g1 * t.ixx * t.ixy + g2 * t.ixy * t.iyy,
            a22: wc * t.iy * t.iy + g1 * t.ixy * t.ixy + g2 * t.iyy * t.iyy + z2,
            b1: -wc * t.iz * t.ix - g1 * t.ixx * t.ixz - g2 * t.ixy * t.iyz,
            b2: -wc * t.iz * t.iy - g1 * t.ixy * t.ixz - g2 * t.iyy * t.iyz,
        }
    }
}

/// The smoothness weights of the pixels of one colour at the current flow, packed: `right`
/// towards the right neighbour and `down` towards the lower one, each 0 where that neighbour
/// is outside the image (the pair of a pixel and its right or lower neighbour is weighted by
/// the pixel's own penaliser weight).
struct Smoothness {
    right: Packed,
    down: Packed,
}

impl Smoothness {
    fn zeros(w: usize, h: usize) -> Self {
        Self { right: Packed::zeros(w, h), down: Packed::zeros(w, h) }
    }

    /// The weights of colour `c` from the refined flow `mine` (this colour) and `other`, rows
    /// in parallel: `α/2 / √(|∇u|² + |∇v|² + ε²)` with forward differences, a neighbour
    /// outside the image counting as the pixel itself.
    fn set(
        &mut self,
        c: usize,
        (u, v): (&Packed, &Packed),
        (ou, ov): (&Packed, &Packed),
        p: &RefineParams,
    ) {
        let (w, h) = (u.width, u.height);
        let (half_alpha, e2) = (0.5 * p.alpha, p.epsilon * p.epsilon);
        let (right, down) = (&mut self.right, &mut self.down);
        (interior_rows(right), interior_rows(down)).into_par_iter().enumerate().for_each(
            |(y, (wr, wd))| {
                let (s, count) = Packed::span(w, y, c);
                let (hu, hv) = (u.slice(y + 1, 1, count), v.slice(y + 1, 1, count));
                // The right neighbour of pixel i is pixel i + s of the other colour; past the
                // row's end it is the border column, fixed below.
                let (ru, rv) = (ou.slice(y + 1, 1 + s, count), ov.slice(y + 1, 1 + s, count));
                // The lower neighbour is pixel i of the other colour in the next row; in the last
                // row the pixel itself.
                let (du, dv) = if y + 1 < h {
                    (ou.slice(y + 2, 1, count), ov.slice(y + 2, 1, count))
                } else {
                    (hu, hv)
                };
                let weight = |here: [f32; 2], right: [f32; 2], down: [f32; 2]| {
                    let g2 = (right[0] - here[0]).powi(2)
                        + (right[1] - here[1]).powi(2)
                        + (down[0] - here[0]).powi(2)
                        + (down[1] - here[1]).powi(2);
                    half_alpha / (g2 + e2).sqrt()
                };
                let (wr, wd) = (&mut wr[1..][..count], &mut wd[1..][..count]);
                let has_down = if y + 1 < h { 1.0 } else { 0.0 };
                for i in 0..count {
                    let m = weight([hu[i], hv[i]], [ru[i], rv[i]], [du[i], dv[i]]);
                    wr[i] = m;
                    wd[i] = m * has_down;
                }
                // The last pixel of the row, if it is the image's last column: no right neighbour.
                let last = count - 1;
                if 2 * last + s == w - 1 {
                    let here = [hu[last], hv[last]];
                    let m = weight(here, here, [du[last], dv[last]]);
                    (wr[last], wd[last]) = (0.0, m * has_down);
                }
            },
        );
    }
}

/// What a half-sweep needs of each pixel of one colour, packed as [`Packed`], beside the
/// smoothness weights ([`Smoothness`] of both colours): `a12`, and, folded with
/// the incoming flow `u⁰` and the total weight `W = Σ w`, `k1 = b1 + a11 u⁰ + a12 v⁰`,
/// `k2 = b2 + a12 u⁰ + a22 v⁰`, `1/(a11 + W)`, `1/(a22 + W)`: the SOR update of the refined
/// flow `u = u⁰ + du` is then `u ← u + ω ((k1 + Σ w u_m − a12 v) / (a11 + W) − u)`, the same as solving
/// for the increment (`(b1 + Σ w (u_m − u⁰) − a12 dv) / (a11 + W)`) up to rounding.
struct Coefficients {
    a12: Packed,
    k: [Packed; 2],
    inv: [Packed; 2],
}

impl Coefficients {
    /// Planes for a `w × h` image, to be set by [`Coefficients::fill`].
    fn zeros(w: usize, h: usize) -> Self {
        let blank = || Packed::zeros(w, h);
        Self { a12: blank(), k: [blank(), blank()], inv: [blank(), blank()] }
    }

    /// Sets every pixel of colour `c` from its data terms' system at the current flow
    /// `(u, v)`, the smoothness weights of both colours and the incoming flow `(bu, bv)` (the
    /// borders stay zero), rows in parallel.
    #[allow(clippy::too_many_arguments)]
    fn fill(
        &mut self,
        c: usize,
        terms: &PackedTerms,
        (u, v): (&Packed, &Packed),
        (bu, bv): (&Packed, &Packed),
        mine: &Smoothness,
        other: &Smoothness,
        params: &RefineParams,
    ) {
        let w = self.a12.width;
        let ([k1, k2], [inv1, inv2]) = (&mut self.k, &mut self.inv);
        let r = interior_rows;
        (r(&mut self.a12), r(k1), r(k2), r(inv1), r(inv2)).into_par_iter().enumerate().for_each(
            |(y, (a12, k1, k2, inv1, inv2))| {
                let (s, count) = Packed::span(w, y, c);
                let t = terms.row(y, count);
                let (hu, hv) = (u.slice(y + 1, 1, count), v.slice(y + 1, 1, count));
                let (bu, bv) = (bu.slice(y + 1, 1, count), bv.slice(y + 1, 1, count));
                let [left, right, up, down] = weights_of(y, s, count, mine, other);
                let range = 1..1 + count;
                let (a12, k1, k2) =
                    (&mut a12[range.clone()], &mut k1[range.clone()], &mut k2[range.clone()]);
                let (inv1, inv2) = (&mut inv1[range.clone()], &mut inv2[range]);
                for i in 0..count {
                    let total = left[i] + right[i] + up[i] + down[i];
                    let (u0, v0) = (bu[i], bv[i]);
                    let sy = terms_at(&t, i).system([hu[i] - u0, hv[i] - v0], params);
                    a12[i] = sy.a12;
                    k1[i] = sy.b1 + sy.a11 * u0 + sy.a12 * v0;
                    k2[i] = sy.b2 + sy.a12 * u0 + sy.a22 * v0;
                    inv1[i] = 1.0 / (sy.a11 + total);
                    inv2[i] = 1.0 / (sy.a22 + total);
                }
            },
        );
    }
}

/// The smoothness weights of the `count` pixels of colour row `y` (first column `s`) towards
/// their left, right, upper and lower neighbours: towards the left one its weight to the right
/// (0 in the border column), towards the upper one its weight downwards (0 in the border row),
/// towards the right and lower ones the pixel's own.
#[inline(always)]
fn weights_of<'a>(
    y: usize,
    s: usize,
    count: usize,
    mine: &'a Smoothness,
    other: &'a Smoothness,
) -> [&'a [f32]; 4] {
    [
        other.right.slice(y + 1, s, count),
        mine.right.slice(y + 1, 1, count),
        other.down.slice(y, 1, count),
        mine.down.slice(y + 1, 1, count),
    ]
}

/// One SOR half-sweep over the pixels of colour `c` (`mine`, updated), reading their
/// neighbours (`other`); `u` is updated first and `v` uses the new `u`, pixel by pixel.
fn half_sweep<'a>(
    c: usize,
    (u, v): (&mut Packed, &mut Packed),
    (ou, ov): (&'a Packed, &'a Packed),
    co: &'a Coefficients,
    (mine, other): (&'a Smoothness, &'a Smoothness),
    omega: f32,
) {
    let (stride, w) = (u.stride, u.width);
    let interior = stride..u.data.len() - stride;
    u.data[interior.clone()]
        .par_chunks_mut(stride)
        .zip(v.data[interior].par_chunks_mut(stride))
        .enumerate()
        .for_each(|(y, (ur, vr))| {
            let (s, count) = Packed::span(w, y, c);
            let at = |p: &'a Packed, row: usize, col: usize| p.slice(row, col, count);
            let (ul, vl) = (at(ou, y + 1, s), at(ov, y + 1, s));
            let (urt, vrt) = (at(ou, y + 1, s + 1), at(ov, y + 1, s + 1));
            let (uu, vu) = (at(ou, y, 1), at(ov, y, 1));
            let (ud, vd) = (at(ou, y + 2, 1), at(ov, y + 2, 1));
            let [wl, wr, wu, wd] = weights_of(y, s, count, mine, other);
            let (a12, k1, k2) =
                (at(&co.a12, y + 1, 1), at(&co.k[0], y + 1, 1), at(&co.k[1], y + 1, 1));
            let (inv1, inv2) = (at(&co.inv[0], y + 1, 1), at(&co.inv[1], y + 1, 1));
            let (ur, vr) = (&mut ur[1..][..count], &mut vr[1..][..count]);
            for i in 0..count {
                let su = wl[i] * ul[i] + wr[i] * urt[i] + wu[i] * uu[i] + wd[i] * ud[i];
                let sv = wl[i] * vl[i] + wr[i] * vrt[i] + wu[i] * vu[i] + wd[i] * vd[i];
                let target_u = (k1[i] + su - a12[i] * vr[i]) * inv1[i];
                ur[i] += omega * (target_u - ur[i]);
                let target_v = (k2[i] + sv - a12[i] * ur[i]) * inv2[i];
                vr[i] += omega * (target_v - vr[i]);
            }
        });
}

/// Refines `flow` (from `i0` to `i1`, same size as both) in place with `iterations`
/// fixed-point iterations.
pub fn refine(i0: &Gray, i1: &Gray, flow: &mut Flow, p: &RefineParams, iterations: usize) {
    let (w, h) = (i0.width(), i0.height());
    if w < 2 || h < 2 {
        return;
    }
    let base: Vec<[f32; 2]> = flow.data.clone();
    let derivatives = Derivatives::new(i0, i1, &base);
    // The state is the refined flow itself (incoming flow + increment), split by the red–black
    // colouring into packed planes (see [`Packed`]).
    let mut state = [0, 1].map(|c| {
        let u = Packed::from_fn(w, h, c, |k| base[k][0]);
        let v = Packed::from_fn(w, h, c, |k| base[k][1]);
        (u, v)
    });
    // The incoming flow and the data terms in the same layout, fixed for the refinement.
    let incoming = state.clone();
    let terms = [0, 1].map(|c| PackedTerms::new(&derivatives, c, p.zeta * p.zeta));
    drop(derivatives);
    let mut smooth = [(); 2].map(|()| Smoothness::zeros(w, h));
    let mut coefficients = [(); 2].map(|()| Coefficients::zeros(w, h));
    for _ in 0..iterations {
        {
            let [(u0, v0), (u1, v1)] = &state;
            let [s0, s1] = &mut smooth;
            s0.set(0, (u0, v0), (u1, v1), p);
            s1.set(1, (u1, v1), (u0, v0), p);
        }
        for (c, co) in coefficients.iter_mut().enumerate() {
            let ((u, v), (bu, bv)) = (&state[c], &incoming[c]);
            co.fill(c, &terms[c], (u, v), (bu, bv), &smooth[c], &smooth[1 - c], p);
        }
        for _ in 0..p.sweeps {
            for (c, co) in coefficients.iter().enumerate() {
                let [(u0, v0), (u1, v1)] = &mut state;
                let (mine, other) =
                    if c == 0 { ((u0, v0), (&*u1, &*v1)) } else { ((u1, v1), (&*u0, &*v0)) };
                half_sweep(c, mine, other, co, (&smooth[c], &smooth[1 - c]), p.omega);
            }
        }
    }
    unpack(&state, &mut flow.data);
}

#[cfg(test)]
mod tests;
