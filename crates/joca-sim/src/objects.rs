//! Scene objects: rigid assemblies of boxes with a material each, and how they move.
//!
//! Every renderable thing — building, lamp post, traffic sign, car, walker — is an [`Object`]: a
//! few [`Part`]s in the object's own frame (`x` forward, `y` left, `z` up, origin on the ground)
//! and a [`Motion`] that gives its ground pose at any time. Only objects with a [`Class`] produce
//! ground truth; the others (buildings, poles) only occlude.

use crate::geometry::{OrientedBox, Pose2, V3};
use joca_core::Class;

/// Linear RGB reflectance or radiance triple.
pub type Rgb = [f32; 3];

/// How a part's surface looks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Material {
    /// Uniform diffuse reflectance.
    Flat(Rgb),
    /// Uniform diffuse reflectance on a box also seen from below (a tunnel's ceiling): the
    /// only material whose box draws its bottom face.
    Underside(Rgb),
    /// A building facade: wall with a grid of windows on the side faces, plain roof on top.
    /// Some windows are lit (emissive), which matters only at night.
    Facade {
        /// Wall reflectance.
        wall: Rgb,
        /// Window glass reflectance.
        glass: Rgb,
        /// Horizontal window pitch, metres.
        pitch_u_m: f32,
        /// Storey height, metres.
        pitch_v_m: f32,
        /// Seed of which windows are lit.
        lit_seed: u32,
    },
    /// Light-emitting surface with a fixed radiance in calibrated DN, plus a small reflectance.
    Emissive(Rgb),
    /// A street-lamp head: emits [`LAMP`] when the lights are on, plain diffuse glass otherwise.
    Lamp,
    /// A traffic sign plate: pattern `kind` on the front (+x) face, grey metal elsewhere.
    Sign(u8),
}

/// One box of an object.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Part {
    /// Centre in the object frame, metres.
    pub offset: V3,
    /// Half extents (forward, left, up), metres.
    pub half: V3,
    /// Surface.
    pub material: Material,
    /// Walking animation: forward swing amplitude in metres (legs, arms); 0 for rigid parts.
    pub swing_m: f32,
}

impl Part {
    /// A rigid part.
    pub fn new(offset: V3, half: V3, material: Material) -> Self {
        Self { offset, half, material, swing_m: 0.0 }
    }
}

/// How an object moves over time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Motion {
    /// Never moves.
    Static(Pose2),
    /// Drives along a straight lane at constant speed, wrapping around at the lane's ends.
    Lane {
        /// Lane start, world metres.
        origin: (f32, f32),
        /// Unit direction of travel.
        dir: (f32, f32),
        /// Lane length, metres.
        length_m: f32,
        /// Position along the lane at t = 0, metres.
        s0_m: f32,
        /// Speed, m/s.
        speed_mps: f32,
    },
    /// Walks back and forth between two points at constant speed.
    PingPong {
        /// One end, world metres.
        a: (f32, f32),
        /// The other end, world metres.
        b: (f32, f32),
        /// Distance walked at t = 0, metres.
        s0_m: f32,
        /// Speed, m/s.
        speed_mps: f32,
    },
}

impl Motion {
    /// Ground pose and gait phase (radians, for walking animation) at time `t_s`.
    pub fn at(&self, t_s: f64) -> (Pose2, f32) {
        match *self {
            Motion::Static(p) => (p, 0.0),
            Motion::Lane { origin, dir, length_m, s0_m, speed_mps } => {
                let s = (f64::from(s0_m) + f64::from(speed_mps) * t_s)
                    .rem_euclid(f64::from(length_m)) as f32;
                let pose = Pose2 {
                    x: origin.0 + dir.0 * s,
                    y: origin.1 + dir.1 * s,
                    yaw: dir.1.atan2(dir.0),
                };
                (pose, 0.0)
            }
            Motion::PingPong { a, b, s0_m, speed_mps } => {
                let (dx, dy) = (b.0 - a.0, b.1 - a.1);
                let len = (dx * dx + dy * dy).sqrt().max(1e-3);
                let walked = f64::from(s0_m) + f64::from(speed_mps) * t_s;
                let cycle = walked.rem_euclid(2.0 * f64::from(len)) as f32;
                let (s, yaw) = if cycle <= len {
                    (cycle, dy.atan2(dx))
                } else {
                    (2.0 * len - cycle, (-dy).atan2(-dx))
                };
                let u = s / len;
                // A stride of ~1.4 m per gait cycle.
                let phase = (walked as f32 / 1.4) * std::f32::consts::TAU;
                (Pose2 { x: a.0 + dx * u, y: a.1 + dy * u, yaw }, phase)
            }
        }
    }

    /// Whether the object ever moves.
    pub fn is_static(&self) -> bool {
        matches!(self, Motion::Static(_))
    }
}

/// A renderable object.
#[derive(Debug, Clone, PartialEq)]
pub struct Object {
    /// Detection class, or `None` for scenery that only occludes.
    pub class: Option<Class>,
    /// Boxes in the object frame.
    pub parts: Vec<Part>,
    /// Motion over time.
    pub motion: Motion,
    /// Radius of a sphere around the object origin that holds every part, metres.
    pub radius_m: f32,
}

impl Object {
    /// An object from its parts; the bounding radius is computed.
    pub fn new(class: Option<Class>, parts: Vec<Part>, motion: Motion) -> Self {
        let radius_m = parts
            .iter()
            .map(|p| p.offset.norm() + p.half.norm() + p.swing_m)
            .fold(0.0f32, f32::max);
        Self { class, parts, motion, radius_m }
    }

    /// The object's boxes in the world at time `t_s`, each with its material.
    pub fn boxes_at(&self, t_s: f64) -> impl Iterator<Item = (OrientedBox, Material)> + '_ {
        let (pose, phase) = self.motion.at(t_s);
        let rotation = pose.yaw.sin_cos();
        self.parts.iter().map(move |p| {
            let mut offset = p.offset;
            if p.swing_m != 0.0 {
                offset.x += p.swing_m * phase.sin();
            }
            let centre = pose.apply_rotated(rotation, offset);
            (OrientedBox { centre, half: p.half, yaw: pose.yaw }, p.material)
        })
    }

    /// World position of the object origin at time `t_s`.
    pub fn position_at(&self, t_s: f64) -> Pose2 {
        self.motion.at(t_s).0
    }
}

/// Builders for the kinds of object the city contains. Dimensions are typical real ones.
pub mod build {
    use super::*;

    /// A car, van or truck of `length × width × height` metres with `paint`, its lights emissive.
    pub fn vehicle(length: f32, width: f32, height: f32, paint: Rgb, motion: Motion) -> Object {
        let (hl, hw) = (length / 2.0, width / 2.0);
        let body_h = height * 0.55;
        let clearance = 0.25;
        let truck = length > 5.6;
        let mut parts = vec![
            // Lower body.
            Part::new(
                V3::new(0.0, 0.0, clearance + body_h / 2.0),
                V3::new(hl, hw, body_h / 2.0),
                Material::Flat(paint),
            ),
        ];
        let top_h = height - clearance - body_h;
        if truck {
            // Cargo box over the rear, cab with windscreen at the front.
            parts.push(Part::new(
                V3::new(-0.2 * length, 0.0, clearance + body_h + top_h / 2.0),
                V3::new(0.3 * length, hw, top_h / 2.0),
                Material::Flat(lighten(paint)),
            ));
            parts.push(Part::new(
                V3::new(0.38 * length, 0.0, clearance + body_h + top_h / 2.0),
                V3::new(0.1 * length, hw * 0.95, top_h / 2.0),
                Material::Flat(GLASS),
            ));
        } else {
            // Cabin: dark glass, slightly narrower, set back.
            parts.push(Part::new(
                V3::new(-0.08 * length, 0.0, clearance + body_h + top_h / 2.0),
                V3::new(0.28 * length, hw * 0.9, top_h / 2.0),
                Material::Flat(GLASS),
            ));
            // Roof in body colour.
            parts.push(Part::new(
                V3::new(-0.08 * length, 0.0, height - 0.02),
                V3::new(0.26 * length, hw * 0.88, 0.03),
                Material::Flat(paint),
            ));
        }
        // Wheels (dark) at the four corners.
        for (sx, sy) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
            parts.push(Part::new(
                V3::new(sx * (hl - 0.75), sy * (hw - 0.12), 0.33),
                V3::new(0.33, 0.13, 0.33),
                Material::Flat(TYRE),
            ));
        }
        // Head lights (front, warm white) and tail lights (rear, red).
        for sy in [1.0, -1.0] {
            let y = sy * (hw - 0.3);
            parts.push(Part::new(
                V3::new(hl + 0.01, y, clearance + body_h * 0.7),
                V3::new(0.02, 0.16, 0.07),
                Material::Emissive(HEADLIGHT),
            ));
            parts.push(Part::new(
                V3::new(-hl - 0.01, y, clearance + body_h * 0.75),
                V3::new(0.02, 0.14, 0.06),
                Material::Emissive(TAILLIGHT),
            ));
        }
        Object::new(Some(Class::Vehicle), parts, motion)
    }

    /// A walker about `height` metres tall wearing `top` and `trousers`.
    pub fn walker(height: f32, top: Rgb, trousers: Rgb, skin: Rgb, motion: Motion) -> Object {
        let s = height / 1.75;
        let leg_h = 0.85 * s;
        let torso_h = 0.6 * s;
        let mut left_leg = Part::new(
            V3::new(0.0, 0.1 * s, leg_h / 2.0),
            V3::new(0.08 * s, 0.08 * s, leg_h / 2.0),
            Material::Flat(trousers),
        );
        left_leg.swing_m = 0.18 * s;
        let mut right_leg = left_leg;
        right_leg.offset.y = -0.1 * s;
        right_leg.swing_m = -0.18 * s;
        let mut left_arm = Part::new(
            V3::new(0.0, 0.26 * s, leg_h + torso_h * 0.55),
            V3::new(0.06 * s, 0.05 * s, 0.3 * s),
            Material::Flat(top),
        );
        left_arm.swing_m = -0.12 * s;
        let mut right_arm = left_arm;
        right_arm.offset.y = -0.26 * s;
        right_arm.swing_m = 0.12 * s;
        let parts = vec![
            left_leg,
            right_leg,
            Part::new(
                V3::new(0.0, 0.0, leg_h + torso_h / 2.0),
                V3::new(0.12 * s, 0.21 * s, torso_h / 2.0),
                Material::Flat(top),
            ),
            left_arm,
            right_arm,
            Part::new(
                V3::new(0.0, 0.0, leg_h + torso_h + 0.13 * s),
                V3::new(0.1 * s, 0.09 * s, 0.12 * s),
                Material::Flat(skin),
            ),
        ];
        Object::new(Some(Class::Walker), parts, motion)
    }

    /// A traffic sign plate of pattern `kind` facing along `yaw`, its centre `height` m up.
    pub fn sign_plate(x: f32, y: f32, yaw: f32, height: f32, kind: u8) -> Object {
        let parts = vec![Part::new(
            V3::new(0.0, 0.0, height),
            V3::new(0.02, 0.35, 0.35),
            Material::Sign(kind),
        )];
        Object::new(Some(Class::TrafficSign), parts, Motion::Static(Pose2 { x, y, yaw }))
    }

    /// A plain pole `height` m tall (sign post).
    pub fn pole(x: f32, y: f32, height: f32) -> Object {
        let parts = vec![Part::new(
            V3::new(0.0, 0.0, height / 2.0),
            V3::new(0.04, 0.04, height / 2.0),
            Material::Flat(METAL),
        )];
        Object::new(None, parts, Motion::Static(Pose2 { x, y, yaw: 0.0 }))
    }

    /// A street lamp: 8 m post with an arm reaching 1.5 m along `yaw` to an emissive head.
    pub fn street_lamp(x: f32, y: f32, yaw: f32) -> Object {
        let parts = vec![
            Part::new(V3::new(0.0, 0.0, 4.0), V3::new(0.09, 0.09, 4.0), Material::Flat(METAL)),
            Part::new(V3::new(0.75, 0.0, 7.95), V3::new(0.75, 0.05, 0.05), Material::Flat(METAL)),
            Part::new(V3::new(1.45, 0.0, 7.85), V3::new(0.3, 0.15, 0.06), Material::Lamp),
        ];
        Object::new(None, parts, Motion::Static(Pose2 { x, y, yaw }))
    }

    /// A building: a box of `length × depth × height` with a facade material, front along `yaw`.
    pub fn building(pose: Pose2, length: f32, depth: f32, height: f32, facade: Material) -> Object {
        let parts = vec![Part::new(
            V3::new(0.0, 0.0, height / 2.0),
            V3::new(depth / 2.0, length / 2.0, height / 2.0),
            facade,
        )];
        Object::new(None, parts, Motion::Static(pose))
    }

    fn lighten(c: Rgb) -> Rgb {
        c.map(|v| (v * 1.3 + 0.15).min(0.9))
    }
}

/// Dark tinted glass.
pub const GLASS: Rgb = [0.05, 0.06, 0.07];
/// Tyre rubber.
pub const TYRE: Rgb = [0.03, 0.03, 0.03];
/// Grey painted metal (poles, sign backs).
pub const METAL: Rgb = [0.35, 0.36, 0.38];
/// Head light radiance, calibrated DN: far above white, so it clips like a real lamp.
pub const HEADLIGHT: Rgb = [2400.0, 2300.0, 2000.0];
/// Tail light radiance, calibrated DN.
pub const TAILLIGHT: Rgb = [420.0, 20.0, 15.0];
/// Street lamp head radiance, calibrated DN (sodium-white).
pub const LAMP: Rgb = [3000.0, 2500.0, 1700.0];
