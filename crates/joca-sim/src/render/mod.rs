//! The rasteriser: one instantaneous view of the city from a pinhole camera.
//!
//! Each view is drawn in two passes into a [`Target`], objects first so that the ground is only
//! shaded where it is seen:
//! 1. **Objects**, nearest first. A box whose screen rectangle is already covered by nearer
//!    surfaces everywhere is skipped (most boxes of a street view stand behind a facade; the
//!    id-only pass still counts the coverage of those whose object shows elsewhere); for the
//!    others every box face that faces the camera is clipped against the
//!    near plane and rasterised with a z-buffer (holding 1/z, so the depth test needs no
//!    division); depth and texture coordinates are interpolated perspective-correctly. Faces are
//!    shaded once each (sun, sky, lamps, head lights at the face centre) and textured per pixel
//!    where the material has a pattern (facade windows, sign faces).
//! 2. **Ground and sky**, per pixel: the view ray of a pixel below the horizon meets the ground
//!    plane at depth `t = z_cam / b` (b = the ray's downward slope), which is constant along an
//!    image row, so the hit point moves linearly along the row. The city's ground albedo (lanes,
//!    crossings, sidewalks) is shaded with sun and sky, street-lamp light (a baked light map) and
//!    the ego vehicle's head lights, wherever the ground is nearer than the object drawn there.
//!    Rays above the horizon that hit no object see the sky.
//!
//! Along with colour the target records, per pixel, which object is visible (the id buffer) and,
//! per object, how many pixels its camera-facing faces cover before the depth test; ground truth
//! uses both (visible pixels over covered pixels is the visible fraction).

mod fill;
pub mod fog;
pub mod glare;
pub mod glow;
mod ground;
pub mod lens;
mod light;
pub mod rain;
mod raster;
mod reach;
mod shade;
pub mod shadow;
pub mod sun;

use crate::city::City;
use crate::geometry::{OrientedBox, Pose2, V3};
use crate::lighting::Lighting;
use crate::objects::Material;
use ground::ground_and_sky;
use joca_core::PinholeCamera;
use light::headlight;
use light::{BoxLight, face_sun};
use raster::{Shade, Sunlit, Vertex};
use reach::{Reach, hidden, screen_reach};
use shadow::{FacePlane, Shadows};

/// Closest depth that is drawn, metres.
pub const NEAR_M: f32 = 0.05;
/// Objects farther than this from the camera are not drawn, metres.
pub const DRAW_RANGE_M: f32 = 220.0;
/// Ground beyond this depth is drawn as sky-coloured haze, metres.
const GROUND_FAR_M: f32 = 600.0;

/// Where the camera is and what it sees by, for one instant.
#[derive(Debug, Clone, Copy)]
pub struct View<'a> {
    /// Intrinsics and the mount on the vehicle.
    pub camera: &'a PinholeCamera,
    /// Ego vehicle pose.
    pub ego: Pose2,
    /// Ambient level and sun.
    pub lighting: Lighting,
    /// Time of this instant since the episode start, seconds.
    pub time_s: f64,
    /// The shadows the city's static objects cast in this sun (`None`: no cast shadows; with
    /// them, moving objects cast theirs too).
    pub shadows: Option<&'a Shadows>,
    /// The sun in the sky: the aureole and the disc where it is in view (see [`sun`]).
    pub sun_disc: bool,
}

/// Colour, depth and object-id buffers of one view.
#[derive(Debug, Clone)]
pub struct Target {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Interleaved RGB radiance, calibrated DN.
    pub colour: Vec<f32>,
    /// Inverse camera-frame depth (1 / distance along the optical axis), 1/metres; 0 = nothing.
    pub inv_depth: Vec<f32>,
    /// Index + 1 of the visible object per pixel (0 = ground or sky).
    pub id: Vec<u32>,
    /// Fog's light above the airlight times its optical depth, per pixel (written by
    /// [`fog::fog`], read by [`glow::fog_glow_integrated`]); empty without fog.
    pub light_depth: Vec<f32>,
    /// Per object index + 1: pixels covered by its camera-facing faces, before occlusion. Exact
    /// on id-only targets ([`render_ids`], the ground truth) for every object with a box that
    /// reaches the depth buffer (so for every object seen anywhere in the view). Renders skip
    /// boxes that nearer ones already hide entirely; a colour render leaves them out of this
    /// count, an id-only render only those of objects with no box drawn.
    pub coverage: Vec<u32>,
}

impl Target {
    /// Buffers for a `width × height` view of a scene with `objects` objects.
    pub fn new(width: usize, height: usize, objects: usize) -> Self {
        Self {
            width,
            height,
            colour: vec![0.0; width * height * 3],
            inv_depth: vec![0.0; width * height],
            id: vec![0; width * height],
            light_depth: Vec::new(),
            coverage: vec![0; objects + 1],
        }
    }

    /// Depth and id buffers without colour, for [`render_ids`].
    pub fn ids_only(width: usize, height: usize, objects: usize) -> Self {
        Self {
            width,
            height,
            colour: Vec::new(),
            inv_depth: vec![0.0; width * height],
            id: vec![0; width * height],
            light_depth: Vec::new(),
            coverage: vec![0; objects + 1],
        }
    }
}

/// The camera's frame in the world.
#[derive(Debug, Clone, Copy)]
pub(crate) struct CameraFrame {
    pub(crate) origin: V3,
    pub(crate) forward: V3,
    pub(crate) right: V3,
    pub(crate) fx: f32,
    pub(crate) fy: f32,
    pub(crate) cx: f32,
    pub(crate) cy: f32,
}

impl CameraFrame {
    pub(crate) fn new(camera: &PinholeCamera, ego: Pose2) -> Self {
        let m = camera.mount_m;
        let origin = ego.apply(V3::new(m[0] as f32, m[1] as f32, m[2] as f32));
        let (s, c) = ego.yaw.sin_cos();
        Self {
            origin,
            forward: V3::new(c, s, 0.0),
            right: V3::new(s, -c, 0.0),
            fx: camera.fx_px as f32,
            fy: camera.fy_px as f32,
            cx: camera.cx_px as f32,
            cy: camera.cy_px as f32,
        }
    }

    /// Camera coordinates (right, down, forward) of a world point.
    pub(crate) fn camera_from_world(&self, p: V3) -> V3 {
        let r = p - self.origin;
        V3::new(r.dot(self.right), -r.z, r.dot(self.forward))
    }

    /// Screen position (f64, the rasteriser's precision) of camera-frame point `c` in front of
    /// the camera, and its `1 / z`.
    #[inline(always)]
    pub(crate) fn screen(&self, c: V3) -> (f64, f64, f64) {
        let inv_z = 1.0 / f64::from(c.z);
        (
            f64::from(self.cx) + f64::from(self.fx) * f64::from(c.x) * inv_z,
            f64::from(self.cy) + f64::from(self.fy) * f64::from(c.y) * inv_z,
            inv_z,
        )
    }
}

/// Position of the ego head lights in the vehicle frame, metres.
const HEADLIGHT_MOUNT: V3 = V3::new(2.3, 0.0, 0.7);

/// Renders one instant of `city` seen through `view` into `target` (which it clears first).
pub fn render(city: &City, view: &View<'_>, target: &mut Target) {
    draw(city, view, target, true);
}

/// [`render`], with the skipping of hidden boxes on or off (off: only for the test that the
/// skipping changes nothing).
fn draw(city: &City, view: &View<'_>, target: &mut Target, skip_hidden: bool) {
    let cam = CameraFrame::new(view.camera, view.ego);
    let lamp_pos = view.ego.apply(HEADLIGHT_MOUNT);
    let heading = cam.forward;
    let with_colour = !target.colour.is_empty();
    target.coverage.iter_mut().for_each(|c| *c = 0);
    target.inv_depth.iter_mut().for_each(|d| *d = 0.0);
    target.id.iter_mut().for_each(|i| *i = 0);

    let frustum = Frustum::new(view, &cam);
    // Cast shadows where the sun is up: with the lamps on (dusk, night, a tunnel) it is not.
    let statics = view.shadows.filter(|_| with_colour && !view.lighting.lights_on());
    let moving = statics.and_then(|_| moving_shadows(city, view, &frustum));
    let layers = [statics, moving.as_ref()];
    let mut visible: Vec<(f32, usize)> = Vec::with_capacity(512);
    for (index, object) in city.objects.iter().enumerate() {
        if let Some(depth) = frustum.holds(object, view.time_s, 0.0) {
            visible.push((depth, index));
        }
    }
    // Nearest first: farther surfaces then mostly fail the depth test before being shaded.
    visible.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let no_shade = |_, _| (Shade::Constant([0.0; 3]), None);
    // Hidden boxes of an id-only target, whose coverage may still be needed.
    let mut hidden_boxes: Vec<(u32, OrientedBox, Material, (V3, V3))> = Vec::new();
    for (_, index) in visible {
        let id = index as u32 + 1;
        for (b, material) in city.objects[index].boxes_at(view.time_s) {
            let axes = b.axes();
            let reach = screen_reach(&cam, &b, axes, target);
            if reach == Reach::Nowhere {
                continue;
            }
            if skip_hidden && hidden(target, reach) {
                if target.colour.is_empty() {
                    hidden_boxes.push((id, b, material, axes));
                }
            } else if target.colour.is_empty() {
                draw_faces(&cam, (&b, material), axes, &no_shade, id, target);
            } else {
                let light = BoxLight::new(city, view, lamp_pos, heading, &b, layers);
                let shade = |face, n| light.shade(material, face, n);
                draw_faces(&cam, (&b, material), axes, &shade, id, target);
            }
        }
    }
    // The coverage of a hidden box counts towards its object's visible fraction. Only an object
    // with a box that was drawn can be visible (a hidden box writes no pixel), so only those
    // boxes are rasterised now; the depth buffer has only grown nearer since they were found
    // hidden, so they still write nothing and only add their coverage.
    for (id, b, material, axes) in hidden_boxes {
        if target.coverage[id as usize] > 0 {
            draw_faces(&cam, (&b, material), axes, &no_shade, id, target);
        }
    }
    if with_colour {
        ground_and_sky(city, view, &cam, (lamp_pos, heading), layers, target);
        if view.sun_disc {
            sun::draw_sun(view, &cam, target);
        }
    }
}

/// The camera's view volume, for rejecting objects by their bounding spheres.
struct Frustum<'c> {
    cam: &'c CameraFrame,
    tan_h: f32,
    tan_v: f32,
}

impl<'c> Frustum<'c> {
    fn new(view: &View<'_>, cam: &'c CameraFrame) -> Self {
        Self {
            cam,
            tan_h: (view.camera.width_px as f32 / 2.0) / cam.fx,
            tan_v: (view.camera.height_px as f32 / 2.0) / cam.fy,
        }
    }

    /// The depth of `object` at `time_s` if a sphere around it, `extra` metres wider than its
    /// own, may reach the view (sides, near, range); `None` if it cannot.
    fn holds(&self, object: &crate::objects::Object, time_s: f64, extra: f32) -> Option<f32> {
        let pose = object.position_at(time_s);
        let c = self.cam.camera_from_world(V3::new(pose.x, pose.y, 1.0));
        let r = object.radius_m + 1.0 + extra;
        if c.z < -r || c.z > DRAW_RANGE_M + r {
            return None;
        }
        let slack_h = r * (1.0 + self.tan_h * self.tan_h).sqrt();
        let slack_v = r * (1.0 + self.tan_v * self.tan_v).sqrt() + object.radius_m;
        let outside =
            c.x.abs() > c.z * self.tan_h + slack_h || c.y.abs() > c.z * self.tan_v + slack_v;
        (!outside).then_some(c.z)
    }
}

/// The shadows of the moving objects (vehicles, walkers) at this instant that can fall into
/// view: a shadow lies within the object's height over the sun's slope of the object, so the
/// object's sphere widened by that much must reach the view.
fn moving_shadows(city: &City, view: &View<'_>, frustum: &Frustum<'_>) -> Option<Shadows> {
    let s = view.lighting.sun_dir;
    let slope = s[2] / (s[0] * s[0] + s[1] * s[1]).sqrt().max(1e-6);
    let boxes = city
        .objects
        .iter()
        .filter(|o| !o.motion.is_static())
        .filter(|o| frustum.holds(o, view.time_s, 2.0 * o.radius_m / slope).is_some())
        .flat_map(|o| o.boxes_at(view.time_s).map(|(b, _)| b));
    Shadows::new(boxes, view.lighting.sun_dir)
}

/// Which object each pixel of `view` sees and how many pixels each object's camera-facing faces
/// cover, without colour, ground or sky: the ground-truth pass. `target` must come from
/// [`Target::ids_only`].
pub fn render_ids(city: &City, view: &View<'_>, target: &mut Target) {
    debug_assert!(target.colour.is_empty());
    render(city, view, target);
}

/// The camera-facing faces of one box (`axes`: its [`OrientedBox::axes`]): corners, texture
/// coordinates and rasterisation; `shade` gives each face's colouring from its index and
/// outward normal. The bottom face (index 5) only where the material is
/// [`Material::Underside`].
fn draw_faces<'a>(
    cam: &CameraFrame,
    (b, material): (&OrientedBox, Material),
    (f, l): (V3, V3),
    shade: &dyn Fn(usize, V3) -> (Shade, Option<Sunlit<'a>>),
    id: u32,
    target: &mut Target,
) {
    let up = V3::new(0.0, 0.0, 1.0);
    let h = b.half;
    // (normal, half along normal, first in-face axis and half, second (vertical if side) axis).
    let faces = [
        (f, h.x, -l, h.y, up, h.z),
        (-f, h.x, l, h.y, up, h.z),
        (l, h.y, f, h.x, up, h.z),
        (-l, h.y, -f, h.x, up, h.z),
        (up, h.z, f, h.x, l, h.y),
        (-up, h.z, f, h.x, -l, h.y),
    ];
    let drawn = if matches!(material, Material::Underside(_)) { 6 } else { 5 };
    for (face_index, (n, hn, ua, hu, va, hv)) in faces.into_iter().take(drawn).enumerate() {
        let centre = b.centre + n * hn;
        if (cam.origin - centre).dot(n) <= 0.0 {
            continue; // back face
        }
        // Corners counter-clockwise seen from outside, with texture coordinates in metres
        // (u along the face, v upwards from its bottom edge for side faces).
        let corners = [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
        let verts: [Vertex; 4] = corners.map(|(su, sv)| {
            let p = centre + ua * (su * hu) + va * (sv * hv);
            let c = cam.camera_from_world(p);
            Vertex { cam: c, u: (su + 1.0) * hu, v: (sv + 1.0) * hv }
        });
        let origin = centre - ua * hu - va * hv;
        let shade = || {
            let (shade, sunlit) = shade(face_index, n);
            let face = FacePlane { origin, ua, va, n, size: [2.0 * hu, 2.0 * hv] };
            (shade, sunlit.and_then(|s| face_sun(s, b, (&face, face_index))))
        };
        raster::draw_polygon(&verts, cam, &shade, id, target);
    }
}

#[cfg(test)]
mod tests;
