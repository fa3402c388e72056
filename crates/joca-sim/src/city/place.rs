//! Placing the city's objects: buildings, street lamps (and their baked light map), traffic
//! signs, parked and moving vehicles, walkers.

use super::actors::{PAINTS, facade, random_vehicle, random_walker};
use super::*;

impl City {
    pub(super) fn place_buildings(&mut self, rng: &mut impl Rng) {
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
    pub(super) fn place_lamps(&mut self, rng: &mut impl Rng) -> Vec<V3> {
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

    pub(super) fn bake_lightmap(&mut self, lamps: &[V3]) {
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
    pub(super) fn place_signs(
        &mut self,
        p: f32,
        rng: &mut impl Rng,
    ) -> Vec<(usize, usize, f32, f32, f32)> {
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
    pub(super) fn approaches(&self) -> Vec<(usize, usize, f32, f32)> {
        let n = self.roads_per_axis();
        let directions = [(1.0f32, 0.0f32), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)];
        (0..n)
            .flat_map(|i| (0..n).flat_map(move |j| directions.map(|(dx, dy)| (i, j, dx, dy))))
            .collect()
    }

    /// `mean` signs per intersection approach on average (its integer part on each, one more
    /// with the fractional part as probability), along the block before the approach.
    pub(super) fn place_mid_block_signs(&mut self, mean: f32, rng: &mut impl Rng) {
        for (i, j, dx, dy) in self.approaches() {
            let extra = u32::from(rng.random::<f32>() < mean.fract());
            for _ in 0..mean.trunc() as u32 + extra {
                self.place_sign(i, j, dx, dy, SignPlace::MidBlock, rng);
            }
        }
    }

    /// A sign on its pole at the approach to intersection `(i, j)` along `(dx, dy)`.
    pub(super) fn place_sign(
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

    pub(super) fn place_vehicles(&mut self, config: &CityConfig, rng: &mut impl Rng) {
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

    pub(super) fn place_walkers(&mut self, config: &CityConfig, rng: &mut impl Rng) {
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
