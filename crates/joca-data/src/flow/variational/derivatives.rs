//! The images the refinement's data terms are made of.

use super::super::Gray;
use super::Terms;
use rayon::prelude::*;

/// The images the data terms are made of, from `I0`, `I1` and the incoming flow `base`: the
/// derivatives of the average of `I0` and the warped `I1`, and their difference and its
/// derivatives.
pub(super) struct Derivatives {
    pub(super) ix: Gray,
    pub(super) iy: Gray,
    pub(super) iz: Gray,
    pub(super) ixx: Gray,
    pub(super) ixy: Gray,
    pub(super) iyy: Gray,
    pub(super) ixz: Gray,
    pub(super) iyz: Gray,
}

impl Derivatives {
    pub(super) fn new(i0: &Gray, i1: &Gray, base: &[[f32; 2]]) -> Self {
        let (w, h) = (i0.width(), i0.height());
        let n = w * h;
        // I1 warped by the incoming flow, the average image, the temporal difference.
        let mut warped = vec![0.0f32; n];
        warped.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, v) in row.iter_mut().enumerate() {
                let u = base[y * w + x];
                *v = i1.sample(x as f32 + u[0], y as f32 + u[1]);
            }
        });
        let average = Gray::new(
            w,
            h,
            (0..n).into_par_iter().map(|k| 0.5 * (i0.data()[k] + warped[k])).collect(),
        );
        let iz =
            Gray::new(w, h, (0..n).into_par_iter().map(|k| warped[k] - i0.data()[k]).collect());
        let (ix, iy) = average.gradients();
        let ((ixx, ixy), (_, iyy)) = (ix.gradients(), iy.gradients());
        let (ixz, iyz) = iz.gradients();
        Self { ix, iy, iz, ixx, ixy, iyy, ixz, iyz }
    }

    /// The linearised data terms of pixel `k`, normalised with `ζ² = z2`.
    #[inline(always)]
    pub(super) fn terms(&self, k: usize, z2: f32) -> Terms {
        Terms {
            ix: self.ix.data()[k],
            iy: self.iy.data()[k],
            iz: self.iz.data()[k],
            ixx: self.ixx.data()[k],
            ixy: self.ixy.data()[k],
            iyy: self.iyy.data()[k],
            ixz: self.ixz.data()[k],
            iyz: self.iyz.data()[k],
            ..Terms::default()
        }
        .normalised(z2)
    }
}
