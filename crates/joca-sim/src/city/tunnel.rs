//! Tunnels as places: road blocks covered by a ceiling between two walls, lit by lamps along
//! the ceiling and by the daylight that enters through the mouths.
//!
//! A tunnel covers one block of a road between two intersections a route can reach, from the
//! far edge of one crossing road's sidewalk to the near edge of the next (45–75 m), across the
//! roadway and both sidewalks, [`CLEARANCE_M`] high. Inside, a surface gets no sun and no sky:
//! - the **lamps**' irradiance, [`Tunnel::lamp_level`] on the roadway (and on every surface
//!   facing up), half of it on the walls and on anything vertical, a fifth on the ceiling;
//! - the **daylight through each mouth**: the irradiance `E` of a horizontal surface outside,
//!   seen as a luminous disc of the mouth's area (`a² = w·h/π`) and luminance `κ·E/π` (κ =
//!   [`MOUTH_REFLECTANCE`], the street, facades and sky seen through it), on a surface parallel
//!   to the tunnel's axis a distance `d` in: `½·κ·E · a²/(a² + d²) · c/√(c² + d²)`, where the
//!   first factor is the disc's solid angle and the second the obliquity of its light on a
//!   surface at a mean `c = √(w·h)/2` from its centre. At the mouth plane that is half of κ·E,
//!   half the view being out; 10 m in a two-lane tunnel a few percent of it; beyond ~12 m the
//!   lamps dominate (CIE 88 counts on daylight only in the first metres of a tunnel).
//!
//! Walls and ceiling are built of [`SEGMENT_M`] pieces, each lit at its own centre.
//!
//! Street lamps that would stand inside are not built (their posts would pierce the ceiling).

use super::{City, SIDEWALK_M};
use crate::geometry::{Pose2, V3};
use crate::objects::{Material, Motion, Object, Part};
use joca_core::tunnels::Tunnels;
use rand::Rng;

/// Height of the ceiling above the road, metres (road tunnels: 4.5–5 m of clearance, plus the
/// lamps and fans under the ceiling).
pub const CLEARANCE_M: f32 = 5.5;
/// Thickness of the cover over the road, metres (what the portal shows above the mouth).
const COVER_M: f32 = 3.0;
/// Thickness of a side wall, metres.
const WALL_M: f32 = 0.6;
/// Spacing of the lamps along the ceiling, metres.
const LAMP_SPACING_M: f32 = 6.0;
/// A tunnel lamp's radiance, calibrated DN: a few times white paper in daylight (LED tunnel
/// luminaires are some 10⁴ cd/m², sunlit white paper about as much), so it clips.
pub const TUNNEL_LAMP: [f32; 3] = [700.0, 680.0, 640.0];
/// Concrete of the walls, ceiling and portal.
const CONCRETE: [f32; 3] = [0.38, 0.37, 0.35];
/// The ceiling's share of the lamps' level (it sees the lit road and walls, not the lamps).
pub const CEILING_SHARE: f32 = 0.2;
/// Mean reflectance of what a mouth shows from inside (street, facades, a little sky).
pub const MOUTH_REFLECTANCE: f32 = 0.3;
/// Length of the pieces walls and ceiling are built of, metres.
pub const SEGMENT_M: f32 = 4.0;

/// One covered road block.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tunnel {
    /// Whether the road runs along x (an east–west road of `roads_y`).
    pub along_x: bool,
    /// The road's index in its list (`roads_y` if `along_x`, else `roads_x`).
    pub road: usize,
    /// The block: between intersections `block` and `block + 1` along the road.
    pub block: usize,
    /// The road's centre line (y if `along_x`, else x), metres.
    pub centre_m: f32,
    /// Half the covered width (roadway and both sidewalks), metres.
    pub half_width_m: f32,
    /// The mouths along the road (x if `along_x`, else y), metres, `from_m < to_m`.
    pub from_m: f32,
    /// The far mouth, metres.
    pub to_m: f32,
    /// The lamps' irradiance on the roadway, relative to daylight's unit.
    pub lamp_level: f32,
}

impl Tunnel {
    /// `(along, across)` of a world point: along the road, and from its centre line.
    pub fn local(&self, x: f32, y: f32) -> (f32, f32) {
        if self.along_x { (x, y - self.centre_m) } else { (y, x - self.centre_m) }
    }

    /// A world point from `(along, across)`, at height `z`.
    pub fn world(&self, along: f32, across: f32, z: f32) -> V3 {
        if self.along_x {
            V3::new(along, self.centre_m + across, z)
        } else {
            V3::new(self.centre_m + across, along, z)
        }
    }

    /// The tunnel's length between its mouths, metres.
    pub fn length_m(&self) -> f32 {
        self.to_m - self.from_m
    }

    /// Whether a point lies under the ceiling, between the mouths and the walls, the walls'
    /// inner faces included (a face in a mouth's plane is outside: the portal is lit by day).
    pub fn holds(&self, p: V3) -> bool {
        self.along_inside(p).is_some()
    }

    /// Where along the road a point under the ceiling lies ([`Tunnel::holds`]), or `None`.
    fn along_inside(&self, p: V3) -> Option<f32> {
        let (along, across) = self.local(p.x, p.y);
        let inside = p.z <= CLEARANCE_M + 1e-3
            && across.abs() <= self.half_width_m + 1e-2
            && along > self.from_m + 1e-3
            && along < self.to_m - 1e-3;
        inside.then_some(along)
    }

    /// The mouths' share of the outside light at `along` (see the module's documentation).
    pub fn mouth_share(&self, along: f32) -> f32 {
        let area = 2.0 * self.half_width_m * CLEARANCE_M;
        let a2 = area / std::f32::consts::PI;
        let c = 0.5 * area.sqrt();
        let share = |d: f32| {
            let d = d.max(0.0);
            0.5 * MOUTH_REFLECTANCE * a2 / (a2 + d * d) * c / (c * c + d * d).sqrt()
        };
        share(along - self.from_m) + share(self.to_m - along)
    }

    /// Irradiance inside at `along` of a surface whose share of the lamps is `lamp_share` (1
    /// facing up, ½ vertical, [`CEILING_SHARE`] the ceiling), given `outside`, the irradiance
    /// of a horizontal surface in the open.
    pub fn irradiance(&self, along: f32, lamp_share: f32, outside: f32) -> f32 {
        self.lamp_level * lamp_share + self.mouth_share(along) * outside
    }

    /// The walls, the cover (seen from below as the ceiling) and the lamps along it.
    fn objects(&self) -> Vec<Object> {
        let (len, mid) = (self.length_m(), 0.5 * (self.from_m + self.to_m));
        let yaw = if self.along_x { 0.0 } else { std::f32::consts::FRAC_PI_2 };
        let at = |along: f32, across: f32| {
            let p = self.world(along, across, 0.0);
            Pose2 { x: p.x, y: p.y, yaw }
        };
        let slab =
            |half: V3, z: f32, material| vec![Part::new(V3::new(0.0, 0.0, z), half, material)];
        let outer = self.half_width_m + WALL_M;
        let pieces = (len / SEGMENT_M).ceil().max(1.0) as usize;
        let piece = len / pieces as f32;
        // Pieces along the object's x (the road), centred on the tunnel's middle.
        let along = |k: usize| (k as f32 + 0.5) * piece - len / 2.0;
        let cover_half = V3::new(piece / 2.0, outer, COVER_M / 2.0);
        let cover = (0..pieces)
            .map(|k| {
                let at = V3::new(along(k), 0.0, CLEARANCE_M + COVER_M / 2.0);
                Part::new(at, cover_half, Material::Underside(CONCRETE))
            })
            .collect();
        let mut out = vec![Object::new(None, cover, Motion::Static(at(mid, 0.0)))];
        let wall_half = V3::new(piece / 2.0, WALL_M / 2.0, CLEARANCE_M / 2.0);
        for side in [-1.0f32, 1.0] {
            let across = side * (self.half_width_m + WALL_M / 2.0);
            let wall = (0..pieces)
                .map(|k| {
                    let at = V3::new(along(k), across, CLEARANCE_M / 2.0);
                    Part::new(at, wall_half, Material::Flat(CONCRETE))
                })
                .collect();
            out.push(Object::new(None, wall, Motion::Static(at(mid, 0.0))));
        }
        let lamp_half = V3::new(0.6, 0.15, 0.06);
        let lamps = (len / LAMP_SPACING_M).floor().max(1.0) as usize;
        let first = mid - 0.5 * (lamps - 1) as f32 * LAMP_SPACING_M;
        for k in 0..lamps {
            for side in [-1.0f32, 1.0] {
                let across = side * (self.half_width_m - SIDEWALK_M);
                let lamp = slab(lamp_half, CLEARANCE_M - 0.06, Material::Emissive(TUNNEL_LAMP));
                let along = first + k as f32 * LAMP_SPACING_M;
                out.push(Object::new(None, lamp, Motion::Static(at(along, across))));
            }
        }
        out
    }
}

impl City {
    /// The town's tunnels.
    pub fn tunnels(&self) -> &[Tunnel] {
        &self.tunnels
    }

    /// The tunnel holding `p` (see [`Tunnel::holds`]), if any.
    #[inline]
    pub fn tunnel_at(&self, p: V3) -> Option<&Tunnel> {
        self.tunnels.iter().find(|t| t.holds(p))
    }

    /// The irradiance at `p` if a tunnel covers it ([`Tunnel::irradiance`] for a surface with
    /// `lamp_share` of the lamps, `outside` being the open ground's), instead of sun, sky and
    /// street lamps; `None` in the open.
    #[inline]
    pub fn tunnel_irradiance(&self, p: V3, lamp_share: f32, outside: f32) -> Option<f32> {
        self.tunnels
            .iter()
            .find_map(|t| t.along_inside(p).map(|along| t.irradiance(along, lamp_share, outside)))
    }

    /// Covers `spec.count` distinct blocks between the intersections a route can reach (two
    /// blocks inside the map's edge), drops the street lamps under them and bakes the lamps'
    /// light map again without them (`lamps`: the heads of every lit street lamp).
    pub(super) fn place_tunnels(&mut self, spec: &Tunnels, lamps: &[V3], rng: &mut impl Rng) {
        let n = self.roads_per_axis();
        let (lo, hi) = (2usize, n - 3);
        let mut blocks: Vec<(bool, usize, usize)> = Vec::new();
        for along_x in [true, false] {
            for road in lo..=hi {
                blocks.extend((lo..hi).map(|block| (along_x, road, block)));
            }
        }
        for _ in 0..(spec.count as usize).min(blocks.len()) {
            let (along_x, road, block) = blocks.swap_remove(rng.random_range(0..blocks.len()));
            let (own, crossing) = if along_x {
                (&self.roads_y, &self.roads_x)
            } else {
                (&self.roads_x, &self.roads_y)
            };
            let (a, b) = (crossing[block], crossing[block + 1]);
            self.tunnels.push(Tunnel {
                along_x,
                road,
                block,
                centre_m: own[road].centre_m,
                half_width_m: own[road].half_width_m() + SIDEWALK_M,
                from_m: a.centre_m + a.half_width_m() + SIDEWALK_M,
                to_m: b.centre_m - b.half_width_m() - SIDEWALK_M,
                lamp_level: spec.lamp_level,
            });
        }
        // A street lamp's post stands on the sidewalk and its head reaches 1.45 m over the road.
        let under = |tunnels: &[Tunnel], p: V3| {
            tunnels.iter().any(|t| {
                let (along, across) = t.local(p.x, p.y);
                across.abs() < t.half_width_m + 2.0
                    && along > t.from_m - 2.0
                    && along < t.to_m + 2.0
            })
        };
        let tunnels = self.tunnels.clone();
        self.objects.retain(|o| {
            let tall = o.parts.iter().any(|p| p.material == Material::Lamp);
            let pose = o.position_at(0.0);
            !(tall && under(&tunnels, V3::new(pose.x, pose.y, 0.0)))
        });
        let kept: Vec<V3> = lamps.iter().copied().filter(|&h| !under(&tunnels, h)).collect();
        self.bake_lightmap(&kept);
        for t in &tunnels {
            self.objects.extend(t.objects());
        }
    }
}
