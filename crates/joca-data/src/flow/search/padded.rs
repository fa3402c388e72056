//! The patch search's image with a replicated border, sampled a whole patch at a time.

use super::super::Gray;

/// An image with a replicated border, from which a whole patch is sampled at one sub-pixel
/// offset: the patch shares its bilinear weights, so each pixel costs four loads and no
/// rounding. A patch reaching past the border is moved back inside it (as OpenCV's DIS
/// clamps its patch positions).
pub(in crate::flow) struct Padded {
    pub(in crate::flow) data: Vec<f32>,
    pub(in crate::flow) stride: usize,
    border: usize,
    width: usize,
    height: usize,
}

impl Padded {
    pub(in crate::flow) fn new(image: &Gray, border: usize) -> Self {
        let (w, h) = (image.width(), image.height());
        let stride = w + 2 * border;
        let mut data = Vec::with_capacity(stride * (h + 2 * border));
        for y in 0..h + 2 * border {
            let yy = y.saturating_sub(border).min(h - 1);
            for x in 0..stride {
                data.push(image.at(x.saturating_sub(border).min(w - 1), yy));
            }
        }
        Self { data, stride, border, width: w, height: h }
    }

    /// Where the `width × height` patch whose top-left pixel lands at `(x, y)` (image
    /// coordinates) is read: the index of its top-left sample in `data` and the bilinear
    /// weights `(w00, w01, w10, w11)` every pixel of it shares. A patch reaching past the
    /// border is moved back inside it, so rows `start + j · stride` hold `width + 1` samples
    /// for `j ≤ height`.
    #[inline(always)]
    pub(in crate::flow) fn place(
        &self,
        x: f32,
        y: f32,
        (width, height): (usize, usize),
    ) -> (usize, [f32; 4]) {
        let b = self.border as f32;
        // Every read, at floor + size, must stay inside the padded image.
        let x = x.clamp(-b, (self.width + self.border - width - 1) as f32);
        let y = y.clamp(-b, (self.height + self.border - height - 1) as f32);
        // floor without libm's call (|x| is far below 2³¹ here).
        let floor = |v: f32| {
            let t = v as i32 as f32;
            if t > v { t - 1.0 } else { t }
        };
        let (fx, fy) = (floor(x), floor(y));
        let (ax, ay) = (x - fx, y - fy);
        let weights = [(1.0 - ax) * (1.0 - ay), ax * (1.0 - ay), (1.0 - ax) * ay, ax * ay];
        let x0 = (fx as isize + self.border as isize) as usize;
        let y0 = (fy as isize + self.border as isize) as usize;
        (y0 * self.stride + x0, weights)
    }

    /// The bilinear samples of the `size × size` patch whose top-left pixel lands at `(x, y)`
    /// (image coordinates), row-major into `out`.
    #[inline(always)]
    pub(in crate::flow) fn patch(&self, x: f32, y: f32, size: usize, out: &mut [f32]) {
        self.rect(x, y, (size, size), out);
    }

    /// The bilinear samples of the `width × height` rectangle whose top-left pixel lands at
    /// `(x, y)`, row-major into `out` (`width · height` long; both sides at most the border).
    #[inline(always)]
    pub(in crate::flow) fn rect(
        &self,
        x: f32,
        y: f32,
        (width, height): (usize, usize),
        out: &mut [f32],
    ) {
        let (start, [w00, w01, w10, w11]) = self.place(x, y, (width, height));
        for (j, row) in out[..width * height].chunks_exact_mut(width).enumerate() {
            let top = &self.data[start + j * self.stride..][..width + 1];
            let bottom = &self.data[start + (j + 1) * self.stride..][..width + 1];
            for (i, o) in row.iter_mut().enumerate() {
                *o = (w00 * top[i] + w01 * top[i + 1]) + (w10 * bottom[i] + w11 * bottom[i + 1]);
            }
        }
    }
}
