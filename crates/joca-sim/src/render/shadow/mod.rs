//! Cast shadows of the sun: whether the ray from a point towards the sun is blocked by a box.
//!
//! The sun is a directional light. Every point whose sun ray meets a box projects, along the sun
//! direction, into the box's projection on the plane perpendicular to it; so boxes are binned by
//! that projection, and a point on an object's face is tested, by an exact slab test of its sun
//! ray, only against the boxes whose projection overlaps the face's (the face's own box never
//! shadows a face the sun lights, and is left out). A face no other box's projection reaches is
//! lit throughout and costs nothing per pixel. On the ground the same test is a polygon: a
//! ground point lies in a box's shadow exactly when it lies in the box's projection along the
//! sun onto the ground (a convex polygon), so the shadow along an image row, whose ground points
//! lie on a line, is a union of intervals found once per row.
//!
//! No depth map, so no resolution-dependent bias, acne or staircase edges. Shadows are hard: the
//! sun's 0.27° radius would soften an edge by under 1 % of its distance from the caster.
//! The static city is binned once per sun direction; moving objects once per rendered instant.

mod bins;
#[cfg(test)]
mod tests;

use crate::geometry::{OrientedBox, V3};
use bins::Bins;
pub(crate) use bins::Polygon;
use std::sync::OnceLock;

/// Side of a cell on the plane perpendicular to the sun, metres.
const PLANE_CELL_M: f32 = 4.0;
/// Side of a cell on the ground, metres.
const GROUND_CELL_M: f32 = 4.0;
/// A sun ray must run this far inside a box to be blocked, metres: points on a box's own
/// sunlit faces (where the ray leaves at once) stay lit despite rounding.
const GRAZE_M: f32 = 1e-3;
/// The lowest sun that casts shadows here: below it shadows grow without bound while the
/// direct light they take away is nearly nil.
pub const MIN_SUN_ELEVATION_RAD: f32 = 0.02;

/// One shadow-casting box, in the form the slab test needs.
#[derive(Debug, Clone, Copy)]
struct Caster {
    centre: V3,
    forward: V3,
    left: V3,
    half: [f32; 3],
    /// The reciprocal of the sun direction in the box's frame (forward, left, up); 0 for a
    /// component under 1e-6 in size (the ray runs parallel to those faces).
    inv: [f32; 3],
    /// The box's eight corners ([`corners`]), for the shadows it casts on faces.
    corners: [V3; 8],
}

impl Caster {
    fn new(b: &OrientedBox, corners: [V3; 8], sun: V3) -> Self {
        let (forward, left) = b.axes();
        let dir = [sun.dot(forward), sun.dot(left), sun.z];
        let inv = dir.map(|d| if d.abs() < 1e-6 { 0.0 } else { 1.0 / d });
        let half = [b.half.x, b.half.y, b.half.z];
        Self { centre: b.centre, forward, left, half, inv, corners }
    }

    /// Whether this is box `b` (the same floats: the same object part at the same instant).
    fn is(&self, b: &OrientedBox) -> bool {
        self.centre == b.centre && self.half == [b.half.x, b.half.y, b.half.z]
    }

    /// The shadow this box casts on `face` (whose normal makes `n_dot_sun` > 0 with the sun
    /// direction `sun`), as a polygon in the face's texture coordinates; `None` where no part of
    /// the box lies on the sun's side of the face's plane. Exact: the part of the box on the
    /// sun's side (the box clipped by the plane) projected along the sun onto the plane.
    fn shadow_on(&self, face: &FacePlane, sun: V3, n_dot_sun: f32) -> Option<Polygon> {
        // A box wholly behind the face's plane casts nothing on it.
        let radius = (self.half[0] * self.half[0]
            + self.half[1] * self.half[1]
            + self.half[2] * self.half[2])
            .sqrt();
        if (self.centre - face.origin).dot(face.n) <= -radius {
            return None;
        }
        let corners = self.corners;
        let d = corners.map(|c| (c - face.origin).dot(face.n));
        if d.iter().all(|&d| d <= GRAZE_M) {
            return None;
        }
        let mut points = [[0.0f32; 2]; bins::MAX_POINTS];
        let mut n = 0;
        let mut add = |x: V3, dist: f32| {
            let on_plane = x - sun * (dist / n_dot_sun) - face.origin;
            points[n] = [on_plane.dot(face.ua), on_plane.dot(face.va)];
            n += 1;
        };
        for (c, &dc) in corners.iter().zip(&d) {
            if dc >= 0.0 {
                add(*c, dc);
            }
        }
        // Where the box's 12 edges cross the plane.
        for a in 0..8usize {
            for bit in 0..3 {
                let b = a | 1 << bit;
                if b != a && (d[a] < 0.0) != (d[b] < 0.0) {
                    let t = d[a] / (d[a] - d[b]);
                    add(corners[a] + (corners[b] - corners[a]) * t, 0.0);
                }
            }
        }
        let polygon = Polygon::hull(&points[..n]);
        polygon.overlaps([0.0, face.size[0], 0.0, face.size[1]]).then_some(polygon)
    }

    /// Whether the sun ray from `p` runs through the box.
    #[inline(always)]
    fn blocks(&self, p: V3) -> bool {
        let r = p - self.centre;
        let o = [r.dot(self.forward), r.dot(self.left), r.z];
        let (mut t0, mut t1) = (0.0f32, f32::INFINITY);
        for ((o, half), inv) in o.into_iter().zip(self.half).zip(self.inv) {
            if inv == 0.0 {
                if o.abs() > half {
                    return false;
                }
            } else {
                let (a, b) = ((-half - o) * inv, (half - o) * inv);
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            }
        }
        t1 > t0 + GRAZE_M
    }
}

/// Boxes binned by their projection along the sun direction.
#[derive(Debug, Clone)]
pub struct Shadows {
    /// Unit vector towards the sun.
    sun: V3,
    /// Two unit vectors spanning the plane perpendicular to the sun.
    e1: V3,
    e2: V3,
    casters: Vec<Caster>,
    /// Each caster's projection on the plane perpendicular to the sun (bounding rectangles).
    plane: Bins,
    /// Each caster's shadow on the ground (bounding rectangles in world x, y) …
    ground: Bins,
    /// … and the shadow itself.
    polygons: Vec<Polygon>,
    /// Per caster and face (5 a box, see [`Shadows::face_shadows_kept`]), the shadows of the
    /// other casters on it, once computed; empty unless made [`Shadows::keeping_faces`].
    faces: Vec<OnceLock<Vec<Polygon>>>,
}

impl Shadows {
    /// The shadows `boxes` cast in sunlight from `sun_dir` (towards the sun, need not be unit),
    /// or `None` where the sun is lower than [`MIN_SUN_ELEVATION_RAD`] or nothing casts.
    pub fn new(boxes: impl IntoIterator<Item = OrientedBox>, sun_dir: [f32; 3]) -> Option<Self> {
        let norm = V3::new(sun_dir[0], sun_dir[1], sun_dir[2]).norm();
        if norm.is_nan() || norm == 0.0 || sun_dir[2] / norm < MIN_SUN_ELEVATION_RAD.sin() {
            return None;
        }
        let sun = V3::new(sun_dir[0] / norm, sun_dir[1] / norm, sun_dir[2] / norm);
        // e1 horizontal (perpendicular to the sun's azimuth), e2 = sun × e1.
        let h = (sun.x * sun.x + sun.y * sun.y).sqrt();
        let e1 =
            if h < 1e-6 { V3::new(1.0, 0.0, 0.0) } else { V3::new(-sun.y / h, sun.x / h, 0.0) };
        let e2 = V3::new(
            sun.y * e1.z - sun.z * e1.y,
            sun.z * e1.x - sun.x * e1.z,
            sun.x * e1.y - sun.y * e1.x,
        );
        let boxes: Vec<OrientedBox> = boxes.into_iter().collect();
        if boxes.is_empty() {
            return None;
        }
        let corners: Vec<[V3; 8]> = boxes.iter().map(corners).collect();
        let plane_rects: Vec<[f32; 4]> =
            corners.iter().map(|c| bounds(c.iter().map(|p| [p.dot(e1), p.dot(e2)]))).collect();
        // A corner at height z falls on the ground z / sun.z sun-lengths away from the sun.
        let on_ground: Vec<[[f32; 2]; 8]> = corners
            .iter()
            .map(|c| {
                c.map(|p| {
                    let t = p.z.max(0.0) / sun.z;
                    [p.x - t * sun.x, p.y - t * sun.y]
                })
            })
            .collect();
        let polygons = on_ground.iter().map(|g| Polygon::hull(g)).collect();
        let ground_rects: Vec<[f32; 4]> =
            on_ground.iter().map(|g| bounds(g.iter().copied())).collect();
        Some(Self {
            sun,
            e1,
            e2,
            casters: boxes.iter().zip(&corners).map(|(b, c)| Caster::new(b, *c, sun)).collect(),
            plane: Bins::new(&plane_rects, PLANE_CELL_M),
            ground: Bins::new(&ground_rects, GROUND_CELL_M),
            polygons,
            faces: Vec::new(),
        })
    }

    /// The same shadows, keeping each face's shadows once computed: for casters that never
    /// move (the static city), whose faces see the same shadows in every frame under one sun.
    #[must_use]
    pub fn keeping_faces(self) -> Self {
        Self { faces: (0..self.casters.len() * 5).map(|_| OnceLock::new()).collect(), ..self }
    }

    /// [`Shadows::face_shadows`] on face `face_index` (0–4) of caster `own`, computed once if
    /// these shadows keep faces and `own` is one of the casters.
    pub(crate) fn face_shadows_kept(
        &self,
        (face, face_index): (&FacePlane, usize),
        own: Option<u32>,
        seen: (&mut Vec<u32>, u32),
        out: &mut Vec<Polygon>,
    ) {
        match own.and_then(|k| self.faces.get(k as usize * 5 + face_index)) {
            Some(kept) => out.extend_from_slice(kept.get_or_init(|| {
                let mut polygons = Vec::new();
                self.face_shadows(face, own, seen, &mut polygons);
                polygons
            })),
            None => self.face_shadows(face, own, seen, out),
        }
    }

    /// Unit vector towards the sun.
    pub fn sun(&self) -> V3 {
        self.sun
    }

    /// Casters binned, over all cells of both grids (a box counts once per cell it reaches).
    pub fn entries(&self) -> usize {
        self.plane.entries() + self.ground.entries()
    }

    /// Whether the sun ray from `p` is blocked by any box.
    pub fn shadowed(&self, p: V3) -> bool {
        self.shadowed_except(p, None)
    }

    /// Whether the sun ray from `p` is blocked by any box but caster `own`.
    #[inline(always)]
    pub(crate) fn shadowed_except(&self, p: V3, own: Option<u32>) -> bool {
        let cell = self.plane.at(p.dot(self.e1), p.dot(self.e2));
        cell.iter().any(|&k| Some(k) != own && self.casters[k as usize].blocks(p))
    }

    /// Which caster box `b` is, if it is one.
    pub(crate) fn caster_of(&self, b: &OrientedBox) -> Option<u32> {
        let cell = self.plane.at(b.centre.dot(self.e1), b.centre.dot(self.e2));
        cell.iter().copied().find(|&k| self.casters[k as usize].is(b))
    }

    /// The shadows that casters other than `own` cast on `face`, as polygons in its texture
    /// coordinates, appended to `out`; `seen` as for [`Shadows::ground_line`].
    pub(crate) fn face_shadows(
        &self,
        face: &FacePlane,
        own: Option<u32>,
        (seen, stamp): (&mut Vec<u32>, u32),
        out: &mut Vec<Polygon>,
    ) {
        let n_dot_sun = face.n.dot(self.sun);
        if n_dot_sun <= 0.0 {
            return;
        }
        let (u, v) = (face.ua * face.size[0], face.va * face.size[1]);
        let corners = [face.origin, face.origin + u, face.origin + u + v, face.origin + v];
        let rect = bounds(corners.iter().map(|p| [p.dot(self.e1), p.dot(self.e2)]));
        self.fit(seen);
        self.plane.any_over(rect, |k| {
            if Some(k) != own && seen[k as usize] != stamp {
                seen[k as usize] = stamp;
                out.extend(self.casters[k as usize].shadow_on(face, self.sun, n_dot_sun));
            }
            false
        });
    }

    /// Makes `seen` one entry per caster, all 0, unless it has that length already.
    fn fit(&self, seen: &mut Vec<u32>) {
        if seen.len() != self.casters.len() {
            seen.clear();
            seen.resize(self.casters.len(), 0);
        }
    }

    /// The stretches of the ground line `origin + s·dir` (z = 0), `s` in `[lo, hi]`, that lie
    /// in shadow, appended to `out` (unsorted, possibly overlapping); `seen` is scratch that
    /// must hold one entry per caster, each below `stamp`, and comes back with the casters met
    /// set to `stamp`.
    pub(crate) fn ground_line(
        &self,
        (origin, dir): ([f32; 2], [f32; 2]),
        (lo, hi): (f32, f32),
        (seen, stamp): (&mut Vec<u32>, u32),
        out: &mut Vec<(f32, f32)>,
    ) {
        self.fit(seen);
        let a = [origin[0] + lo * dir[0], origin[1] + lo * dir[1]];
        let b = [origin[0] + hi * dir[0], origin[1] + hi * dir[1]];
        self.ground.along(a, b, |k| {
            let k = k as usize;
            if seen[k] != stamp {
                seen[k] = stamp;
                if let Some(stretch) = self.polygons[k].clip(origin, dir, lo, hi) {
                    out.push(stretch);
                }
            }
        });
    }

    /// Whether the ground point `(x, y)` lies in shadow (the polygon test of [`ground_line`]
    /// for one point).
    ///
    /// [`ground_line`]: Shadows::ground_line
    pub fn ground_shadowed(&self, x: f32, y: f32) -> bool {
        self.ground.at(x, y).iter().any(|&k| self.polygons[k as usize].contains([x, y]))
    }
}

/// A face of a box as a plane that shadows fall on: its point at texture coordinates `(u, v)`
/// (metres, `0 ≤ u ≤ size[0]`, `0 ≤ v ≤ size[1]`) is `origin + ua·u + va·v`; `n` is its
/// outward normal.
#[derive(Debug, Clone, Copy)]
pub(crate) struct FacePlane {
    pub(crate) origin: V3,
    pub(crate) ua: V3,
    pub(crate) va: V3,
    pub(crate) n: V3,
    pub(crate) size: [f32; 2],
}

/// The eight corners of `b`.
fn corners(b: &OrientedBox) -> [V3; 8] {
    let (f, l) = b.axes();
    let up = V3::new(0.0, 0.0, 1.0);
    std::array::from_fn(|corner| {
        let s = |bit: usize| if corner >> bit & 1 == 1 { 1.0 } else { -1.0 };
        b.centre + f * (s(0) * b.half.x) + l * (s(1) * b.half.y) + up * (s(2) * b.half.z)
    })
}

/// The bounding rectangle `[x_min, x_max, y_min, y_max]` of `points`.
fn bounds(points: impl Iterator<Item = [f32; 2]>) -> [f32; 4] {
    points.fold([f32::INFINITY, f32::NEG_INFINITY, f32::INFINITY, f32::NEG_INFINITY], |r, p| {
        [r[0].min(p[0]), r[1].max(p[0]), r[2].min(p[1]), r[3].max(p[1])]
    })
}
