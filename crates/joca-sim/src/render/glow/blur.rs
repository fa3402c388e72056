//! The glow's Gaussians on an RGB plane: extended-box passes (Gwosdek et al., 2011: cost
//! independent of σ, variance exact) on a pyramid of block-mean grids, each Gaussian blurred on
//! the coarsest grid that keeps it at least 4 grid pixels wide, the grids summed back to full
//! resolution by bilinear doubling. Outside the frame counts as 0: light leaving it is lost.

use rayon::prelude::*;

/// One RGB value.
pub(crate) type Rgb = [f32; 3];

/// Below this σ, pixels, a Gaussian adds its share to the pixel itself.
const POINT_SIGMA_PX: f64 = 0.5;

/// Σ_k G(σ_k) ∗ source(k, ·) over a `width × height` frame, σ in pixels (`source(k, p)`: the
/// k-th Gaussian's input at pixel p, row-major).
pub(super) fn sum_of_gaussians(
    source: &(impl Fn(usize, usize) -> Rgb + Sync),
    sigmas_px: &[f64],
    (width, height): (usize, usize),
) -> Vec<Rgb> {
    let n = width * height;
    let levels: Vec<usize> = sigmas_px.iter().map(|&s| level_for(s, width.min(height))).collect();
    let top = levels.iter().copied().max().unwrap_or(0);
    let size = |j: usize| (width.div_ceil(1 << j), height.div_ceil(1 << j));
    let mut sum: Vec<Rgb> = vec![[0.0; 3]; size(top).0 * size(top).1];
    for j in (0..=top).rev() {
        if j < top {
            sum = upsample2(&sum, size(j + 1), size(j));
        }
        for (k, &sigma) in sigmas_px.iter().enumerate().filter(|&(k, _)| levels[k] == j) {
            if sigma < POINT_SIGMA_PX {
                sum.par_iter_mut().enumerate().for_each(|(p, v)| add(v, source(k, p)));
                continue;
            }
            let mut plane = if j == 0 {
                (0..n).into_par_iter().map(|p| source(k, p)).collect()
            } else {
                block_mean(&|p| source(k, p), (width, height), 1 << j)
            };
            blur_rgb(&mut plane, size(j), sigma_on_level(sigma, j));
            sum.par_iter_mut().zip(&plane).for_each(|(v, p)| add(v, *p));
        }
    }
    sum
}

/// The σ, in grid pixels of level `j` (step 2^j), that blurs a Gaussian of `sigma_px` fine
/// pixels there: less what the block mean ((s² − 1)/12) and the doublings back (4^i/6 each)
/// add, at least half a grid pixel.
pub(crate) fn sigma_on_level(sigma_px: f64, j: usize) -> f64 {
    let s = f64::from(1u32 << j);
    let added = (s * s - 1.0) / 12.0 + (1..=j).map(|i| 4f64.powi(i as i32) / 6.0).sum::<f64>();
    ((sigma_px * sigma_px - added).max(0.25 * s * s) / (s * s)).sqrt()
}

pub(crate) fn add(v: &mut Rgb, x: Rgb) {
    v.iter_mut().zip(x).for_each(|(a, b)| *a += b);
}

/// The pyramid level (grid step 2^j) for a Gaussian of `sigma_px`: the coarsest that keeps σ at
/// least 4 grid pixels wide (so losing where in a block the light fell moves it by at most σ/8)
/// and at least 8 pixels on the grid's short side.
pub(crate) fn level_for(sigma_px: f64, short_px: usize) -> usize {
    let mut j = 0;
    while 4.0 * f64::from(2u32 << j) <= sigma_px && short_px >> (j + 1) >= 8 {
        j += 1;
    }
    j
}

/// `source` averaged over `s × s` blocks (outside the frame counts as 0).
pub(crate) fn block_mean(
    source: &(impl Fn(usize) -> Rgb + Sync),
    (width, height): (usize, usize),
    s: usize,
) -> Vec<Rgb> {
    let (cw, ch) = (width.div_ceil(s), height.div_ceil(s));
    let mut coarse = vec![[0.0f32; 3]; cw * ch];
    let norm = 1.0 / (s * s) as f32;
    coarse.par_chunks_mut(cw).enumerate().for_each(|(cy, row)| {
        for y in cy * s..((cy + 1) * s).min(height) {
            for x in 0..width {
                add(&mut row[x / s], source(y * width + x).map(|v| v * norm));
            }
        }
    });
    coarse
}

/// A grid of `coarse` size, bilinearly doubled to `fine` size (each fine pixel centred at half
/// a coarse pixel's steps; edges clamped).
pub(crate) fn upsample2(
    grid: &[Rgb],
    (cw, ch): (usize, usize),
    (fw, fh): (usize, usize),
) -> Vec<Rgb> {
    let at = |i: usize, lim: usize| -> (usize, usize, f32) {
        let u = ((i as f32 + 0.5) / 2.0 - 0.5).clamp(0.0, (lim - 1) as f32);
        let i0 = (u as usize).min(lim.saturating_sub(2));
        (i0, (i0 + 1).min(lim - 1), u - i0 as f32)
    };
    let mut fine = vec![[0.0f32; 3]; fw * fh];
    fine.par_chunks_mut(fw).enumerate().for_each(|(y, row)| {
        let (y0, y1, fy) = at(y, ch);
        for (x, v) in row.iter_mut().enumerate() {
            let (x0, x1, fx) = at(x, cw);
            let w = [(1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy];
            let q =
                [grid[y0 * cw + x0], grid[y0 * cw + x1], grid[y1 * cw + x0], grid[y1 * cw + x1]];
            *v = std::array::from_fn(|c| (0..4).map(|i| w[i] * q[i][c]).sum());
        }
    });
    fine
}

/// One pass of an extended box: radius `r` plus weight `alpha` on the two next taps, of
/// variance `var` pixels². Three passes of σ²/3 each: a Gaussian of σ to within the shape.
pub(super) fn extended_box(var: f64) -> (usize, f64) {
    // The widest plain box of no more variance (r(r+1)/3), then the end weight that tops it up.
    let r = (((1.0 + 12.0 * var).sqrt() - 1.0) / 2.0).floor().max(0.0);
    let r2 = 2.0 * r + 1.0;
    let alpha = (var * r2 - r * (r + 1.0) * r2 / 3.0) / (2.0 * (r + 1.0).powi(2) - 2.0 * var);
    (r as usize, alpha.clamp(0.0, 1.0))
}

/// Blurs a `w × h` RGB plane in place by a Gaussian of `sigma` pixels (three extended-box
/// passes a direction).
pub(crate) fn blur_rgb(plane: &mut [Rgb], (w, h): (usize, usize), sigma: f64) {
    let (r, alpha) = extended_box(sigma * sigma / 3.0);
    plane.par_chunks_mut(w).for_each_init(Vec::new, |pad, row| {
        for _ in 0..3 {
            slide(row, r, alpha, pad);
        }
    });
    // Columns in strips of 16, gathered into contiguous lines and scattered back.
    const STRIP: usize = 16;
    let strips: Vec<(usize, Vec<Rgb>)> = (0..w)
        .step_by(STRIP)
        .collect::<Vec<_>>()
        .into_par_iter()
        .map(|x0| {
            let cols = STRIP.min(w - x0);
            let mut lines = vec![[0.0f32; 3]; cols * h];
            for y in 0..h {
                for c in 0..cols {
                    lines[c * h + y] = plane[y * w + x0 + c];
                }
            }
            let mut pad = Vec::new();
            for line in lines.chunks_mut(h) {
                for _ in 0..3 {
                    slide(line, r, alpha, &mut pad);
                }
            }
            (x0, lines)
        })
        .collect();
    for (x0, lines) in strips {
        for (c, line) in lines.chunks(h).enumerate() {
            for (y, v) in line.iter().enumerate() {
                plane[y * w + x0 + c] = *v;
            }
        }
    }
}

/// One extended-box pass (radius `r`, end weight `alpha`) along `line` in place, zero outside:
/// a running sum in f64 over a zero-padded copy (`pad`, reused).
fn slide(line: &mut [Rgb], r: usize, alpha: f64, pad: &mut Vec<[f64; 3]>) {
    let n = line.len();
    pad.clear();
    pad.resize(n + 2 * r + 2, [0.0; 3]);
    for (p, v) in pad[r + 1..].iter_mut().zip(line.iter()) {
        *p = v.map(f64::from);
    }
    let norm = 1.0 / (2.0 * r as f64 + 1.0 + 2.0 * alpha);
    let mut sum = [0.0f64; 3];
    for p in &pad[1..2 * r + 2] {
        (0..3).for_each(|c| sum[c] += p[c]);
    }
    for (i, out) in line.iter_mut().enumerate() {
        // Padded index of i is i + r + 1: the window is [i + 1, i + 2r + 1], its ends i and
        // i + 2r + 2.
        let (lo, hi, first) = (pad[i], pad[i + 2 * r + 2], pad[i + 1]);
        *out = std::array::from_fn(|c| ((sum[c] + alpha * (lo[c] + hi[c])) * norm) as f32);
        (0..3).for_each(|c| sum[c] += hi[c] - first[c]);
    }
}

/// Blurs a `w × h` plane of one channel in place by a Gaussian of `sigma` pixels (the RGB blur
/// on one channel; for the tests).
#[cfg(test)]
pub(super) fn gaussian_blur(plane: &mut [f32], w: usize, h: usize, sigma: f64) {
    let mut rgb: Vec<Rgb> = plane.iter().map(|&v| [v, 0.0, 0.0]).collect();
    blur_rgb(&mut rgb, (w, h), sigma);
    plane.iter_mut().zip(&rgb).for_each(|(v, x)| *v = x[0]);
}

#[cfg(test)]
pub(super) fn gaussians_of_one_source(
    source: &(impl Fn(usize) -> f32 + Sync),
    sigma_px: f64,
    (w, h): (usize, usize),
) -> Vec<f32> {
    let s = |_: usize, p: usize| [source(p), 0.0, 0.0];
    sum_of_gaussians(&s, &[sigma_px], (w, h)).iter().map(|v| v[0]).collect()
}
