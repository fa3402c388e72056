//! How an object's faces are lit and coloured: sun and sky by orientation, street lamps from
//! above, the ego vehicle's head lights, the material, and the shadows other boxes cast on a
//! face the sun lights.

use super::View;
use super::raster::{FaceSun, Shade, Sunlit};
use super::shadow::{FacePlane, Shadows};
use crate::city::{CEILING_SHARE, City};
use crate::geometry::{OrientedBox, V3};
use crate::lighting::{self, RADIANCE_SCALE_DN};
use crate::objects::{Material, Rgb};

/// Relative irradiance from the ego head lights on a surface at `p` with normal `n`
/// (`n = None`: a horizontal ground point, lit at grazing incidence).
pub(super) fn headlight(lamp: V3, heading: V3, p: V3, n: Option<V3>) -> f32 {
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

/// The shadows on face `face` (and its index) of box `b` where `sunlit` says the sun lights it,
/// or `None` where no other box shadows any of it.
pub(super) fn face_sun(
    sunlit: Sunlit<'_>,
    b: &OrientedBox,
    face: (&FacePlane, usize),
) -> Option<FaceSun> {
    thread_local! {
        /// Per layer, which casters the current face has met (see `Shadows::face_shadows`),
        /// and the current face's number.
        static SEEN: std::cell::RefCell<([Vec<u32>; 2], u32)> =
            const { std::cell::RefCell::new(([Vec::new(), Vec::new()], 0)) };
    }
    let mut polygons = Vec::new();
    SEEN.with_borrow_mut(|(seen, stamp)| {
        if *stamp == u32::MAX {
            seen.iter_mut().for_each(Vec::clear);
            *stamp = 0;
        }
        *stamp += 1;
        for (s, seen) in sunlit.layers.iter().zip(seen) {
            if let Some(s) = s {
                s.face_shadows_kept(face, s.caster_of(b), (seen, *stamp), &mut polygons);
            }
        }
    });
    (!polygons.is_empty()).then_some(FaceSun { dim: sunlit.dim, polygons })
}

/// What lights one box: the lamps' irradiance at its foot, computed once per box, and what each
/// face needs to add its own sun, sky and head-light terms.
pub(super) struct BoxLight<'a> {
    view: &'a View<'a>,
    city: &'a City,
    lamp: V3,
    heading: V3,
    b: &'a OrientedBox,
    lights_on: bool,
    lamp_ground: f32,
    /// What casts shadows (static, moving), if anything.
    layers: [Option<&'a Shadows>; 2],
}

impl<'a> BoxLight<'a> {
    /// Whether a street lamp's head glows: where the instant's street lamps shine.
    fn lamps_on(&self) -> bool {
        self.view.lighting.street_lamps_on()
    }

    pub(super) fn new(
        city: &'a City,
        view: &'a View<'a>,
        lamp: V3,
        heading: V3,
        b: &'a OrientedBox,
        layers: [Option<&'a Shadows>; 2],
    ) -> Self {
        let lights_on = view.lighting.lights_on();
        let lamp_ground = if view.lighting.street_lamps_on() {
            city.lamp_irradiance(b.centre.x, b.centre.y)
        } else {
            0.0
        };
        Self { view, city, lamp, heading, b, lights_on, lamp_ground, layers }
    }

    /// The colouring of face `face_index` (outward normal `n`): irradiance at the face centre
    /// from sun and sky by orientation, lamps from above (half on vertical faces), head lights
    /// by distance and incidence, then the material; with cast shadows, what a pixel of the
    /// face keeps where the sun does not reach it (per colour channel: the irradiance without
    /// the sun's share over that with it; reflected light only, so emitters cast no such dim).
    /// A face whose centre lies in a tunnel gets the tunnel's light instead of sun, sky and
    /// street lamps (the bottom face, index 5, of a ceiling is always there).
    pub(super) fn shade(
        &self,
        material: Material,
        face_index: usize,
        n: V3,
    ) -> (Shade, Option<Sunlit<'a>>) {
        let h = self.b.half;
        let hn = [h.x, h.x, h.y, h.y, h.z, h.z][face_index];
        let centre = self.b.centre + n * hn;
        let head =
            if self.lights_on { headlight(self.lamp, self.heading, centre, Some(n)) } else { 0.0 };
        let share = match face_index {
            4 => 1.0,
            5 => CEILING_SHARE,
            _ => 0.5,
        };
        let outside = self.view.lighting.sun_sky([0.0, 0.0, 1.0]);
        if let Some(e) = self.city.tunnel_irradiance(centre, share, outside) {
            return (shade_for(material, face_index, &[e + head; 3], self.lamps_on()), None);
        }
        let sun_sky = self.view.lighting.sun_sky([n.x, n.y, n.z]);
        let lamp_share = if face_index == 4 { 1.0 } else { 0.5 };
        let irradiance: Rgb = std::array::from_fn(|ch| {
            sun_sky + lamp_share * self.lamp_ground * lighting::LAMP_TINT[ch] + head
        });
        let sun = self.view.lighting.direct_sun([n.x, n.y, n.z]);
        let reflects = !matches!(material, Material::Lamp | Material::Emissive(_));
        let sunlit = (self.layers[0].is_some() && sun > 0.0 && reflects).then(|| Sunlit {
            dim: irradiance.map(|e| (e - sun).max(0.0) / e),
            layers: self.layers,
        });
        (shade_for(material, face_index, &irradiance, self.lamps_on()), sunlit)
    }
}

fn shade_for(material: Material, face_index: usize, e: &Rgb, lamps_on: bool) -> Shade {
    let k = RADIANCE_SCALE_DN;
    let lit = |rho: Rgb| -> Rgb { std::array::from_fn(|c| k * rho[c] * e[c]) };
    match material {
        Material::Flat(rho) | Material::Underside(rho) => Shade::Constant(lit(rho)),
        Material::Lamp if !lamps_on => Shade::Constant(lit([0.5; 3])),
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
