//! The ego vehicle: a route through the city's intersections and a speed profile that keeps
//! changing between 0 and a maximum.
//!
//! The route is a chain of straight lane segments and quarter-circle turns, chosen at random at
//! each intersection (straight ahead twice as often as either turn, never a U-turn), staying two
//! blocks inside the map. The speed follows targets redrawn uniformly in `[0, v_max]` every
//! 2–6 s, approached at up to 2.5 m/s², and is integrated once at episode creation, so the pose
//! at any time is a table look-up plus exact path geometry (yaw included).

use crate::city::City;
use crate::geometry::Pose2;
use rand::Rng;
use std::f32::consts::FRAC_PI_2;

/// Time step of the integrated speed profile, seconds.
const PROFILE_DT_S: f64 = 0.01;
/// Largest acceleration and deceleration, m/s².
const MAX_ACCEL: f64 = 2.5;
/// When a drive through a tunnel passes its mouth, seconds after the episode's start: within
/// the test's frames (they start at 1 s), after a few frames of AverageAE's settling.
pub const MOUTH_AT_S: (f64, f64) = (1.3, 2.7);

#[derive(Debug, Clone, Copy, PartialEq)]
enum Segment {
    Line { start: (f32, f32), dir: (f32, f32), length: f32 },
    Arc { centre: (f32, f32), radius: f32, start_angle: f32, sweep: f32 },
}

impl Segment {
    fn length(&self) -> f32 {
        match *self {
            Segment::Line { length, .. } => length,
            Segment::Arc { radius, sweep, .. } => radius * sweep.abs(),
        }
    }

    fn at(&self, s: f32) -> Pose2 {
        match *self {
            Segment::Line { start, dir, .. } => {
                Pose2 { x: start.0 + dir.0 * s, y: start.1 + dir.1 * s, yaw: dir.1.atan2(dir.0) }
            }
            Segment::Arc { centre, radius, start_angle, sweep } => {
                let a = start_angle + sweep.signum() * s / radius;
                let yaw = a + sweep.signum() * FRAC_PI_2;
                Pose2 { x: centre.0 + radius * a.cos(), y: centre.1 + radius * a.sin(), yaw }
            }
        }
    }
}

/// The ego vehicle's trajectory over one episode.
#[derive(Debug, Clone, PartialEq)]
pub struct EgoTrajectory {
    segments: Vec<Segment>,
    /// Cumulative path length at the start of each segment.
    starts: Vec<f32>,
    /// Distance travelled at `k · PROFILE_DT_S`.
    distance: Vec<f64>,
}

impl EgoTrajectory {
    /// A route and speed profile for `duration_s` seconds with top speed `v_max_mps`.
    pub fn generate(city: &City, duration_s: f64, v_max_mps: f64, rng: &mut impl Rng) -> Self {
        let distance = speed_profile(duration_s, v_max_mps, rng);
        let needed = distance.last().copied().unwrap_or(0.0) as f32 + 50.0;
        let segments = route(city, needed, rng);
        Self::along(segments, distance)
    }

    /// A trajectory through one of `city`'s tunnels (drawn), passing a mouth between
    /// [`MOUTH_AT_S`] s: entering or leaving it as `drives` says (with `both`, one chance in
    /// two), in either direction; the route starts on the tunnel's road, in its lane, and goes
    /// on at random after the tunnel's block. Returns the trajectory, when it passes the mouth
    /// and whether it enters there; `None` if the city has no tunnels. The draws are the same
    /// for every `drives`, so a fixed direction changes only the drives that went the other way.
    pub fn through_tunnel(
        city: &City,
        duration_s: f64,
        v_max_mps: f64,
        drives: joca_core::tunnels::TunnelDrives,
        rng: &mut impl Rng,
    ) -> Option<(Self, f64, bool)> {
        let tunnels = city.tunnels();
        if tunnels.is_empty() {
            return None;
        }
        let distance = speed_profile(duration_s, v_max_mps, rng);
        let t = tunnels[rng.random_range(0..tunnels.len())];
        let forward = rng.random::<bool>();
        let entering = drives.entering(rng.random::<bool>());
        let crossing_s = rng.random_range(MOUTH_AT_S.0..MOUTH_AT_S.1);
        let to_mouth = distance_in(&distance, crossing_s) as f32;
        let mouth = if forward == entering { t.from_m } else { t.to_m };
        let sign: i32 = if forward { 1 } else { -1 };
        let heading = if t.along_x { (sign, 0) } else { (0, sign) };
        // The intersection behind the tunnel's block, seen in the direction of travel.
        let behind = if forward { t.block } else { t.block + 1 };
        let node = if t.along_x { (behind, t.road) } else { (t.road, behind) };
        let along = mouth - sign as f32 * to_mouth;
        let offset = own_road(city, node, heading).lane_offset_m(0);
        let side = right_of(fdir(heading));
        let across = if t.along_x { side.1 } else { side.0 } * offset;
        let start = t.world(along, across, 0.0);
        let needed = distance.last().copied().unwrap_or(0.0) as f32 + 50.0;
        let segments = extend(city, (node, heading, (start.x, start.y)), needed, rng);
        Some((Self::along(segments, distance), crossing_s, entering))
    }

    fn along(segments: Vec<Segment>, distance: Vec<f64>) -> Self {
        let mut starts = Vec::with_capacity(segments.len());
        let mut total = 0.0;
        for seg in &segments {
            starts.push(total);
            total += seg.length();
        }
        Self { segments, starts, distance }
    }

    /// A scripted trajectory: from `start`, constant speed, constant yaw rate (a straight line
    /// when the yaw rate is 0, else a circle of radius speed/yaw-rate), for `duration_s`.
    pub fn scripted(start: Pose2, speed_mps: f64, yaw_rate_rad_s: f64, duration_s: f64) -> Self {
        let steps = (duration_s / PROFILE_DT_S).ceil() as usize + 2;
        let distance = (0..steps).map(|k| speed_mps * k as f64 * PROFILE_DT_S).collect();
        let (dir, len) =
            ((start.yaw.cos(), start.yaw.sin()), (speed_mps * duration_s) as f32 + 10.0);
        let segment = if yaw_rate_rad_s == 0.0 || speed_mps == 0.0 {
            Segment::Line { start: (start.x, start.y), dir, length: len }
        } else {
            let radius = (speed_mps / yaw_rate_rad_s.abs()) as f32;
            let side = if yaw_rate_rad_s > 0.0 { left_of(dir) } else { right_of(dir) };
            let centre = (start.x + side.0 * radius, start.y + side.1 * radius);
            let start_angle = (start.y - centre.1).atan2(start.x - centre.0);
            let sweep = (len / radius) * yaw_rate_rad_s.signum() as f32;
            Segment::Arc { centre, radius, start_angle, sweep }
        };
        Self { segments: vec![segment], starts: vec![0.0], distance }
    }

    /// Distance travelled since the episode start, metres.
    pub fn distance_at(&self, t_s: f64) -> f64 {
        distance_in(&self.distance, t_s)
    }

    /// Speed at `t_s`, m/s.
    pub fn speed_at(&self, t_s: f64) -> f64 {
        (self.distance_at(t_s + 0.005) - self.distance_at(t_s - 0.005).max(0.0)) / 0.01
    }

    /// Pose of the vehicle centre at `t_s`.
    pub fn pose_at(&self, t_s: f64) -> Pose2 {
        let s = self.distance_at(t_s) as f32;
        let k = self.starts.partition_point(|&start| start <= s).saturating_sub(1);
        self.segments[k].at(s - self.starts[k])
    }
}

/// Distance travelled at `t_s` in a profile sampled every [`PROFILE_DT_S`].
fn distance_in(profile: &[f64], t_s: f64) -> f64 {
    let f = (t_s.max(0.0) / PROFILE_DT_S).min((profile.len() - 1) as f64);
    let i = (f as usize).min(profile.len() - 2);
    let w = f - i as f64;
    profile[i] * (1.0 - w) + profile[i + 1] * w
}

fn speed_profile(duration_s: f64, v_max: f64, rng: &mut impl Rng) -> Vec<f64> {
    let steps = (duration_s / PROFILE_DT_S).ceil() as usize + 2;
    let mut out = Vec::with_capacity(steps);
    let mut v: f64 = rng.random_range(0.0..=v_max);
    let mut target: f64 = rng.random_range(0.0..=v_max);
    let mut until = rng.random_range(2.0..6.0);
    let mut d = 0.0;
    for k in 0..steps {
        let t = k as f64 * PROFILE_DT_S;
        if t >= until {
            target = rng.random_range(0.0..=v_max);
            until = t + rng.random_range(2.0..6.0);
        }
        out.push(d);
        let dv = (target - v).clamp(-MAX_ACCEL * PROFILE_DT_S, MAX_ACCEL * PROFILE_DT_S);
        let v_next = (v + dv).clamp(0.0, v_max);
        d += 0.5 * (v + v_next) * PROFILE_DT_S;
        v = v_next;
    }
    out
}

fn right_of(d: (f32, f32)) -> (f32, f32) {
    (d.1, -d.0)
}

fn left_of(d: (f32, f32)) -> (f32, f32) {
    (-d.1, d.0)
}

fn fdir(h: (i32, i32)) -> (f32, f32) {
    (h.0 as f32, h.1 as f32)
}

/// The road a vehicle at intersection `node` heading `h` drives on.
fn own_road(city: &City, node: (usize, usize), h: (i32, i32)) -> crate::city::Road {
    if h.0 != 0 { city.roads_y[node.1] } else { city.roads_x[node.0] }
}

/// The point `s` metres past intersection `node`'s centre along heading `h`, in the innermost
/// lane.
fn lane_point(city: &City, node: (usize, usize), h: (i32, i32), s: f32) -> (f32, f32) {
    let c = city.intersection(node.0, node.1);
    let d = fdir(h);
    let o = own_road(city, node, h).lane_offset_m(0);
    let r = right_of(d);
    (c.0 + r.0 * o + d.0 * s, c.1 + r.1 * o + d.1 * s)
}

/// The intersections a route may reach: two blocks inside the map's edge.
fn inner(city: &City) -> (usize, usize) {
    (2, city.roads_per_axis() - 3)
}

/// A random route of at least `length` metres in the innermost lane.
fn route(city: &City, length: f32, rng: &mut impl Rng) -> Vec<Segment> {
    let (lo, hi) = inner(city);
    let node = (rng.random_range(lo..=hi), rng.random_range(lo..=hi));
    let dirs = [(1i32, 0i32), (-1, 0), (0, 1), (0, -1)];
    let mut heading = dirs[rng.random_range(0..4)];
    let inside =
        |i: i64, j: i64| i >= lo as i64 && i <= hi as i64 && j >= lo as i64 && j <= hi as i64;
    // Make sure the first step stays inside.
    while !inside(node.0 as i64 + i64::from(heading.0), node.1 as i64 + i64::from(heading.1)) {
        heading = dirs[rng.random_range(0..4)];
    }
    // Start just past the crossing road of the starting node.
    let cross_hw = if heading.0 != 0 {
        city.roads_x[node.0].half_width_m()
    } else {
        city.roads_y[node.1].half_width_m()
    };
    let pos = lane_point(city, node, heading, cross_hw + rng.random_range(2.0..20.0));
    extend(city, (node, heading, pos), length, rng)
}

/// A route of at least `length` metres from `pos`, in the innermost lane of the road from
/// intersection `node` along `heading`: at each intersection ahead, straight on or a turn.
fn extend(
    city: &City,
    (mut node, mut heading, mut pos): ((usize, usize), (i32, i32), (f32, f32)),
    length: f32,
    rng: &mut impl Rng,
) -> Vec<Segment> {
    let (lo, hi) = inner(city);
    let inside =
        |i: i64, j: i64| i >= lo as i64 && i <= hi as i64 && j >= lo as i64 && j <= hi as i64;
    let mut segments = Vec::new();
    let mut total = 0.0;
    while total < length {
        let next = (
            (node.0 as i64 + i64::from(heading.0)) as usize,
            (node.1 as i64 + i64::from(heading.1)) as usize,
        );
        let d = fdir(heading);
        // Options at `next` that keep the following node inside.
        let mut options: Vec<((i32, i32), f32)> = Vec::new();
        for (turn, weight) in [(0, 2.0f32), (1, 1.0), (-1, 1.0)] {
            let h = match turn {
                0 => heading,
                1 => (-heading.1, heading.0), // left
                _ => (heading.1, -heading.0), // right
            };
            if inside(next.0 as i64 + i64::from(h.0), next.1 as i64 + i64::from(h.1)) {
                options.push((h, weight));
            }
        }
        let total_w: f32 = options.iter().map(|o| o.1).sum();
        let mut pick = rng.random_range(0.0..total_w);
        let mut new_heading = options[0].0;
        for (h, w) in &options {
            if pick < *w {
                new_heading = *h;
                break;
            }
            pick -= w;
        }
        if new_heading == heading {
            // Straight through: the line continues to the next node's far side.
            let end = lane_point(city, next, heading, 0.0);
            let len = (end.0 - pos.0) * d.0 + (end.1 - pos.1) * d.1;
            segments.push(Segment::Line { start: pos, dir: d, length: len });
            total += len;
            pos = end;
        } else {
            // Q: where the incoming and outgoing lane lines cross; arc of radius R tangent to both.
            let c = city.intersection(next.0, next.1);
            let d2 = fdir(new_heading);
            let o_in = own_road(city, next, heading).lane_offset_m(0);
            let o_out = own_road(city, next, new_heading).lane_offset_m(0);
            let hw_in = own_road(city, next, heading).half_width_m();
            let hw_out = own_road(city, next, new_heading).half_width_m();
            let left = left_of(d) == d2;
            let r_in = right_of(d);
            let (s_q, radius) = if left {
                (o_out, (hw_out + o_out).min(hw_in + o_in))
            } else {
                (-o_out, (hw_out - o_out).min(hw_in - o_in))
            };
            let q = (c.0 + d.0 * s_q + r_in.0 * o_in, c.1 + d.1 * s_q + r_in.1 * o_in);
            let a = (q.0 - d.0 * radius, q.1 - d.1 * radius);
            let len = (a.0 - pos.0) * d.0 + (a.1 - pos.1) * d.1;
            segments.push(Segment::Line { start: pos, dir: d, length: len.max(0.0) });
            total += len.max(0.0);
            let n_side = if left { left_of(d) } else { r_in };
            let centre = (a.0 + n_side.0 * radius, a.1 + n_side.1 * radius);
            let start_angle = (a.1 - centre.1).atan2(a.0 - centre.0);
            let sweep = if left { FRAC_PI_2 } else { -FRAC_PI_2 };
            let arc = Segment::Arc { centre, radius, start_angle, sweep };
            total += arc.length();
            segments.push(arc);
            pos = (q.0 + d2.0 * radius, q.1 + d2.1 * radius);
            heading = new_heading;
        }
        node = next;
    }
    segments
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::city::CityConfig;
    use joca_core::SeedStreams;

    /// Drives five one-minute episodes through `city` and checks every 10 ms step.
    fn assert_continuous_inside(city: &City, s: &SeedStreams) {
        for e in 0..5 {
            let ego = EgoTrajectory::generate(city, 60.0, 14.0, &mut s.indexed("ego", e));
            let mut prev = ego.pose_at(0.0);
            for k in 1..6000 {
                let t = k as f64 * 0.01;
                let p = ego.pose_at(t);
                let step = ((p.x - prev.x).powi(2) + (p.y - prev.y).powi(2)).sqrt();
                // 14 m/s for 10 ms is 0.14 m; allow rounding.
                assert!(step < 0.2, "episode {e} jump of {step} m at {t}");
                let dyaw = (p.yaw - prev.yaw).sin().abs();
                assert!(dyaw < 0.05, "episode {e} yaw jump {dyaw} at {t}");
                let v = ego.speed_at(t);
                assert!((-1e-6..=14.0 + 1e-6).contains(&v), "{v}");
                prev = p;
            }
            // The route stays inside the map.
            assert!(
                prev.x > 0.0 && prev.x < city.extent_m && prev.y > 0.0 && prev.y < city.extent_m
            );
        }
    }

    #[test]
    fn path_is_continuous_and_speed_stays_in_range() {
        let s = SeedStreams::new(3);
        let city = City::generate(&CityConfig::default(), &mut s.stream("city"));
        assert_continuous_inside(&city, &s);
    }

    #[test]
    fn the_smallest_town_still_has_routes() {
        // Asking for fewer blocks than a route needs (4 once left one intersection to start
        // from and generate() looped forever) gets the smallest town that has routes.
        let s = SeedStreams::new(5);
        for blocks in [0, 4, City::MIN_BLOCKS] {
            let config = CityConfig { blocks, ..CityConfig::default() };
            let city = City::generate(&config, &mut s.stream("city"));
            assert_eq!(city.roads_per_axis(), City::MIN_BLOCKS + 1, "{blocks} blocks asked");
            assert_continuous_inside(&city, &s);
        }
    }
}
