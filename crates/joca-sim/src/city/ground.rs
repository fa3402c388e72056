//! The ground's materials: which zone (road, sidewalk, block) each coordinate falls in, and the
//! albedo of asphalt, lane markings and zebra crossings.

use super::*;

pub(super) fn zone_table(roads: &[Road], extent: f32) -> Vec<Zone> {
    let cells = (extent / ZONE_RES_M) as usize + 1;
    (0..cells)
        .map(|c| {
            let v = (c as f32 + 0.5) * ZONE_RES_M;
            for (i, r) in roads.iter().enumerate() {
                let d = (v - r.centre_m).abs();
                if d <= r.half_width_m() {
                    return Zone::Road(i as u16);
                }
                if d <= r.half_width_m() + SIDEWALK_M {
                    return Zone::Walk;
                }
            }
            Zone::Block
        })
        .collect()
}

pub(super) fn asphalt(grain: f32) -> Rgb {
    let v = 0.085 * grain;
    [v, v, v * 1.04]
}

const PAINT: f32 = 0.62;

pub(super) fn zebra(offset: f32, grain: f32, road: Road) -> Rgb {
    // Stripes 0.5 m wide every metre across the drivable width.
    if offset.abs() < road.half_width_m() - 0.3 && modulo(offset, 1.0) < 0.5 {
        [PAINT * grain; 3]
    } else {
        asphalt(grain)
    }
}

pub(super) fn lane_marking(offset: f32, along: f32, road: Road, grain: f32) -> Rgb {
    let a = offset.abs();
    let lanes_edge = f32::from(road.lanes_per_dir) * LANE_WIDTH_M;
    let dashed = modulo(along, 9.0) < 3.0;
    let centre = a < 0.1;
    let divider = road.lanes_per_dir > 1 && (a - LANE_WIDTH_M).abs() < 0.07 && dashed;
    let edge = (a - lanes_edge).abs() < 0.07;
    if centre || divider || edge { [PAINT * grain; 3] } else { asphalt(grain) }
}

/// `floor(x)` as an integer without a library call (baseline x86-64 has no rounding
/// instruction for `f32::floor`, and this runs per pixel). Exact for |x| < 2³¹; larger values
/// and NaN give the nearest end of that range (−2³¹ + 128 for NaN).
///
/// `x` is clamped into the range first, so the conversion needs no saturation: Rust's `as`
/// saturates, and LLVM cannot vectorise that on AVX2 (it became a compare and a branch per
/// lane in the ground pass's eight-wide loop).
#[inline(always)]
#[allow(unsafe_code)] // an unchecked conversion of a value already clamped into range
#[allow(clippy::manual_clamp)] // `clamp` passes NaN through; `max` then `min` does not
pub fn fast_floor(x: f32) -> i32 {
    const END: f32 = 2_147_483_520.0; // the largest f32 below 2³¹
    let c = x.max(-END).min(END);
    // SAFETY: `c` is not NaN (`max` returns the other operand) and lies in [−END, END], whose
    // truncation fits in an i32.
    let i = unsafe { c.to_int_unchecked::<i32>() };
    if (i as f32) > c { i - 1 } else { i }
}

/// `x mod m` in `[0, m)` for `m > 0`, without a library call.
#[inline(always)]
pub(super) fn modulo(x: f32, m: f32) -> f32 {
    x - fast_floor(x / m) as f32 * m
}

/// A uniform value in [0, 1) from the integer cell of `(x, y)`: texture without storage.
/// Branch-free, so that a loop of it vectorises.
#[inline(always)]
pub fn hash_unit(x: f32, y: f32) -> f32 {
    let (ix, iy) = (fast_floor(x) as u32, fast_floor(y) as u32);
    let mut h = ix.wrapping_mul(0x8da6_b343) ^ iy.wrapping_mul(0xd816_3841);
    h ^= h >> 13;
    h = h.wrapping_mul(0x5bd1_e995);
    h ^= h >> 15;
    // h >> 8 < 2²⁴: the signed conversion (one instruction, also in vectors) is exact.
    ((h >> 8) as i32) as f32 / (1u32 << 24) as f32
}

/// The ground's grain at world `(x, y)`: two octaves of value noise, coarse patches and fine
/// grain, ±10 % overall.
#[inline(always)]
pub fn ground_grain(x: f32, y: f32) -> f32 {
    0.9 + 0.12 * hash_unit(x * 1.3, y * 1.3) + 0.08 * hash_unit(x * 9.0, y * 9.0)
}

#[cfg(test)]
mod tests {
    use super::fast_floor;

    #[test]
    fn the_fast_floor_is_the_library_floor_in_range_and_clamps_outside() {
        let mut x = -3.0e6f32;
        while x < 3.0e6 {
            for v in [x, x + 0.5, x.next_up(), x.next_down()] {
                assert_eq!(fast_floor(v) as f32, v.floor(), "{v}");
            }
            x += 977.375;
        }
        for v in [-0.0f32, 0.0, -0.25, 0.999_999_9, -1.0, 2_147_483_520.0, -2_147_483_520.0] {
            assert_eq!(fast_floor(v) as f32, v.floor(), "{v}");
        }
        assert_eq!(fast_floor(3.0e9), 2_147_483_520);
        assert_eq!(fast_floor(f32::NEG_INFINITY), -2_147_483_520);
        assert_eq!(fast_floor(f32::NAN), -2_147_483_520);
    }
}
