//! Filling one span of a rasterised face: the depth test, the face's colouring per pixel, and
//! the shadows' dim where a mask says the sun does not reach.

use super::raster::Shade;
use crate::objects::Rgb;

/// A span's values at its first pixel and their steps to the next.
#[derive(Clone, Copy)]
pub(super) struct Step {
    pub(super) inv_z: f32,
    pub(super) d_inv_z: f32,
    pub(super) u: f32,
    pub(super) du: f32,
    pub(super) v: f32,
    pub(super) dv: f32,
}

/// Depth-tests and fills one span: `colour_at(1/z, (u/z, v/z))` gives a visible pixel's colour,
/// multiplied by `dim` where `mask` (one entry per pixel of the span) is set.
#[inline(always)]
fn fill(
    (depth, ids, colour): (&mut [f32], &mut [u32], &mut [f32]),
    id: u32,
    s: Step,
    mask: Option<(&[bool], Rgb)>,
    colour_at: impl Fn(f32, (f32, f32)) -> Rgb,
) {
    let Step { mut inv_z, d_inv_z, mut u, du, mut v, dv } = s;
    let pixels = depth.iter_mut().zip(ids).zip(colour.chunks_exact_mut(3));
    match mask {
        None => {
            for ((d, i), rgb) in pixels {
                if inv_z > *d {
                    *d = inv_z;
                    *i = id;
                    rgb.copy_from_slice(&colour_at(inv_z, (u, v)));
                }
                inv_z += d_inv_z;
                u += du;
                v += dv;
            }
        }
        Some((mask, dim)) => {
            for (((d, i), rgb), &shadowed) in pixels.zip(mask) {
                if inv_z > *d {
                    *d = inv_z;
                    *i = id;
                    let c = colour_at(inv_z, (u, v));
                    if shadowed {
                        rgb.copy_from_slice(&[c[0] * dim[0], c[1] * dim[1], c[2] * dim[2]]);
                    } else {
                        rgb.copy_from_slice(&c);
                    }
                }
                inv_z += d_inv_z;
                u += du;
                v += dv;
            }
        }
    }
}

/// [`fill`] with the colouring of `shade`, its kind chosen once outside the pixel loop so that
/// the loop does not branch on it (only a patterned face divides by 1/z).
#[inline(always)]
pub(super) fn fill_shaded(
    span: (&mut [f32], &mut [u32], &mut [f32]),
    id: u32,
    step: Step,
    mask: Option<(&[bool], Rgb)>,
    shade: &Shade,
) {
    match *shade {
        Shade::Constant(c) => fill(span, id, step, mask, |_, _| c),
        Shade::Facade { wall, glass, glow, inv_pitch_u, inv_pitch_v, seed } => {
            // Rebuilt here so that, inlined, `at` knows the variant.
            let f = Shade::Facade { wall, glass, glow, inv_pitch_u, inv_pitch_v, seed };
            fill(span, id, step, mask, patterned(&f));
        }
        Shade::Sign { .. } => fill(span, id, step, mask, patterned(shade)),
    }
}

/// A patterned face's colour at `(1/z, (u/z, v/z))`: its pattern at the texture coordinates.
#[inline(always)]
fn patterned(shade: &Shade) -> impl Fn(f32, (f32, f32)) -> Rgb + '_ {
    #[inline(always)]
    move |inv_z, (u, v)| {
        let z = 1.0 / inv_z;
        shade.at(u * z, v * z)
    }
}
