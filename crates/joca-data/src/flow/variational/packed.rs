//! The red–black packing of the refinement's planes: each colour of the checkerboard in its own
//! padded plane (the flow and the data terms), so that a half-sweep reads one plane and writes the
//! other in contiguous runs.

use super::{Derivatives, Terms};
use rayon::prelude::*;

/// One colour `c` of the red–black ordering of a `w × h` image, packed: row `y` holds the pixels
/// `x ≡ y + c (mod 2)` in order, from column 1, behind a zero border one column wide on each side
/// and one row high above and below. Pixel `i` of row `y` (image `x = 2i + s`, `s = (y + c) mod
/// 2`) then has its left, right, upper and lower neighbours (the other colour) at columns
/// `i + s`, `i + s + 1` of row `y` and column `i + 1` of rows `y − 1`, `y + 1` of the other
/// colour's plane: contiguous in `i`, so a half-sweep is a loop the compiler vectorises, and it
/// writes one plane while reading the other, so rows update in parallel without a copy.
#[derive(Debug, Clone)]
pub(super) struct Packed {
    /// The image's width and height.
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) stride: usize,
    pub(super) data: Vec<f32>,
}

impl Packed {
    pub(super) fn stride(w: usize) -> usize {
        w.div_ceil(2) + 2
    }

    /// First image column of colour `c` in row `y`, and the row's pixel count.
    pub(super) fn span(w: usize, y: usize, c: usize) -> (usize, usize) {
        let s = (y + c) % 2;
        (s, (w - s).div_ceil(2))
    }

    /// A plane of zeros for a `w × h` image.
    pub(super) fn zeros(w: usize, h: usize) -> Self {
        let stride = Self::stride(w);
        Self { width: w, height: h, stride, data: vec![0.0; stride * (h + 2)] }
    }

    /// The plane of colour `c` with pixel `k = y·w + x` set to `f(k)`, zero elsewhere.
    pub(super) fn from_fn(w: usize, h: usize, c: usize, f: impl Fn(usize) -> f32) -> Self {
        let mut plane = Self::zeros(w, h);
        let stride = plane.stride;
        for y in 0..h {
            let (s, count) = Self::span(w, y, c);
            let row = &mut plane.data[(y + 1) * stride + 1..][..count];
            for (i, d) in row.iter_mut().enumerate() {
                *d = f(y * w + 2 * i + s);
            }
        }
        plane
    }

    /// `count` values of buffer row `row` (image row `row − 1`) from buffer column `col`.
    #[inline(always)]
    pub(super) fn slice(&self, row: usize, col: usize, count: usize) -> &[f32] {
        &self.data[row * self.stride + col..][..count]
    }
}

/// Writes the refined flow held in the packed planes `state[c] = (u, v)` of both colours into
/// an image-order field, rows in parallel.
pub(super) fn unpack(state: &[(Packed, Packed); 2], field: &mut [[f32; 2]]) {
    let (w, h, stride) = (state[0].0.width, state[0].0.height, state[0].0.stride);
    debug_assert_eq!(field.len(), w * h);
    field.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (c, (u, v)) in state.iter().enumerate() {
            let (s, count) = Packed::span(w, y, c);
            let (u, v) = (
                &u.data[(y + 1) * stride + 1..][..count],
                &v.data[(y + 1) * stride + 1..][..count],
            );
            for (i, (&u, &v)) in u.iter().zip(v).enumerate() {
                row[2 * i + s] = [u, v];
            }
        }
    });
}

/// The image rows of a plane (its border rows left out), to be filled in parallel.
pub(super) fn interior_rows(p: &mut Packed) -> rayon::slice::ChunksMut<'_, f32> {
    let (stride, h) = (p.stride, p.height);
    p.data[stride..][..h * stride].par_chunks_mut(stride)
}

/// The data terms of the pixels of one colour, packed as [`Packed`], one plane per field of
/// [`Terms`] (fixed for the refinement).
pub(super) struct PackedTerms([Packed; 11]);

impl PackedTerms {
    /// The terms of the pixels of colour `c`, rows in parallel.
    pub(super) fn new(d: &Derivatives, c: usize, z2: f32) -> Self {
        let (w, h) = (d.ix.width(), d.ix.height());
        let mut planes = [(); 11].map(|()| Packed::zeros(w, h));
        let [p0, p1, p2, p3, p4, p5, p6, p7, p8, p9, p10] = &mut planes;
        let r = interior_rows;
        (r(p0), r(p1), r(p2), r(p3), r(p4), r(p5), r(p6), r(p7), r(p8), r(p9), r(p10))
            .into_par_iter()
            .enumerate()
            .for_each(|(y, (ix, iy, iz, ixx, ixy, iyy, ixz, iyz, n, n1, n2))| {
                let (s, count) = Packed::span(w, y, c);
                for i in 0..count {
                    let t = d.terms(y * w + 2 * i + s, z2);
                    let at = 1 + i;
                    (ix[at], iy[at], iz[at], ixx[at], ixy[at], iyy[at]) =
                        (t.ix, t.iy, t.iz, t.ixx, t.ixy, t.iyy);
                    (ixz[at], iyz[at], n[at], n1[at], n2[at]) =
                        (t.ixz, t.iyz, t.inv_n, t.inv_n1, t.inv_n2);
                }
            });
        Self(planes)
    }

    /// The `count` pixels of image row `y`, one slice per field.
    pub(super) fn row(&self, y: usize, count: usize) -> [&[f32]; 11] {
        self.0.each_ref().map(|p| p.slice(y + 1, 1, count))
    }
}

/// Pixel `i` of a row of [`PackedTerms::row`].
#[inline(always)]
pub(super) fn terms_at(t: &[&[f32]; 11], i: usize) -> Terms {
    Terms {
        ix: t[0][i],
        iy: t[1][i],
        iz: t[2][i],
        ixx: t[3][i],
        ixy: t[4][i],
        iyy: t[5][i],
        ixz: t[6][i],
        iyz: t[7][i],
        inv_n: t[8][i],
        inv_n1: t[9][i],
        inv_n2: t[10][i],
    }
}
