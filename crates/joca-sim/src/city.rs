//! The procedural city: a Manhattan grid of roads and blocks generated from a seed, with
//! buildings, street lamps, traffic signs, parked and moving vehicles, and walkers.
//!
//! Roads run north–south (at constant `x`) and east–west (constant `y`). Each road has one or two
//! driving lanes per direction (3.5 m), a 2.2 m parking strip on each side and 3.5 m sidewalks.
//! Traffic keeps to the right. Blocks are 45–75 m across. The outer ring of blocks and walls
//! across the road ends close the view at the map's edge; the ego vehicle stays two blocks
//! inside it.

use crate::geometry::{Pose2, V3};
use crate::objects::{Material, Motion, Object, Rgb, build};
use rand::Rng;
use std::f32::consts::{FRAC_PI_2, PI};

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
    /// Blocks per side of the grid.
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
}

impl City {
    /// Generates a city from `rng`.
    pub fn generate(config: &CityConfig, rng: &mut impl Rng) -> Self {
        let n = config.blocks.max(4);
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
        };
        city.place_buildings(rng);
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
        city
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
        // Two octaves of value noise: coarse patches and fine grain, ±10 % overall.
        let grain = 0.9 + 0.12 * hash_unit(x * 1.3, y * 1.3) + 0.08 * hash_unit(x * 9.0, y * 9.0);
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
        let (ix, iy) = (fx as usize, fy as usize);
        let (tx, ty) = (fx - ix as f32, fy - iy as f32);
        let at = |i: usize, j: usize| self.lightmap[j * n + i];
        let top = at(ix, iy) * (1.0 - tx) + at(ix + 1, iy) * tx;
        let bottom = at(ix, iy + 1) * (1.0 - tx) + at(ix + 1, iy + 1) * tx;
        top * (1.0 - ty) + bottom * ty
    }

    fn place_buildings(&mut self, rng: &mut impl Rng) {
        let n = self.roads_x.len() - 1;
        for bi in 0..n {
            for bj in 0..n {
                let x0 = self.roads_x[bi].centre_m + self.roads_x[bi].half_width_m() + SIDEWALK_M;
                let x1 = self.roads_x[bi + 1].centre_m
                    - self.roads_x[bi + 1].half_width_m()
                    - SIDEWALK_M;
                let y0 = self.roads_y[bj].centre_m + self.roads_y[bj].half_width_m() + SIDEWALK_M;
                let y1 = self.roads_y[bj + 1].centre_m
                    - self.roads_y[bj + 1].half_width_m()
                    - SIDEWALK_M;
                let tall = rng.random::<f32>() < 0.3;
                // South and north rows run the whole block; west and east rows fill between them.
                let margin = 18.0;
                let rows = [
                    ((x0, y0), (1.0, 0.0), x1 - x0, -FRAC_PI_2),
                    ((x0, y1), (1.0, 0.0), x1 - x0, FRAC_PI_2),
                    ((x0, y0 + margin), (0.0, 1.0), y1 - y0 - 2.0 * margin, PI),
                    ((x1, y0 + margin), (0.0, 1.0), y1 - y0 - 2.0 * margin, 0.0),
                ];
                for (start, along, length, yaw) in rows {
                    let mut s = 0.0;
                    while s < length - 4.0 {
                        let width = rng.random_range(9.0..24.0f32).min(length - s);
                        let depth = rng.random_range(9.0..17.0f32);
                        let height = if tall {
                            rng.random_range(15.0..45.0)
                        } else {
                            rng.random_range(5.0..18.0)
                        };
                        let setback = rng.random_range(0.0..1.5f32);
                        // Facing outward: the front is `depth/2 + setback` inside the block edge.
                        let inward = -(depth / 2.0 + setback);
                        let (fx, fy) = (yaw.cos(), yaw.sin());
                        let cx = start.0 + along.0 * (s + width / 2.0) + fx * inward;
                        let cy = start.1 + along.1 * (s + width / 2.0) + fy * inward;
                        let pose = Pose2 { x: cx, y: cy, yaw };
                        self.objects.push(build::building(pose, width, depth, height, facade(rng)));
                        s += width
                            + if rng.random::<f32>() < 0.25 {
                                rng.random_range(1.0..4.0)
                            } else {
                                0.0
                            };
                    }
                }
            }
        }
        // Walls across every road end close the view at the edge of the map.
        let e = self.extent_m;
        for r in self.roads_x.clone() {
            for (y, yaw) in [(-12.0, FRAC_PI_2), (e + 12.0, -FRAC_PI_2)] {
                let pose = Pose2 { x: r.centre_m, y, yaw };
                self.objects.push(build::building(
                    pose,
                    2.0 * r.half_width_m() + 30.0,
                    10.0,
                    30.0,
                    facade(rng),
                ));
            }
        }
        for r in self.roads_y.clone() {
            for (x, yaw) in [(-12.0, 0.0), (e + 12.0, PI)] {
                let pose = Pose2 { x, y: r.centre_m, yaw };
                self.objects.push(build::building(
                    pose,
                    2.0 * r.half_width_m() + 30.0,
                    10.0,
                    30.0,
                    facade(rng),
                ));
            }
        }
    }

    /// Street lamps along both kerbs of every road, every ~28 m outside intersections.
    fn place_lamps(&mut self, rng: &mut impl Rng) -> Vec<V3> {
        let mut heads = Vec::new();
        let e = self.extent_m;
        for (vertical, roads) in [(true, self.roads_x.clone()), (false, self.roads_y.clone())] {
            for r in roads {
                for side in [-1.0f32, 1.0] {
                    let mut s = rng.random_range(0.0..28.0f32);
                    while s < e {
                        let other = if vertical { &self.zones_y } else { &self.zones_x };
                        if !matches!(Self::zone(other, s), Zone::Road(_)) {
                            let off = r.centre_m + side * (r.half_width_m() + 0.6);
                            let (x, y) = if vertical { (off, s) } else { (s, off) };
                            // The arm reaches over the road: towards the centre line.
                            let yaw = if vertical {
                                if side > 0.0 { PI } else { 0.0 }
                            } else if side > 0.0 {
                                -FRAC_PI_2
                            } else {
                                FRAC_PI_2
                            };
                            let lamp = build::street_lamp(x, y, yaw);
                            let pose = lamp.position_at(0.0);
                            heads.push(pose.apply(V3::new(1.45, 0.0, LAMP_HEIGHT_M)));
                            self.objects.push(lamp);
                        }
                        s += 28.0;
                    }
                }
            }
        }
        heads
    }

    fn bake_lightmap(&mut self, lamps: &[V3]) {
        let n = (self.extent_m / LIGHTMAP_RES_M) as usize + 2;
        let mut map = vec![0.0f32; n * n];
        let h = LAMP_HEIGHT_M;
        let reach = 30.0f32;
        for l in lamps {
            let (i0, i1) = (
                ((l.x - reach) / LIGHTMAP_RES_M).max(0.0) as usize,
                (((l.x + reach) / LIGHTMAP_RES_M) as usize).min(n - 1),
            );
            let (j0, j1) = (
                ((l.y - reach) / LIGHTMAP_RES_M).max(0.0) as usize,
                (((l.y + reach) / LIGHTMAP_RES_M) as usize).min(n - 1),
            );
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let (dx, dy) =
                        (i as f32 * LIGHTMAP_RES_M - l.x, j as f32 * LIGHTMAP_RES_M - l.y);
                    let r2 = dx * dx + dy * dy + h * h;
                    // Lambert: E = I·cosθ/r² with cosθ = h/r; scaled so E(0) = LAMP_PEAK.
                    map[j * n + i] += LAMP_PEAK * h * h * h / (r2 * r2.sqrt());
                }
            }
        }
        self.lightmap = map;
        self.lightmap_n = n;
    }

    /// Signs at intersection approaches (on the right, facing oncoming traffic), each with
    /// probability `p`; returns the approaches left empty with their draws.
    fn place_signs(&mut self, p: f32, rng: &mut impl Rng) -> Vec<(usize, usize, f32, f32, f32)> {
        let mut empty = Vec::new();
        for (i, j, dx, dy) in self.approaches() {
            let draw = rng.random::<f32>();
            if draw > p {
                empty.push((i, j, dx, dy, draw));
                continue;
            }
            self.place_sign(i, j, dx, dy, SignPlace::Intersection, rng);
        }
        empty
    }

    /// Every intersection approach `(i, j, dx, dy)`: intersection `(i, j)` reached along
    /// `(dx, dy)`, in the order the sign draws follow.
    fn approaches(&self) -> Vec<(usize, usize, f32, f32)> {
        let n = self.roads_per_axis();
        let directions = [(1.0f32, 0.0f32), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)];
        (0..n)
            .flat_map(|i| (0..n).flat_map(move |j| directions.map(|(dx, dy)| (i, j, dx, dy))))
            .collect()
    }

    /// `mean` signs per intersection approach on average (its integer part on each, one more
    /// with the fractional part as probability), along the block before the approach.
    fn place_mid_block_signs(&mut self, mean: f32, rng: &mut impl Rng) {
        for (i, j, dx, dy) in self.approaches() {
            let extra = u32::from(rng.random::<f32>() < mean.fract());
            for _ in 0..mean.trunc() as u32 + extra {
                self.place_sign(i, j, dx, dy, SignPlace::MidBlock, rng);
            }
        }
    }

    /// A sign on its pole at the approach to intersection `(i, j)` along `(dx, dy)`.
    fn place_sign(
        &mut self,
        i: usize,
        j: usize,
        dx: f32,
        dy: f32,
        place: SignPlace,
        rng: &mut impl Rng,
    ) {
        let (cx, cy) = self.intersection(i, j);
        // Approaching along (dx, dy): the crossing road's half width lies ahead.
        let (hw_cross, hw_own) = if dx != 0.0 {
            (self.roads_x[i].half_width_m(), self.roads_y[j].half_width_m())
        } else {
            (self.roads_y[j].half_width_m(), self.roads_x[i].half_width_m())
        };
        let (rx, ry) = (dy, -dx); // right of travel
        // Blocks are at least 45 m long, so 40 m back is still before the previous crossing.
        let back = hw_cross
            + match place {
                SignPlace::Intersection => rng.random_range(1.0..6.0),
                SignPlace::MidBlock => rng.random_range(8.0..40.0),
            };
        let x = cx - dx * back + rx * (hw_own + 1.0);
        let y = cy - dy * back + ry * (hw_own + 1.0);
        let yaw = (-dy).atan2(-dx);
        let kind = rng.random_range(0..4u8);
        self.objects.push(build::pole(x, y, 2.9));
        let height = rng.random_range(2.2..2.6);
        let fwd = 0.06;
        self.objects.push(build::sign_plate(x - dx * fwd, y - dy * fwd, yaw, height, kind));
    }

    fn place_vehicles(&mut self, config: &CityConfig, rng: &mut impl Rng) {
        let e = self.extent_m;
        for (vertical, roads) in [(true, self.roads_x.clone()), (false, self.roads_y.clone())] {
            for r in roads {
                for dir in [1.0f32, -1.0] {
                    // Right-hand traffic: lanes lie right of the direction of travel.
                    let right = if vertical { dir } else { -dir };
                    // Moving traffic in every lane.
                    for k in 0..r.lanes_per_dir {
                        let count = (config.vehicles_per_100m * e / 100.0
                            * rng.random_range(0.5..1.5f32))
                        .round() as usize;
                        for _ in 0..count {
                            let off = r.centre_m + right * r.lane_offset_m(k);
                            let (origin, d) = if vertical {
                                ((off, if dir > 0.0 { -20.0 } else { e + 20.0 }), (0.0, dir))
                            } else {
                                ((if dir > 0.0 { -20.0 } else { e + 20.0 }, off), (dir, 0.0))
                            };
                            let motion = Motion::Lane {
                                origin,
                                dir: d,
                                length_m: e + 40.0,
                                s0_m: rng.random_range(0.0..e + 40.0),
                                speed_mps: rng.random_range(5.0..14.0),
                            };
                            self.objects.push(random_vehicle(rng, motion));
                        }
                    }
                    // Parked cars in the parking strip, outside intersections.
                    let off =
                        r.centre_m + right * (f32::from(r.lanes_per_dir) * LANE_WIDTH_M + 1.1);
                    let mut s = rng.random_range(0.0..8.0f32);
                    while s < e {
                        let other = if vertical { &self.zones_y } else { &self.zones_x };
                        let clear = [s - 3.5, s, s + 3.5]
                            .iter()
                            .all(|&v| Self::zone(other, v) == Zone::Block);
                        if clear && rng.random::<f32>() < 0.35 {
                            let (x, y) = if vertical { (off, s) } else { (s, off) };
                            let yaw = if vertical {
                                if dir > 0.0 { FRAC_PI_2 } else { -FRAC_PI_2 }
                            } else if dir > 0.0 {
                                0.0
                            } else {
                                PI
                            };
                            let length = rng.random_range(3.9..4.9);
                            let paint = PAINTS[rng.random_range(0..PAINTS.len())];
                            self.objects.push(build::vehicle(
                                length,
                                1.8,
                                1.5,
                                paint,
                                Motion::Static(Pose2 { x, y, yaw }),
                            ));
                        }
                        s += 6.5;
                    }
                }
            }
        }
    }

    fn place_walkers(&mut self, config: &CityConfig, rng: &mut impl Rng) {
        let n = self.roads_per_axis();
        // Along sidewalks: each walker paces one side of a block.
        for i in 0..n {
            for (vertical, road) in [(true, self.roads_x[i]), (false, self.roads_y[i])] {
                let other = if vertical { self.roads_y.clone() } else { self.roads_x.clone() };
                for b in 0..other.len() - 1 {
                    let s0 = other[b].centre_m + other[b].half_width_m() + 1.0;
                    let s1 = other[b + 1].centre_m - other[b + 1].half_width_m() - 1.0;
                    for side in [-1.0f32, 1.0] {
                        let count = (config.walkers_per_edge * rng.random_range(0.0..2.0f32))
                            .round() as usize;
                        for _ in 0..count {
                            let off = road.centre_m
                                + side
                                    * (road.half_width_m()
                                        + rng.random_range(0.8..SIDEWALK_M - 0.5));
                            let (a, b2) = if vertical {
                                ((off, s0), (off, s1))
                            } else {
                                ((s0, off), (s1, off))
                            };
                            let motion = Motion::PingPong {
                                a,
                                b: b2,
                                s0_m: rng.random_range(0.0..200.0),
                                speed_mps: rng.random_range(0.9..1.7),
                            };
                            self.objects.push(random_walker(rng, motion));
                        }
                    }
                }
            }
        }
        // Across roads at zebra crossings.
        for i in 0..n {
            for j in 0..n {
                if rng.random::<f32>() > config.crossing_walker_probability {
                    continue;
                }
                let (cx, cy) = self.intersection(i, j);
                let across_x = rng.random::<bool>();
                let (hw_walk_road, hw_other) = if across_x {
                    (self.roads_x[i].half_width_m(), self.roads_y[j].half_width_m())
                } else {
                    (self.roads_y[j].half_width_m(), self.roads_x[i].half_width_m())
                };
                let side = if rng.random::<bool>() { 1.0 } else { -1.0 };
                let lateral = side * (hw_other + 1.6);
                let (a, b) = if across_x {
                    (
                        (cx - hw_walk_road - 1.5, cy + lateral),
                        (cx + hw_walk_road + 1.5, cy + lateral),
                    )
                } else {
                    (
                        (cx + lateral, cy - hw_walk_road - 1.5),
                        (cx + lateral, cy + hw_walk_road + 1.5),
                    )
                };
                let motion = Motion::PingPong {
                    a,
                    b,
                    s0_m: rng.random_range(0.0..100.0),
                    speed_mps: rng.random_range(0.9..1.6),
                };
                self.objects.push(random_walker(rng, motion));
            }
        }
    }
}

fn zone_table(roads: &[Road], extent: f32) -> Vec<Zone> {
    let cells = (extent / ZONE_RES_M) as usize + 1;
    (0..cells)
        .map(|c| {
            let v = (c as f32 + 0.5) * ZONE_RES_M;
            for (i, r) in roads.iter().enumerate() {
                let d = (v - r.centre_m).abs();
                if d <= r.half_width_m() {
                    return Zone::Road(i as u16);
                }
                if d <= r.half_width_m() + SIDEWALK_M {
                    return Zone::Walk;
                }
            }
            Zone::Block
        })
        .collect()
}

fn asphalt(grain: f32) -> Rgb {
    let v = 0.085 * grain;
    [v, v, v * 1.04]
}

const PAINT: f32 = 0.62;

fn zebra(offset: f32, grain: f32, road: Road) -> Rgb {
    // Stripes 0.5 m wide every metre across the drivable width.
    if offset.abs() < road.half_width_m() - 0.3 && modulo(offset, 1.0) < 0.5 {
        [PAINT * grain; 3]
    } else {
        asphalt(grain)
    }
}

fn lane_marking(offset: f32, along: f32, road: Road, grain: f32) -> Rgb {
    let a = offset.abs();
    let lanes_edge = f32::from(road.lanes_per_dir) * LANE_WIDTH_M;
    let dashed = modulo(along, 9.0) < 3.0;
    let centre = a < 0.1;
    let divider = road.lanes_per_dir > 1 && (a - LANE_WIDTH_M).abs() < 0.07 && dashed;
    let edge = (a - lanes_edge).abs() < 0.07;
    if centre || divider || edge { [PAINT * grain; 3] } else { asphalt(grain) }
}

/// `floor(x)` as an integer without a library call (baseline x86-64 has no rounding
/// instruction for `f32::floor`, and this runs per pixel). Valid for |x| < 2³¹.
#[inline(always)]
pub fn fast_floor(x: f32) -> i32 {
    let i = x as i32;
    if (i as f32) > x { i - 1 } else { i }
}

/// `x mod m` in `[0, m)` for `m > 0`, without a library call.
#[inline(always)]
fn modulo(x: f32, m: f32) -> f32 {
    x - fast_floor(x / m) as f32 * m
}

/// A uniform value in [0, 1) from the integer cell of `(x, y)`: texture without storage.
pub fn hash_unit(x: f32, y: f32) -> f32 {
    let (ix, iy) = (fast_floor(x) as u32, fast_floor(y) as u32);
    let mut h = ix.wrapping_mul(0x8da6_b343) ^ iy.wrapping_mul(0xd816_3841);
    h ^= h >> 13;
    h = h.wrapping_mul(0x5bd1_e995);
    h ^= h >> 15;
    (h >> 8) as f32 / (1u32 << 24) as f32
}

const PAINTS: [Rgb; 9] = [
    [0.72, 0.72, 0.70],  // white
    [0.04, 0.04, 0.045], // black
    [0.45, 0.46, 0.47],  // silver
    [0.22, 0.22, 0.23],  // grey
    [0.50, 0.05, 0.04],  // red
    [0.05, 0.10, 0.40],  // blue
    [0.06, 0.22, 0.10],  // green
    [0.62, 0.48, 0.08],  // yellow
    [0.30, 0.18, 0.10],  // brown
];

fn random_vehicle(rng: &mut impl Rng, motion: Motion) -> Object {
    let paint = PAINTS[rng.random_range(0..PAINTS.len())];
    let kind = rng.random::<f32>();
    if kind < 0.72 {
        build::vehicle(
            rng.random_range(3.9..4.9),
            rng.random_range(1.7..1.9),
            rng.random_range(1.4..1.6),
            paint,
            motion,
        )
    } else if kind < 0.9 {
        build::vehicle(
            rng.random_range(4.8..5.4),
            rng.random_range(1.9..2.0),
            rng.random_range(1.9..2.3),
            paint,
            motion,
        )
    } else {
        build::vehicle(rng.random_range(6.5..9.0), 2.4, rng.random_range(2.8..3.4), paint, motion)
    }
}

fn random_walker(rng: &mut impl Rng, motion: Motion) -> Object {
    const CLOTHES: [Rgb; 8] = [
        [0.05, 0.05, 0.06],
        [0.55, 0.08, 0.08],
        [0.08, 0.15, 0.45],
        [0.6, 0.6, 0.58],
        [0.12, 0.3, 0.12],
        [0.55, 0.45, 0.2],
        [0.35, 0.35, 0.38],
        [0.6, 0.3, 0.1],
    ];
    const SKIN: [Rgb; 4] =
        [[0.6, 0.45, 0.36], [0.45, 0.32, 0.24], [0.3, 0.2, 0.15], [0.55, 0.42, 0.3]];
    let top = CLOTHES[rng.random_range(0..CLOTHES.len())];
    let trousers = CLOTHES[rng.random_range(0..CLOTHES.len())];
    let skin = SKIN[rng.random_range(0..SKIN.len())];
    build::walker(rng.random_range(1.5..1.95), top, trousers, skin, motion)
}

fn facade(rng: &mut impl Rng) -> Material {
    const WALLS: [Rgb; 6] = [
        [0.55, 0.48, 0.38],
        [0.40, 0.40, 0.42],
        [0.42, 0.20, 0.14],
        [0.68, 0.67, 0.64],
        [0.16, 0.17, 0.19],
        [0.50, 0.36, 0.25],
    ];
    Material::Facade {
        wall: WALLS[rng.random_range(0..WALLS.len())],
        glass: [0.07, 0.09, 0.11],
        pitch_u_m: rng.random_range(2.8..4.2),
        pitch_v_m: rng.random_range(3.0..3.6),
        lit_seed: rng.random(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use joca_core::{Class, SeedStreams};

    fn city() -> City {
        City::generate(&CityConfig::default(), &mut SeedStreams::new(5).stream("city"))
    }

    #[test]
    fn roads_and_zones_are_consistent() {
        let c = city();
        assert_eq!(c.roads_x.len(), 9);
        for w in c.roads_x.windows(2) {
            let gap = w[1].centre_m - w[1].half_width_m() - (w[0].centre_m + w[0].half_width_m());
            assert!((2.0 * SIDEWALK_M + 45.0..=2.0 * SIDEWALK_M + 75.0).contains(&gap), "{gap}");
        }
        // The centre line of a road is asphalt or paint; a block interior is green.
        let r = c.roads_x[3];
        let b = c.roads_y[2].centre_m + c.roads_y[2].half_width_m() + SIDEWALK_M + 10.0;
        let g = c.ground_albedo(r.centre_m + 1.7, b);
        assert!(g[0] < 0.15 && (g[0] - g[2]).abs() < 0.02, "{g:?}");
        let inside = c.ground_albedo(r.centre_m + r.half_width_m() + SIDEWALK_M + 20.0, b);
        assert!(inside[1] > inside[0], "{inside:?}");
    }

    #[test]
    fn city_has_every_class_and_lamp_light() {
        let c = city();
        for class in Class::ALL {
            let count = c.objects.iter().filter(|o| o.class == Some(class)).count();
            assert!(count > 20, "{class:?}: {count}");
        }
        let moving = c.objects.iter().filter(|o| !o.motion.is_static()).count();
        assert!(moving > 100, "{moving}");
        // Somewhere along a kerb there is a lamp pool of about the configured peak.
        let r = c.roads_x[4];
        let peak = (0..(c.extent_m as usize))
            .map(|y| c.lamp_irradiance(r.centre_m + r.half_width_m() + 0.6 + 1.45, y as f32))
            .fold(0.0f32, f32::max);
        assert!((0.8 * LAMP_PEAK..=2.0 * LAMP_PEAK).contains(&peak), "{peak}");
    }

    #[test]
    fn generation_is_deterministic_per_seed() {
        let a = city();
        let b = city();
        assert_eq!(a.objects, b.objects);
        let other = City::generate(&CityConfig::default(), &mut SeedStreams::new(6).stream("city"));
        assert_ne!(a.objects.len(), 0);
        assert_ne!(a.objects, other.objects);
    }

    fn count(c: &City, class: Class) -> usize {
        c.objects.iter().filter(|o| o.class == Some(class)).count()
    }

    #[test]
    fn walker_density_scales_walkers_and_nothing_else() {
        let base = city();
        let dense = City::generate(
            &CityConfig::default().with_walker_density(3.0),
            &mut SeedStreams::new(5).stream("city"),
        );
        let (w1, w3) = (count(&base, Class::Walker), count(&dense, Class::Walker));
        // Sidewalk walkers are Σ round(3 · 1.2 · U(0, 2)) per edge against Σ round(1.2 · U(0, 2));
        // crossings go from 35 % to every intersection.
        let ratio = w3 as f64 / w1 as f64;
        assert!((2.5..3.5).contains(&ratio), "{w1} → {w3}");
        assert_eq!(count(&base, Class::Vehicle), count(&dense, Class::Vehicle));
        assert_eq!(base.roads_x, dense.roads_x);
        // Density 1 is the default city, drawn identically.
        let same = City::generate(
            &CityConfig::default().with_walker_density(1.0),
            &mut SeedStreams::new(5).stream("city"),
        );
        assert_eq!(same.objects, base.objects);
    }

    #[test]
    fn sign_density_adds_signs_to_the_same_town() {
        let base = city();
        let dense = City::generate(
            &CityConfig::default().with_sign_density(2.0),
            &mut SeedStreams::new(5).stream("city"),
        );
        let (s1, s2) = (count(&base, Class::TrafficSign), count(&dense, Class::TrafficSign));
        // Each approach has a sign with probability 0.45, then 0.9: twice as many, within the
        // binomial spread of a town's approaches.
        let ratio = s2 as f64 / s1 as f64;
        assert!((1.6..2.4).contains(&ratio), "{s1} → {s2}");
        // Everything drawn before is the same town: the extra signs (and poles) come last.
        assert_eq!(dense.objects[..base.objects.len()], base.objects[..]);
        assert_eq!(dense.objects.len() - base.objects.len(), 2 * (s2 - s1));
        // A sign on every approach at 1/0.45 times the default; beyond it the rest stand along
        // the blocks: 5 × 0.45 = 2.25 signs per approach.
        let full = City::generate(
            &CityConfig::default().with_sign_density(1.0 / 0.45),
            &mut SeedStreams::new(5).stream("city"),
        );
        let approaches = 4 * full.roads_per_axis().pow(2);
        assert_eq!(count(&full, Class::TrafficSign), approaches);
        let denser = City::generate(
            &CityConfig::default().with_sign_density(5.0),
            &mut SeedStreams::new(5).stream("city"),
        );
        assert_eq!(denser.objects[..full.objects.len()], full.objects[..]);
        let per_approach = count(&denser, Class::TrafficSign) as f64 / approaches as f64;
        assert!((2.1..2.4).contains(&per_approach), "{per_approach}");
    }
}
