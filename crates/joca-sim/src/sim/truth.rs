//! Ground truth: the reference objects every design is scored against, and the 180° count.
//!
//! Reference objects do not depend on the design's pixel count. They come from an id pass
//! rendered on a reference grid with a fixed angular sampling ([`REFERENCE_PX_PER_RAD`]) over
//! the design's field of view, so two designs with the same lens field of view get the same
//! objects whatever their resolution, and an object too small for a design to resolve stays an
//! object: a miss when undetected. Boxes are the reference grid's tight boxes mapped to the
//! design's pixel coordinates (sub-pixel for small designs).

use super::{Episode, Simulator, pool};
use crate::geometry::{OrientedBox, V3};
use crate::render::{self, CameraFrame};
use joca_core::{Annotation, BBox, PinholeCamera};

/// Angular sampling of the reference grid at the image centre, pixels per radian (2 mrad a
/// pixel: a car 1.8 m wide at 100 m spans 9 pixels, a walker 0.5 m wide at 50 m 5 pixels).
pub const REFERENCE_PX_PER_RAD: f64 = 500.0;
/// Longest side of the reference grid, pixels; wider fields of view are sampled more coarsely
/// (still independent of the design's resolution).
pub const REFERENCE_MAX_PX: usize = 2048;

/// The reference grid of `camera`: a camera with the same field of view, principal point and
/// mount sampled at [`REFERENCE_PX_PER_RAD`], and the reference pixels per design pixel
/// (horizontal, vertical).
pub fn reference_camera(camera: &PinholeCamera) -> (PinholeCamera, f64, f64) {
    let (mut kx, mut ky) =
        (REFERENCE_PX_PER_RAD / camera.fx_px, REFERENCE_PX_PER_RAD / camera.fy_px);
    let side = |k: f64, n: usize| (n as f64 * k - 1e-9).ceil().max(1.0) as usize;
    let longest = side(kx, camera.width_px).max(side(ky, camera.height_px));
    if longest > REFERENCE_MAX_PX {
        let s = REFERENCE_MAX_PX as f64 / longest as f64;
        kx *= s;
        ky *= s;
    }
    let reference = PinholeCamera {
        width_px: side(kx, camera.width_px).min(REFERENCE_MAX_PX),
        height_px: side(ky, camera.height_px).min(REFERENCE_MAX_PX),
        fx_px: camera.fx_px * kx,
        fy_px: camera.fy_px * ky,
        cx_px: camera.cx_px * kx,
        cy_px: camera.cy_px * ky,
        mount_m: camera.mount_m,
        lens: None,
    };
    (reference, kx, ky)
}

impl Simulator {
    /// The reference objects and ignore regions that `camera` has at `time_s` of episode
    /// `episode` (what [`joca_core::FrameSource::render`] returns with the frame).
    pub fn ground_truth(
        &self,
        camera: &PinholeCamera,
        episode: u64,
        time_s: f64,
    ) -> (Vec<Annotation>, Vec<Annotation>) {
        self.annotations(&self.episode(episode), camera, time_s)
    }

    /// Ground truth at `time_s`: the reference objects (classed objects in the field of view
    /// within their class's range and at least the minimum share visible, at any size in
    /// pixels) and, second, the ignore regions (classed objects in view that fail those rules).
    pub(super) fn annotations(
        &self,
        episode: &Episode,
        camera: &PinholeCamera,
        time_s: f64,
    ) -> (Vec<Annotation>, Vec<Annotation>) {
        let rules = self.config.visibility;
        let (reference, kx, ky) = reference_camera(camera);
        let (rw, rh) = (reference.width_px, reference.height_px);
        let mut grid = pool::take(rw, rh, self.city.objects.len(), false);
        render::render_ids(&self.city, &self.view(episode, &reference, time_s), &mut grid);
        // Per object id: visible pixels and tight box, indexed by id (no hashing per pixel of a
        // grid of ~1.5 Mpixel).
        let mut stats: Vec<(u32, [usize; 4])> =
            vec![(0, [usize::MAX, usize::MAX, 0, 0]); self.city.objects.len() + 1];
        for y in 0..rh {
            for (x, &id) in grid.id[y * rw..(y + 1) * rw].iter().enumerate() {
                if id == 0 {
                    continue;
                }
                let e = &mut stats[id as usize];
                e.0 += 1;
                e.1 = [e.1[0].min(x), e.1[1].min(y), e.1[2].max(x), e.1[3].max(y)];
            }
        }
        let cam = CameraFrame::new(camera, episode.ego.pose_at(time_s));
        let (w, h) = (camera.width_px as f64, camera.height_px as f64);
        let to_design = |v: usize, k: f64, max: f64| ((v as f64 / k).min(max)) as f32;
        // In id order, as the ground truth always was.
        let out: Vec<(bool, Annotation)> = stats
            .into_iter()
            .enumerate()
            .filter(|(_, (count, _))| *count > 0)
            .filter_map(|(id, (count, b))| {
                let object = &self.city.objects[id - 1];
                let class = object.class?;
                let bbox = BBox::new(
                    to_design(b[0], kx, w),
                    to_design(b[1], ky, h),
                    to_design(b[2] + 1, kx, w),
                    to_design(b[3] + 1, ky, h),
                );
                // The reference grid may reach a fraction of a design pixel past the image's
                // right and bottom edges: an object seen only there is not in the design's view.
                if bbox.width() <= 0.0 || bbox.height() <= 0.0 {
                    return None;
                }
                let pos = object.position_at(time_s);
                let (dx, dy) = (pos.x - cam.origin.x, pos.y - cam.origin.y);
                let distance = (dx * dx + dy * dy).sqrt();
                let coverage = grid.coverage[id].max(count);
                let reference = distance <= rules.range_m(class)
                    && count as f32 >= rules.min_visible_fraction * coverage as f32;
                Some((reference, Annotation::at_distance(bbox, class, distance)))
            })
            .collect();
        pool::give([grid]);
        let (boxes, ignore): (Vec<_>, Vec<_>) = out.into_iter().partition(|(r, _)| *r);
        let strip = |v: Vec<(bool, Annotation)>| v.into_iter().map(|(_, a)| a).collect();
        (strip(boxes), strip(ignore))
    }

    /// Objects visible within a 180° horizontal field around the heading, from an eye at the
    /// vehicle centre 1.5 m up: within range, and with at least the minimum share of sample
    /// points on the object reachable by an unoccluded ray. Independent of the camera design.
    pub fn visible_180(&self, episode: &Episode, time_s: f64) -> u32 {
        let rules = self.config.visibility;
        let ego = episode.ego.pose_at(time_s);
        let eye = V3::new(ego.x, ego.y, 1.5);
        let (fx, fy) = (ego.yaw.cos(), ego.yaw.sin());
        struct Occ {
            owner: usize,
            bearing: f32,
            half_angle: f32,
            near: f32,
            boxes: Vec<OrientedBox>,
        }
        let reach = rules.farthest_m() + 30.0;
        let mut occluders = Vec::new();
        for (index, object) in self.city.objects.iter().enumerate() {
            let p = object.position_at(time_s);
            let (dx, dy) = (p.x - eye.x, p.y - eye.y);
            let d = (dx * dx + dy * dy).sqrt();
            if d - object.radius_m > reach {
                continue;
            }
            let half_angle = if d > object.radius_m {
                (object.radius_m / d).asin()
            } else {
                std::f32::consts::PI
            };
            occluders.push(Occ {
                owner: index,
                bearing: dy.atan2(dx),
                half_angle,
                near: d - object.radius_m,
                boxes: object.boxes_at(time_s).map(|(b, _)| b).collect(),
            });
        }
        let mut count = 0;
        for occ in occluders.iter() {
            let object = &self.city.objects[occ.owner];
            let Some(class) = object.class else {
                continue;
            };
            let p = object.position_at(time_s);
            let (dx, dy) = (p.x - eye.x, p.y - eye.y);
            let d = (dx * dx + dy * dy).sqrt();
            if d > rules.range_m(class) || dx * fx + dy * fy <= 0.0 {
                continue;
            }
            let blockers: Vec<&Occ> = occluders
                .iter()
                .filter(|o| {
                    o.owner != occ.owner
                        && o.near < d
                        && angle_diff(o.bearing, occ.bearing).abs() < o.half_angle + occ.half_angle
                })
                .collect();
            let samples = sample_points(&occ.boxes);
            let free = samples
                .iter()
                .filter(|&&s| {
                    let v = s - eye;
                    let len = v.norm();
                    let dir = v * (1.0 / len);
                    !blockers
                        .iter()
                        .any(|o| o.boxes.iter().any(|b| b.ray_hit(eye, dir, len - 0.05).is_some()))
                })
                .count();
            if free as f32 >= rules.min_visible_fraction * samples.len() as f32 && free > 0 {
                count += 1;
            }
        }
        count
    }
}

fn angle_diff(a: f32, b: f32) -> f32 {
    let d = (a - b).rem_euclid(std::f32::consts::TAU);
    if d > std::f32::consts::PI { d - std::f32::consts::TAU } else { d }
}

/// Sample points on an object: each part's centre and, for its largest part, the eight corners
/// pulled 20 % towards the centre.
fn sample_points(boxes: &[OrientedBox]) -> Vec<V3> {
    let mut points: Vec<V3> = boxes.iter().map(|b| b.centre).collect();
    if let Some(big) = boxes.iter().max_by(|a, b| {
        (a.half.x * a.half.y * a.half.z).total_cmp(&(b.half.x * b.half.y * b.half.z))
    }) {
        let (f, l) = big.axes();
        for sx in [-0.8f32, 0.8] {
            for sy in [-0.8f32, 0.8] {
                for sz in [-0.8f32, 0.8] {
                    points.push(
                        big.centre
                            + f * (sx * big.half.x)
                            + l * (sy * big.half.y)
                            + V3::new(0.0, 0.0, sz * big.half.z),
                    );
                }
            }
        }
    }
    points
}
