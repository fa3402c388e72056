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

pub mod fog;
pub mod glow;
mod ground;
pub mod lens;
pub mod rain;
mod raster;
mod reach;

use crate::city::City;
use crate::geometry::{OrientedBox, Pose2, V3};
use crate::lighting::{self, Lighting, RADIANCE_SCALE_DN};
use crate::objects::{Material, Rgb};
use ground::ground_and_sky;
use joca_core::PinholeCamera;
use raster::{Shade, Vertex};
use reach::{Reach, hidden, screen_reach};

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
    target.coverage.iter_mut().for_each(|c| *c = 0);
    target.inv_depth.iter_mut().for_each(|d| *d = 0.0);
    target.id.iter_mut().for_each(|i| *i = 0);

    let (tan_h, tan_v) = (
        (view.camera.width_px as f32 / 2.0) / cam.fx,
        (view.camera.height_px as f32 / 2.0) / cam.fy,
    );
    let mut visible: Vec<(f32, usize)> = Vec::with_capacity(512);
    for (index, object) in city.objects.iter().enumerate() {
        let pose = object.position_at(view.time_s);
        let c = cam.camera_from_world(V3::new(pose.x, pose.y, 1.0));
        let r = object.radius_m + 1.0;
        // Sphere-against-frustum rejection (sides, near, range).
        if c.z < -r || c.z > DRAW_RANGE_M + r {
            continue;
        }
        let slack_h = r * (1.0 + tan_h * tan_h).sqrt();
        let slack_v = r * (1.0 + tan_v * tan_v).sqrt() + object.radius_m;
        if c.x.abs() > c.z * tan_h + slack_h || c.y.abs() > c.z * tan_v + slack_v {
            continue;
        }
        visible.push((c.z, index));
    }
    // Nearest first: farther surfaces then mostly fail the depth test before being shaded.
    visible.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let no_shade = |_, _| Shade::Constant([0.0; 3]);
    // Hidden boxes of an id-only target, whose coverage may still be needed.
    let mut hidden_boxes: Vec<(u32, OrientedBox, (V3, V3))> = Vec::new();
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
                    hidden_boxes.push((id, b, axes));
                }
            } else if target.colour.is_empty() {
                draw_faces(&cam, &b, axes, &no_shade, id, target);
            } else {
                let light = BoxLight::new(city, view, lamp_pos, heading, &b);
                let shade = |face, n| light.shade(material, face, n);
                draw_faces(&cam, &b, axes, &shade, id, target);
            }
        }
    }
    // The coverage of a hidden box counts towards its object's visible fraction. Only an object
    // with a box that was drawn can be visible (a hidden box writes no pixel), so only those
    // boxes are rasterised now; the depth buffer has only grown nearer since they were found
    // hidden, so they still write nothing and only add their coverage.
    for (id, b, axes) in hidden_boxes {
        if target.coverage[id as usize] > 0 {
            draw_faces(&cam, &b, axes, &no_shade, id, target);
        }
    }
    if !target.colour.is_empty() {
        ground_and_sky(city, view, &cam, lamp_pos, heading, target);
    }
}

/// Which object each pixel of `view` sees and how many pixels each object's camera-facing faces
/// cover, without colour, ground or sky: the ground-truth pass. `target` must come from
/// [`Target::ids_only`].
pub fn render_ids(city: &City, view: &View<'_>, target: &mut Target) {
    debug_assert!(target.colour.is_empty());
    render(city, view, target);
}

/// Relative irradiance from the ego head lights on a surface at `p` with normal `n`
/// (`n = None`: a horizontal ground point, lit at grazing incidence).
fn headlight(lamp: V3, heading: V3, p: V3, n: Option<V3>) -> f32 {
    let v = p - lamp;
    let d2 = v.dot(v).max(1.0);
    let d = d2.sqrt();
    let along = v.dot(heading) / d;
    let cos_half = lighting::EGO_HEADLIGHT_HALF_ANGLE.cos();
    if along <= cos_half {
        return 0.0;
    }
    // Smooth edge of the beam.
    let cone = ((along - cos_half) / (1.0 - cos_half) * 3.0).min(1.0);
    let incidence = match n {
        Some(n) => (-(v.dot(n)) / d).max(0.0),
        None => (lamp.z - p.z).max(0.0) / d,
    };
    lighting::EGO_HEADLIGHT * cone * incidence / d2
}

/// The camera-facing faces of one box (`axes`: its [`OrientedBox::axes`]): corners, texture
/// coordinates and rasterisation; `shade` gives each face's colouring from its index and
/// outward normal.
fn draw_faces(
    cam: &CameraFrame,
    b: &OrientedBox,
    (f, l): (V3, V3),
    shade: &dyn Fn(usize, V3) -> Shade,
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
    ];
    for (face_index, (n, hn, ua, hu, va, hv)) in faces.into_iter().enumerate() {
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
        raster::draw_polygon(&verts, cam, &|| shade(face_index, n), id, target);
    }
}

/// What lights one box: the lamps' irradiance at its foot, computed once per box, and what each
/// face needs to add its own sun, sky and head-light terms.
struct BoxLight<'a> {
    view: &'a View<'a>,
    lamp: V3,
    heading: V3,
    b: &'a OrientedBox,
    lights_on: bool,
    lamp_ground: f32,
}

impl<'a> BoxLight<'a> {
    fn new(city: &City, view: &'a View<'a>, lamp: V3, heading: V3, b: &'a OrientedBox) -> Self {
        let lights_on = view.lighting.lights_on();
        let lamp_ground =
            if lights_on { city.lamp_irradiance(b.centre.x, b.centre.y) } else { 0.0 };
        Self { view, lamp, heading, b, lights_on, lamp_ground }
    }

    /// The colouring of face `face_index` (outward normal `n`): irradiance at the face centre
    /// from sun and sky by orientation, lamps from above (half on vertical faces), head lights
    /// by distance and incidence, then the material.
    fn shade(&self, material: Material, face_index: usize, n: V3) -> Shade {
        let h = self.b.half;
        let hn = [h.x, h.x, h.y, h.y, h.z][face_index];
        let centre = self.b.centre + n * hn;
        let sun_sky = self.view.lighting.sun_sky([n.x, n.y, n.z]);
        let lamp_share = if face_index == 4 { 1.0 } else { 0.5 };
        let head =
            if self.lights_on { headlight(self.lamp, self.heading, centre, Some(n)) } else { 0.0 };
        let irradiance: Rgb = std::array::from_fn(|ch| {
            sun_sky + lamp_share * self.lamp_ground * lighting::LAMP_TINT[ch] + head
        });
        shade_for(material, face_index, &irradiance, self.lights_on)
    }
}

fn shade_for(material: Material, face_index: usize, e: &Rgb, lights_on: bool) -> Shade {
    let k = RADIANCE_SCALE_DN;
    let lit = |rho: Rgb| -> Rgb { std::array::from_fn(|c| k * rho[c] * e[c]) };
    match material {
        Material::Flat(rho) => Shade::Constant(lit(rho)),
        Material::Lamp if !lights_on => Shade::Constant(lit([0.5; 3])),
        Material::Lamp | Material::Emissive(_) => {
            let radiance =
                if let Material::Emissive(r) = material { r } else { crate::objects::LAMP };
            let r = lit([0.1; 3]);
            Shade::Constant(std::array::from_fn(|c| radiance[c] + r[c]))
        }
        Material::Sign(kind) => {
            if face_index == 0 {
                Shade::Sign {
                    kind,
                    white: lit([0.75; 3]),
                    red: lit([0.55, 0.04, 0.04]),
                    blue: lit([0.04, 0.12, 0.5]),
                    yellow: lit([0.7, 0.55, 0.05]),
                    dark: lit([0.05; 3]),
                }
            } else {
                Shade::Constant(lit(crate::objects::METAL))
            }
        }
        Material::Facade { wall, glass, pitch_u_m, pitch_v_m, lit_seed } => {
            if face_index == 4 {
                Shade::Constant(lit(wall.map(|v| v * 0.6)))
            } else {
                Shade::Facade {
                    wall: lit(wall),
                    glass: lit(glass),
                    glow: lighting::WINDOW_GLOW,
                    inv_pitch_u: 1.0 / pitch_u_m,
                    inv_pitch_v: 1.0 / pitch_v_m,
                    seed: lit_seed.wrapping_add(face_index as u32 * 7919),
                }
            }
        }
    }
}

#[cfg(test)]
mod tests;
