//! Triangle rasterisation with a z-buffer: near-plane clipping, edge functions, perspective-
//! correct depth and texture coordinates, and the per-pixel material patterns.

use super::fill::{Step, fill_shaded};
pub(crate) use super::shade::Shade;
use super::shadow::{Polygon, Shadows};
use super::{CameraFrame, NEAR_M, Target};
use crate::geometry::V3;
use crate::objects::Rgb;

/// How a face's pixels change where the sun does not reach them.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sunlit<'a> {
    /// Factor per colour channel of a pixel in shadow.
    pub(crate) dim: Rgb,
    /// What casts the shadows (static, moving).
    pub(crate) layers: [Option<&'a Shadows>; 2],
}

/// A face that the sun lights and other boxes shadow in part: the shadows as polygons in its
/// texture coordinates, and what a pixel in shadow keeps.
#[derive(Debug, Clone)]
pub(crate) struct FaceSun {
    pub(crate) dim: Rgb,
    pub(crate) polygons: Vec<Polygon>,
}

impl FaceSun {
    /// The shadows' edges on the screen: a polygon's edge `a·u + b·v ≤ c` is, with `u = U/W`,
    /// `v = V/W` and `W = 1/z > 0` all linear on the screen (`planes`), the linear inequality
    /// `a·U + b·V − c·W ≤ 0`, which on the row through `y` bounds the column `x` by a bound
    /// linear in `y`. Made once a face, so that a row costs one multiply-add an edge.
    fn on_screen(&self, planes: [&Plane; 3]) -> ScreenShadows {
        let [uz, vz, iz] = planes;
        let mut edges = Vec::new();
        let mut ends = Vec::with_capacity(self.polygons.len());
        for polygon in &self.polygons {
            for &[a, b, c] in polygon.planes() {
                let (a, b, c) = (f64::from(a), f64::from(b), f64::from(c));
                let rate = a * uz.a + b * vz.a - c * iz.a;
                // The edge's value at column 0 of the row through y: at_y·y + at_0.
                let at_y = a * uz.b + b * vz.b - c * iz.b;
                let at_0 = a * uz.c + b * vz.c - c * iz.c;
                edges.push(if rate == 0.0 {
                    ScreenEdge::Row { at_y, at_0 }
                } else if rate > 0.0 {
                    ScreenEdge::Below { slope: -at_y / rate, at_0: -at_0 / rate }
                } else {
                    ScreenEdge::Above { slope: -at_y / rate, at_0: -at_0 / rate }
                });
            }
            ends.push(edges.len());
        }
        ScreenShadows { edges, ends }
    }
}

/// One shadow edge on the screen, on the row through `y`: the column is at most (`Below`) or
/// at least (`Above`) `slope·y + at_0`, or (`Row`, parallel to the rows) the whole row is
/// outside where `at_y·y + at_0 > 0`.
#[derive(Debug, Clone, Copy)]
enum ScreenEdge {
    Below { slope: f64, at_0: f64 },
    Above { slope: f64, at_0: f64 },
    Row { at_y: f64, at_0: f64 },
}

/// A face's shadow polygons on the screen ([`FaceSun::on_screen`]): polygon `k`'s edges are
/// `edges[ends[k − 1]..ends[k]]`.
#[derive(Debug, Clone, Default)]
struct ScreenShadows {
    edges: Vec<ScreenEdge>,
    ends: Vec<usize>,
}

impl ScreenShadows {
    /// Marks in `mask` (one entry per pixel of the span from column `x0` to `x1` of the row
    /// whose centre is at `yc`) the pixels whose centres lie in a shadow.
    fn mask_span(&self, yc: f64, (x0, x1): (usize, usize), mask: &mut Vec<bool>) {
        mask.clear();
        mask.resize(x1 + 1 - x0, false);
        let mut start = 0;
        for &end in &self.ends {
            let (mut lo, mut hi) = (x0 as f64 + 0.5, x1 as f64 + 0.5);
            for edge in &self.edges[start..end] {
                match *edge {
                    ScreenEdge::Below { slope, at_0 } => hi = hi.min(slope * yc + at_0),
                    ScreenEdge::Above { slope, at_0 } => lo = lo.max(slope * yc + at_0),
                    ScreenEdge::Row { at_y, at_0 } => {
                        if at_y * yc + at_0 > 0.0 {
                            hi = f64::NEG_INFINITY;
                        }
                    }
                }
            }
            start = end;
            let (first, last) = centre_span_f64(lo, hi, x1 + 1);
            if first <= last {
                mask[first as usize - x0..=last as usize - x0].iter_mut().for_each(|m| *m = true);
            }
        }
    }
}

/// What colours a face: its material's shading, and its shadows if the sun lights it.
pub(crate) type FaceShading = (Shade, Option<FaceSun>);

/// A polygon corner in camera coordinates with its texture coordinates (metres on the face).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Vertex {
    pub(crate) cam: V3,
    pub(crate) u: f32,
    pub(crate) v: f32,
}

/// The first and last pixel index `k` in `0..size` whose centre `k + 0.5` lies in `[lo, hi]`
/// (first > last: none): `max(⌈lo − ½⌉, 0)` and `min(⌊hi − ½⌋, size − 1)`.
///
/// Written with an integer conversion instead of `f64::ceil`/`floor`: baseline x86-64 has no
/// rounding instruction, so those are library calls, and they ran for every row of every
/// polygon. Bounds are clamped to `[−2, size + 1]` first, which keeps the conversion exact and
/// changes no span: a non-empty span has the same ends, an empty one stays empty (its ends may
/// differ; tested against the library functions, NaN and infinite bounds included).
#[inline(always)]
pub(crate) fn centre_span_f64(lo: f64, hi: f64, size: usize) -> (f64, f64) {
    let top = size as f64 + 1.0;
    let (a, b) = ((lo - 0.5).max(-2.0).min(top), (hi - 0.5).min(top).max(-2.0));
    let (fa, fb) = ((a as i64) as f64, (b as i64) as f64);
    let first = if fa < a { fa + 1.0 } else { fa };
    let last = if fb > b { fb - 1.0 } else { fb };
    (first.max(0.0), last.min(size as f64 - 1.0))
}

/// Clips a convex polygon against the near plane and rasterises it.
pub(crate) fn draw_polygon(
    verts: &[Vertex],
    cam: &CameraFrame,
    shade: &dyn Fn() -> FaceShading,
    id: u32,
    target: &mut Target,
) {
    let mut clipped: [Vertex; 8] = [verts[0]; 8];
    let mut n = 0;
    for i in 0..verts.len() {
        let a = verts[i];
        let b = verts[(i + 1) % verts.len()];
        let (ina, inb) = (a.cam.z >= NEAR_M, b.cam.z >= NEAR_M);
        if ina {
            clipped[n] = a;
            n += 1;
        }
        if ina != inb {
            let s = (NEAR_M - a.cam.z) / (b.cam.z - a.cam.z);
            clipped[n] = Vertex {
                cam: a.cam + (b.cam - a.cam) * s,
                u: a.u + (b.u - a.u) * s,
                v: a.v + (b.v - a.v) * s,
            };
            n += 1;
        }
    }
    if n < 3 {
        return;
    }
    let mut projected = [Projected::default(); 8];
    for (p, v) in projected.iter_mut().zip(&clipped[..n]) {
        *p = Projected::new(v, cam);
    }
    convex(&projected[..n], shade, id, target);
}

/// A vertex in screen space with the quantities that interpolate linearly there.
#[derive(Debug, Clone, Copy, Default)]
struct Projected {
    x: f64,
    y: f64,
    inv_z: f64,
    u_over_z: f64,
    v_over_z: f64,
}

impl Projected {
    fn new(v: &Vertex, cam: &CameraFrame) -> Self {
        let (x, y, inv_z) = cam.screen(v.cam);
        Self { x, y, inv_z, u_over_z: f64::from(v.u) * inv_z, v_over_z: f64::from(v.v) * inv_z }
    }
}

/// `q(x, y) = a·x + b·y + c` through three screen points.
#[derive(Debug, Clone, Copy)]
struct Plane {
    a: f64,
    b: f64,
    c: f64,
}

impl Plane {
    fn through(p: [&Projected; 3], q: impl Fn(&Projected) -> f64, area2: f64) -> Self {
        let [p0, p1, p2] = p;
        let (q0, q1, q2) = (q(p0), q(p1), q(p2));
        let a = ((q1 - q0) * (p2.y - p0.y) - (q2 - q0) * (p1.y - p0.y)) / area2;
        let b = ((q2 - q0) * (p1.x - p0.x) - (q1 - q0) * (p2.x - p0.x)) / area2;
        Self { a, b, c: q0 - a * p0.x - b * p0.y }
    }

    fn at(&self, x: f64, y: f64) -> f64 {
        self.a * x + self.b * y + self.c
    }
}

/// Rasterises a convex polygon, sampling at pixel centres. Each row's covered span is solved
/// from the edge inequalities (no per-pixel inside test), and 1/z, u/z, v/z are planes in
/// screen space, so a pixel costs one reciprocal and a depth test. Set-up is in f64 so that
/// polygons reaching far outside the image (close to the camera) stay watertight.
fn convex(p: &[Projected], shade: &dyn Fn() -> FaceShading, id: u32, target: &mut Target) {
    let n = p.len();
    // Many faces that pass the box test cover no pixel centre themselves: they end here,
    // before any set-up or shading.
    let w = target.width as f64;
    let (mut x_min, mut x_max) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut y_min, mut y_max) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in p {
        (x_min, x_max) = (x_min.min(v.x), x_max.max(v.x));
        (y_min, y_max) = (y_min.min(v.y), y_max.max(v.y));
    }
    let (y0, y1) = centre_span_f64(y_min, y_max, target.height);
    let (x0, x1) = centre_span_f64(x_min, x_max, target.width);
    if y0 > y1 || x0 > x1 {
        return;
    }
    // Signed double area, and the fan triangle with the largest area for the planes.
    let mut area = 0.0;
    let mut best = (0.0f64, 1usize);
    for k in 1..n - 1 {
        let a =
            (p[k].x - p[0].x) * (p[k + 1].y - p[0].y) - (p[k + 1].x - p[0].x) * (p[k].y - p[0].y);
        area += a;
        if a.abs() > best.0.abs() {
            best = (a, k);
        }
    }
    if best.0.abs() < 1e-9 {
        return;
    }
    let sign = area.signum();
    // Edge i: A·x + B·y + C ≥ 0 inside.
    let mut edges = [(0.0f64, 0.0f64, 0.0f64); 8];
    for i in 0..n {
        let (a, b) = (&p[i], &p[(i + 1) % n]);
        let (dx, dy) = (b.x - a.x, b.y - a.y);
        edges[i] = (-dy * sign, dx * sign, (dy * a.x - dx * a.y) * sign);
    }
    let tri = [&p[0], &p[best.1], &p[best.1 + 1]];
    let iz = Plane::through(tri, |v| v.inv_z, best.0);
    let (shade, sun) = shade();
    let shade = &shade;
    let textured = !matches!(shade, Shade::Constant(_)) || sun.is_some();
    let (uz, vz) = if textured {
        (Plane::through(tri, |v| v.u_over_z, best.0), Plane::through(tri, |v| v.v_over_z, best.0))
    } else {
        (Plane { a: 0.0, b: 0.0, c: 0.0 }, Plane { a: 0.0, b: 0.0, c: 0.0 })
    };
    let mut covered = 0u32;
    let shadows = sun.as_ref().map(|sun| (sun.on_screen([&uz, &vz, &iz]), sun.dim));
    let mut shadowed = Vec::new();
    // An id-only target (the ground-truth pass) has no colour buffer.
    let with_colour = !target.colour.is_empty();
    for y in y0 as usize..=y1 as usize {
        let yc = y as f64 + 0.5;
        let (mut lo, mut hi) = (0.5f64, w - 0.5);
        let mut empty = false;
        for &(a, b, c) in &edges[..n] {
            let rest = b * yc + c;
            if a > 0.0 {
                lo = lo.max(-rest / a);
            } else if a < 0.0 {
                hi = hi.min(-rest / a);
            } else if rest < 0.0 {
                empty = true;
            }
        }
        if empty || lo > hi {
            continue;
        }
        let (x0, x1) = centre_span_f64(lo, hi, target.width);
        if x1 < x0 {
            continue;
        }
        let (x0, x1) = (x0 as usize, x1 as usize);
        covered += (x1 + 1 - x0) as u32;
        let xc = x0 as f64 + 0.5;
        let mut inv_z = iz.at(xc, yc) as f32;
        let d_inv_z = iz.a as f32;
        let (u, v) = (uz.at(xc, yc) as f32, vz.at(xc, yc) as f32);
        let (du, dv) = (uz.a as f32, vz.a as f32);
        // The span's slices, taken once, so the pixel loop has no bounds checks.
        let span = y * target.width + x0..y * target.width + x1 + 1;
        let depth = &mut target.inv_depth[span.clone()];
        let ids = &mut target.id[span.clone()];
        if with_colour {
            let colour = &mut target.colour[span.start * 3..span.end * 3];
            let step = Step { inv_z, d_inv_z, u, du, v, dv };
            let mask = shadows.as_ref().map(|(on_screen, dim)| {
                on_screen.mask_span(yc, (x0, x1), &mut shadowed);
                (shadowed.as_slice(), *dim)
            });
            fill_shaded((depth, ids, colour), id, step, mask, shade);
        } else {
            for (d, i) in depth.iter_mut().zip(ids) {
                if inv_z > *d {
                    *d = inv_z;
                    *i = id;
                }
                inv_z += d_inv_z;
            }
        }
    }
    target.coverage[id as usize] += covered;
}
