//! The per-pixel patterns of materials: facade windows (some lit), sign faces.

use crate::city::fast_floor;
use crate::objects::Rgb;

/// How the pixels of one face are coloured (radiance already includes the face's lighting).
#[derive(Debug, Clone, Copy)]
pub(crate) enum Shade {
    Constant(Rgb),
    Facade { wall: Rgb, glass: Rgb, glow: Rgb, inv_pitch_u: f32, inv_pitch_v: f32, seed: u32 },
    Sign { kind: u8, white: Rgb, red: Rgb, blue: Rgb, yellow: Rgb, dark: Rgb },
}

impl Shade {
    #[inline(always)]
    pub(crate) fn at(&self, u: f32, v: f32) -> Rgb {
        match *self {
            Shade::Constant(c) => c,
            Shade::Facade { wall, glass, glow, inv_pitch_u, inv_pitch_v, seed } => {
                let (cu, cv) = (u * inv_pitch_u, v * inv_pitch_v);
                let (iu, iv) = (fast_floor(cu), fast_floor(cv));
                let (fu, fv) = (cu - iu as f32, cv - iv as f32);
                if cv > 0.3 && (0.2..0.8).contains(&fu) && (0.28..0.82).contains(&fv) {
                    let lit = cell_hash(iu, iv, seed) < 0.3;
                    if lit {
                        [glass[0] + glow[0], glass[1] + glow[1], glass[2] + glow[2]]
                    } else {
                        glass
                    }
                } else {
                    wall
                }
            }
            Shade::Sign { kind, white, red, blue, yellow, dark } => {
                // Plate coordinates in [-0.5, 0.5]², t upwards.
                let (s, t) = (u / 0.7 - 0.5, v / 0.7 - 0.5);
                let r = (s * s + t * t).sqrt();
                match kind {
                    0 => {
                        // Prohibition: red ring, white centre.
                        if r < 0.31 {
                            white
                        } else if r < 0.45 {
                            red
                        } else {
                            dark
                        }
                    }
                    1 => {
                        // Mandatory: blue disc with a white upward arrow.
                        let shaft = s.abs() < 0.06 && (-0.28..0.08).contains(&t);
                        let head = (0.08..0.3).contains(&t) && s.abs() < (0.3 - t) * 0.8;
                        if r < 0.45 { if shaft || head { white } else { blue } } else { dark }
                    }
                    2 => {
                        // Warning: red-bordered white triangle, point up.
                        let outer = t > -0.42 && s.abs() < (0.45 - t) * 0.58;
                        let inner = t > -0.3 && s.abs() < (0.3 - t) * 0.58;
                        if inner {
                            white
                        } else if outer {
                            red
                        } else {
                            dark
                        }
                    }
                    _ => {
                        // Priority road: yellow diamond with a white border.
                        let d = s.abs() + t.abs();
                        if d < 0.3 {
                            yellow
                        } else if d < 0.45 {
                            white
                        } else {
                            dark
                        }
                    }
                }
            }
        }
    }
}

fn cell_hash(x: i32, y: i32, seed: u32) -> f32 {
    let mut h = (x as u32).wrapping_mul(0x27d4_eb2d) ^ (y as u32).wrapping_mul(0x1656_67b1) ^ seed;
    h ^= h >> 15;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    (h >> 8) as f32 / (1u32 << 24) as f32
}
