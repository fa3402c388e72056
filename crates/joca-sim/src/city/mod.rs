//! The procedural city: a Manhattan grid of roads and blocks generated from a seed, with
//! buildings, street lamps, traffic signs, parked and moving vehicles, and walkers.
//!
//! Roads run north–south (at constant `x`) and east–west (constant `y`). Each road has one or two
//! driving lanes per direction (3.5 m), a 2.2 m parking strip on each side and 3.5 m sidewalks.
//! Traffic keeps to the right. Blocks are 45–75 m across. The outer ring of blocks and walls
//! across the road ends close the view at the map's edge; the ego vehicle stays two blocks
//! inside it.

mod actors;
mod ground;
mod place;
mod tunnel;

use crate::geometry::{Pose2, V3};
use crate::objects::{Material, Motion, Object, Rgb, build};
use ground::{asphalt, lane_marking, modulo, zebra, zone_table};
pub use ground::{fast_floor, ground_grain, hash_unit};
use joca_core::tunnels::Tunnels;
use rand::Rng;
use std::f32::consts::{FRAC_PI_2, PI};
pub use tunnel::{CEILING_SHARE, CLEARANCE_M, TUNNEL_LAMP, Tunnel};

/// Width of a driving lane, metres.
pub const LANE_WIDTH_M: f32 = 3.5;
/// Width of the parking strip on each side of a road, metres.
pub const PARKING_M: f32 = 2.2;
/// Width of a sidewalk, metres.
pub const SIDEWALK_M: f32 = 3.5;
/// Resolution of the ground zone tables and the lamp light map, metres per cell.
const ZONE_RES_M: f32 = 0.25;
const LIGHTMAP_RES_M: f32 = 1.0;
/// Height of street-lamp heads, metres.
const LAMP_HEIGHT_M: f32 = 7.85;
/// Irradiance right under a lamp, relative to daylight (street lighting is ~10–30 lux against
/// ~10⁴ lux of daylight; physically ~0.1 %, but 1 % keeps lamp pools visible with the exposure
/// ranges of the paper).
const LAMP_PEAK: f32 = 0.01;

/// One straight road of the grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Road {
    /// Coordinate of the centre line (x for north–south roads, y for east–west), metres.
    pub centre_m: f32,
    /// Driving lanes per direction.
    pub lanes_per_dir: u8,
}

impl Road {
    /// Half width from the centre line to the kerb, metres.
    pub fn half_width_m(&self) -> f32 {
        f32::from(self.lanes_per_dir) * LANE_WIDTH_M + PARKING_M
    }

    /// Offset of lane `k` (0 = innermost) from the centre line, metres.
    pub fn lane_offset_m(&self, k: u8) -> f32 {
        (f32::from(k) + 0.5) * LANE_WIDTH_M
    }
}

/// What lies at a coordinate along one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Zone {
    Road(u16),
    Walk,
    Block,
}

/// Generation parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CityConfig {
    /// Blocks per side of the grid; fewer than [`City::MIN_BLOCKS`] are raised to it.
    pub blocks: usize,
    /// Walkers per block edge, on average.
    pub walkers_per_edge: f32,
    /// Moving vehicles per lane per 100 m.
    pub vehicles_per_100m: f32,
    /// Probability that a walker crosses at a given intersection's zebra crossing.
    pub crossing_walker_probability: f32,
    /// Probability of a traffic sign at each intersection approach.
    pub sign_probability: f32,
    /// Further signs per approach, on average, placed along the block before it (speed
    /// limits, parking signs): 0 in the default town; [`CityConfig::with_sign_density`] uses
    /// them once every approach has its intersection sign.
    pub mid_block_signs: f32,
    /// Covered road blocks (none unless `tunnels.kind` is places): drawn after everything else,
    /// so the rest of the town is the same town without them.
    pub tunnels: Tunnels,
    /// Whether the street lamps light at night (default); `false`: the posts stand where they
    /// would (the same town) but stay dark, so at night the street has only the cars' lights,
    /// the lit windows and the night sky. Tunnel lamps are the tunnels' own and stay lit.
    pub street_lamps: bool,
}

/// The default [`CityConfig::sign_probability`]. Signs are drawn with at most this first;
/// approaches left empty get theirs after everything else is placed, so a denser setting adds
/// signs to the same town instead of redrawing it.
const SIGN_PROBABILITY: f32 = 0.45;

impl Default for CityConfig {
    fn default() -> Self {
        Self {
            blocks: 8,
            walkers_per_edge: 1.2,
            vehicles_per_100m: 0.9,
            crossing_walker_probability: 0.35,
            sign_probability: SIGN_PROBABILITY,
            mid_block_signs: 0.0,
            tunnels: Tunnels::default(),
            street_lamps: true,
        }
    }
}

impl CityConfig {
    /// The same city with `factor` times the walkers, on sidewalks and at crossings (the
    /// crossing probability saturates at one walker per intersection).
    #[must_use]
    pub fn with_walker_density(self, factor: f32) -> Self {
        Self {
            walkers_per_edge: self.walkers_per_edge * factor,
            crossing_walker_probability: (self.crossing_walker_probability * factor).min(1.0),
            ..self
        }
    }

    /// The same city with `factor` times the traffic signs: first at more intersection
    /// approaches, then, beyond a sign on every approach (1/0.45 ≈ 2.2 times the default), along
    /// the blocks. A factor above 1 leaves the rest of the town unchanged; one below redraws it.
    #[must_use]
    pub fn with_sign_density(self, factor: f32) -> Self {
        let per_approach = self.sign_probability + self.mid_block_signs;
        let wanted = per_approach * factor.max(0.0);
        Self { sign_probability: wanted.min(1.0), mid_block_signs: (wanted - 1.0).max(0.0), ..self }
    }
}

/// Where along an approach a sign stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SignPlace {
    /// 1–6 m before the crossing road.
    Intersection,
    /// 8–40 m before it, along the block.
    MidBlock,
}

/// A generated city.
#[derive(Debug, Clone)]
pub struct City {
    /// North–south roads, west to east.
    pub roads_x: Vec<Road>,
    /// East–west roads, south to north.
    pub roads_y: Vec<Road>,
    /// Size of the square map, metres (both axes span `[0, extent_m]`).
    pub extent_m: f32,
    /// Everything that is rendered.
    pub objects: Vec<Object>,
    zones_x: Vec<Zone>,
    zones_y: Vec<Zone>,
    lightmap: Vec<f32>,
    lightmap_n: usize,
    tunnels: Vec<Tunnel>,
    /// Whether the street lamps light at night ([`CityConfig::street_lamps`]).
    street_lamps: bool,
}

impl City {
    /// The fewest blocks per side: routes keep two roads inside the map's edge, so five blocks
    /// (six roads) leave a 2 × 2 grid of intersections a route can turn through; four left one
    /// intersection and no road to drive from it.
    pub const MIN_BLOCKS: usize = 5;

    /// Generates a city from `rng`.
    pub fn generate(config: &CityConfig, rng: &mut impl Rng) -> Self {
        let n = config.blocks.max(Self::MIN_BLOCKS);
        let lanes = |rng: &mut dyn rand::RngCore, outer: bool| -> u8 {
            if !outer && rng.random::<f32>() < 0.3 { 2 } else { 1 }
        };
        let blocks: Vec<f32> = (0..n).map(|_| rng.random_range(45.0..75.0)).collect();
        let mut lanes_x = Vec::new();
        let mut lanes_y = Vec::new();
        for i in 0..=n {
            lanes_x.push(lanes(rng, i == 0 || i == n));
            lanes_y.push(lanes(rng, i == 0 || i == n));
        }
        let layout = |lanes: &[u8]| -> (Vec<Road>, f32) {
            let mut roads = Vec::new();
            let mut cursor = 0.0;
            for (i, &l) in lanes.iter().enumerate() {
                let road = Road { centre_m: 0.0, lanes_per_dir: l };
                let hw = road.half_width_m();
                roads.push(Road { centre_m: cursor + hw, ..road });
                cursor += 2.0 * hw;
                if i < n {
                    cursor += 2.0 * SIDEWALK_M + blocks[i];
                }
            }
            (roads, cursor)
        };
        let (roads_x, extent_x) = layout(&lanes_x);
        let (roads_y, extent_y) = layout(&lanes_y);
        let extent_m = extent_x.max(extent_y);
        let zones_x = zone_table(&roads_x, extent_m);
        let zones_y = zone_table(&roads_y, extent_m);
        let mut city = City {
            roads_x,
            roads_y,
            extent_m,
            objects: Vec::new(),
            zones_x,
            zones_y,
            lightmap: Vec::new(),
            lightmap_n: 0,
            tunnels: Vec::new(),
            street_lamps: config.street_lamps,
        };
        city.place_buildings(rng);
        // Dark streets keep the posts, their light (and so every draw): whether it shines is
        // the instant's (`Lighting::street_lamps_on`).
        let lamps = city.place_lamps(rng);
        city.bake_lightmap(&lamps);
        let empty_approaches = city.place_signs(config.sign_probability.min(SIGN_PROBABILITY), rng);
        city.place_vehicles(config, rng);
        city.place_walkers(config, rng);
        for (i, j, dx, dy, draw) in empty_approaches {
            if draw <= config.sign_probability {
                city.place_sign(i, j, dx, dy, SignPlace::Intersection, rng);
            }
        }
        if config.mid_block_signs > 0.0 {
            city.place_mid_block_signs(config.mid_block_signs, rng);
        }
        if config.tunnels.are_places() {
            city.place_tunnels(&config.tunnels, &lamps, rng);
        }
        city
    }

    /// Whether the street lamps light at night (not with dark streets).
    pub fn street_lamps_lit(&self) -> bool {
        self.street_lamps
    }

    /// Number of intersections per side (roads per axis).
    pub fn roads_per_axis(&self) -> usize {
        self.roads_x.len().min(self.roads_y.len())
    }

    /// Centre of intersection `(i, j)` (road `i` of `roads_x`, road `j` of `roads_y`).
    pub fn intersection(&self, i: usize, j: usize) -> (f32, f32) {
        (self.roads_x[i].centre_m, self.roads_y[j].centre_m)
    }

    fn zone(table: &[Zone], v: f32) -> Zone {
        if v < 0.0 {
            return Zone::Block;
        }
        table.get((v / ZONE_RES_M) as usize).copied().unwrap_or(Zone::Block)
    }

    /// Diffuse reflectance of the ground at world `(x, y)`: asphalt with lane markings and
    /// zebra crossings, paved sidewalks, and planted block interiors.
    pub fn ground_albedo(&self, x: f32, y: f32) -> Rgb {
        self.ground_albedo_with(x, y, ground_grain(x, y))
    }

    /// [`City::ground_albedo`] given the point's [`ground_grain`] (which the renderer computes
    /// for a whole row at once).
    #[inline]
    pub fn ground_albedo_with(&self, x: f32, y: f32, grain: f32) -> Rgb {
        match (Self::zone(&self.zones_x, x), Self::zone(&self.zones_y, y)) {
            (Zone::Road(_), Zone::Road(_)) => asphalt(grain),
            (Zone::Road(i), Zone::Walk) => {
                let off = x - self.roads_x[usize::from(i)].centre_m;
                zebra(off, grain, self.roads_x[usize::from(i)])
            }
            (Zone::Walk, Zone::Road(j)) => {
                let off = y - self.roads_y[usize::from(j)].centre_m;
                zebra(off, grain, self.roads_y[usize::from(j)])
            }
            (Zone::Road(i), Zone::Block) => lane_marking(
                x - self.roads_x[usize::from(i)].centre_m,
                y,
                self.roads_x[usize::from(i)],
                grain,
            ),
            (Zone::Block, Zone::Road(j)) => lane_marking(
                y - self.roads_y[usize::from(j)].centre_m,
                x,
                self.roads_y[usize::from(j)],
                grain,
            ),
            (Zone::Block, Zone::Block) => {
                let g = 0.8 + 0.4 * hash_unit(x * 0.7, y * 0.7);
                [0.10 * g, 0.16 * g, 0.07 * g]
            }
            _ => {
                // Paving slabs of 1.5 m with darker joints.
                let joint = modulo(x, 1.5) < 0.06 || modulo(y, 1.5) < 0.06;
                let v = if joint { 0.16 } else { 0.26 * grain };
                [v, v, v * 0.97]
            }
        }
    }

    /// Irradiance from street lamps at ground point `(x, y)`, relative to daylight (bilinear in a
    /// 1 m light map).
    pub fn lamp_irradiance(&self, x: f32, y: f32) -> f32 {
        let n = self.lightmap_n;
        let (fx, fy) = (x / LIGHTMAP_RES_M, y / LIGHTMAP_RES_M);
        if !(fx >= 0.0 && fy >= 0.0 && fx < (n - 1) as f32 && fy < (n - 1) as f32) {
            return 0.0;
        }
        // In range (checked above, and the map is far smaller than 2³¹ m), so a conversion to
        // i32 gives the same cell as one to usize, and costs less: x86-64 converts floats only
        // to signed integers. This runs per ground pixel at night.
        let (ix, iy) = (fx as i32 as usize, fy as i32 as usize);
        let (tx, ty) = (fx - ix as f32, fy - iy as f32);
        let at = |i: usize, j: usize| self.lightmap[j * n + i];
        let top = at(ix, iy) * (1.0 - tx) + at(ix + 1, iy) * tx;
        let bottom = at(ix, iy + 1) * (1.0 - tx) + at(ix + 1, iy + 1) * tx;
        top * (1.0 - ty) + bottom * ty
    }
}

#[cfg(test)]
mod tests;
