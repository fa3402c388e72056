//! Where a box can draw before any of its faces is set up: its screen rectangle and nearest
//! depth ([`screen_reach`]), and whether nearer surfaces already hide all of that
//! ([`hidden`]). Both are conservative: a box they rule out would have changed no pixel.

use super::{CameraFrame, NEAR_M, Target, raster};
use crate::geometry::{OrientedBox, V3};

/// Where on the screen a box can draw, from [`screen_reach`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Reach {
    /// It covers no pixel centre.
    Nowhere,
    /// It reaches the near plane: anywhere, at any depth.
    Anywhere,
    /// Only pixels in columns `x0..=x1` and rows `y0..=y1`, at inverse depths of at most
    /// `max_inv_z`.
    Within { x0: usize, x1: usize, y0: usize, y1: usize, max_inv_z: f32 },
}

/// Relative allowance on [`Reach::Within`]'s depth bound for the rasteriser's own rounding:
/// each pixel's 1/z is a plane value rounded to f32 and then stepped along the row by f32
/// additions, each off by at most half an ulp of the running value, so a span of n pixels
/// strays by less than (n + 2)·2⁻²⁴ ≈ 2.5·10⁻⁴ relative for n ≤ 4,096; the allowance is eight
/// times that.
pub(super) const DEPTH_BOUND_SLACK: f32 = 2e-3;

/// Where box `b`, seen from `cam`, can draw in `target` (most boxes of a city view are small,
/// far or beside the view, or behind nearer ones). In front of the camera, the screen image of
/// a box lies within the bounding rectangle of its eight projected corners, and its depth is
/// no less than the centre's depth less the box's extent along the optical axis. The corners
/// are those of the box grown by a margin that exceeds the rounding of the faces' own corner
/// arithmetic (f32 world coordinates), so the rectangle and depth hold whatever the rounding.
/// A box that reaches the near plane can draw anywhere (its faces are clipped there). `axes`:
/// the box's [`OrientedBox::axes`].
pub(super) fn screen_reach(
    cam: &CameraFrame,
    b: &OrientedBox,
    (f, l): (V3, V3),
    target: &Target,
) -> Reach {
    let c = cam.camera_from_world(b.centre);
    let margin = 0.01 + 1e-5 * (b.centre.x.abs() + b.centre.y.abs() + b.centre.z.abs());
    // The box's half axes in camera coordinates (right, down, forward).
    let to_cam = |v: V3, half: f32| {
        let h = half + margin;
        V3::new(v.dot(cam.right) * h, -v.z * h, v.dot(cam.forward) * h)
    };
    let axes = [to_cam(f, b.half.x), to_cam(l, b.half.y), V3::new(0.0, -(b.half.z + margin), 0.0)];
    let depth = axes.iter().map(|a| a.z.abs()).sum::<f32>();
    let nearest = c.z - depth;
    if nearest <= NEAR_M {
        return Reach::Anywhere;
    }
    let (mut x_min, mut x_max) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut y_min, mut y_max) = (f64::INFINITY, f64::NEG_INFINITY);
    for corner in 0..8 {
        let sign = |bit: usize| if corner >> bit & 1 == 0 { -1.0 } else { 1.0 };
        let (x, y, _) = cam.screen(c + axes[0] * sign(0) + axes[1] * sign(1) + axes[2] * sign(2));
        (x_min, x_max) = (x_min.min(x), x_max.max(x));
        (y_min, y_max) = (y_min.min(y), y_max.max(y));
    }
    let (x0, x1) = raster::centre_span_f64(x_min, x_max, target.width);
    let (y0, y1) = raster::centre_span_f64(y_min, y_max, target.height);
    if x0 > x1 || y0 > y1 {
        return Reach::Nowhere;
    }
    Reach::Within {
        x0: x0 as usize,
        x1: x1 as usize,
        y0: y0 as usize,
        y1: y1 as usize,
        max_inv_z: (1.0 + DEPTH_BOUND_SLACK) / nearest,
    }
}

/// Whether everything a box with `reach` could draw is already hidden in `target`: every pixel
/// of its rectangle holds a surface at least as near as the box's nearest point, so no pixel
/// would pass the depth test (which needs a strictly nearer value). The depth buffer only
/// grows nearer as objects are drawn, so the answer never depends on the drawing order.
pub(super) fn hidden(target: &Target, reach: Reach) -> bool {
    let Reach::Within { x0, x1, y0, y1, max_inv_z } = reach else {
        return reach == Reach::Nowhere;
    };
    (y0..=y1).all(|y| {
        let row = &target.inv_depth[y * target.width + x0..=y * target.width + x1];
        // An or-reduction rather than an early exit, so that it runs on vectors.
        !row.iter().fold(false, |open, &d| open | (d < max_inv_z))
    })
}
