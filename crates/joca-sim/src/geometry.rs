//! Small 3D vector and oriented-box geometry in the world frame.
//!
//! World frame: `x` east, `y` north, `z` up, metres, ground at `z = 0`. Yaw is measured
//! counter-clockwise from `+x`, radians. Rendering uses `f32`: the maps span well under 1 km, where
//! `f32` resolves better than 0.1 mm.

use std::ops::{Add, Mul, Neg, Sub};

/// A 3D vector or point.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct V3 {
    /// East, metres.
    pub x: f32,
    /// North, metres.
    pub y: f32,
    /// Up, metres.
    pub z: f32,
}

impl V3 {
    /// `(x, y, z)`.
    pub const fn new(x: f32, y: f32, z: f32) -> Self {
        Self { x, y, z }
    }

    /// Dot product.
    pub fn dot(self, o: V3) -> f32 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// Euclidean length.
    pub fn norm(self) -> f32 {
        self.dot(self).sqrt()
    }
}

impl Add for V3 {
    type Output = V3;
    fn add(self, o: V3) -> V3 {
        V3::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl Sub for V3 {
    type Output = V3;
    fn sub(self, o: V3) -> V3 {
        V3::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl Mul<f32> for V3 {
    type Output = V3;
    fn mul(self, s: f32) -> V3 {
        V3::new(self.x * s, self.y * s, self.z * s)
    }
}

impl Neg for V3 {
    type Output = V3;
    fn neg(self) -> V3 {
        V3::new(-self.x, -self.y, -self.z)
    }
}

/// A planar pose: position on the ground and heading.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose2 {
    /// East, metres.
    pub x: f32,
    /// North, metres.
    pub y: f32,
    /// Heading, radians counter-clockwise from east.
    pub yaw: f32,
}

impl Pose2 {
    /// Maps a point from this pose's local frame (`x` forward, `y` left, `z` up) to the world.
    pub fn apply(&self, p: V3) -> V3 {
        self.apply_rotated(self.yaw.sin_cos(), p)
    }

    /// [`Pose2::apply`] with the sine and cosine of the yaw given (computed once for many
    /// points).
    pub fn apply_rotated(&self, (s, c): (f32, f32), p: V3) -> V3 {
        V3::new(self.x + c * p.x - s * p.y, self.y + s * p.x + c * p.y, p.z)
    }
}

/// An oriented box: centre, half extents along its own axes, yaw about the vertical.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrientedBox {
    /// Centre, world metres.
    pub centre: V3,
    /// Half extents along the box's forward, left and up axes, metres.
    pub half: V3,
    /// Heading of the box's forward axis, radians.
    pub yaw: f32,
}

impl OrientedBox {
    /// The box's forward and left unit axes in the world.
    pub fn axes(&self) -> (V3, V3) {
        let (s, c) = self.yaw.sin_cos();
        (V3::new(c, s, 0.0), V3::new(-s, c, 0.0))
    }

    /// Radius of the bounding sphere.
    pub fn radius(&self) -> f32 {
        self.half.norm()
    }

    /// Distance along the ray `origin + t·dir` (t in `[0, t_max]`) to the box, if it is hit.
    /// Slab test in the box's own frame.
    pub fn ray_hit(&self, origin: V3, dir: V3, t_max: f32) -> Option<f32> {
        let (f, l) = self.axes();
        let rel = origin - self.centre;
        let o = [rel.dot(f), rel.dot(l), rel.z];
        let d = [dir.dot(f), dir.dot(l), dir.z];
        let h = [self.half.x, self.half.y, self.half.z];
        let (mut t0, mut t1) = (0.0f32, t_max);
        for k in 0..3 {
            if d[k].abs() < 1e-9 {
                if o[k].abs() > h[k] {
                    return None;
                }
            } else {
                let inv = 1.0 / d[k];
                let (a, b) = ((-h[k] - o[k]) * inv, (h[k] - o[k]) * inv);
                let (a, b) = if a < b { (a, b) } else { (b, a) };
                t0 = t0.max(a);
                t1 = t1.min(b);
                if t0 > t1 {
                    return None;
                }
            }
        }
        Some(t0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pose_rotates_counter_clockwise() {
        let p = Pose2 { x: 1.0, y: 2.0, yaw: std::f32::consts::FRAC_PI_2 };
        let w = p.apply(V3::new(1.0, 0.0, 3.0));
        assert!((w.x - 1.0).abs() < 1e-6 && (w.y - 3.0).abs() < 1e-6 && w.z == 3.0);
    }

    #[test]
    fn ray_hits_box_at_the_near_face() {
        let b =
            OrientedBox { centre: V3::new(10.0, 0.0, 1.0), half: V3::new(1.0, 1.0, 1.0), yaw: 0.3 };
        let t = b.ray_hit(V3::new(0.0, 0.0, 1.0), V3::new(1.0, 0.0, 0.0), 100.0).unwrap();
        // Near face of a box rotated by 0.3 rad, seen along x through its centre: 10 − 1/cos(0.3).
        assert!((t - (10.0 - 1.0 / 0.3f32.cos())).abs() < 1e-4, "{t}");
        assert!(b.ray_hit(V3::new(0.0, 0.0, 1.0), V3::new(0.0, 1.0, 0.0), 100.0).is_none());
        assert!(b.ray_hit(V3::new(0.0, 0.0, 1.0), V3::new(1.0, 0.0, 0.0), 5.0).is_none());
    }
}
