//! Flow fields on disk, and their error against ground truth.
//!
//! - Middlebury `.flo` (Baker et al., "A Database and Evaluation Methodology for Optical Flow"):
//!   the float32 202021.25 (bytes "PIEH" little-endian), int32 width, int32 height, then
//!   `width·height` pairs `(u, v)` of float32, row-major, little-endian. OpenCV's
//!   `readOpticalFlow`/`writeOpticalFlow` use it. Vectors with a component above 1e9 (or not
//!   finite) are unknown.
//! - Ground-truth disparity of a rectified stereo pair (left → right): flow `(−d, 0)`. Read from
//!   NumPy `.npy` (float32/float64, 2-D, C order) or PFM (`Pf`, bottom row first, scale sign =
//!   endianness); non-finite and non-positive disparities are unknown.
//!
//! A file is written whole or not at all: to a temporary name next to it, then renamed.

use super::Flow;
use crate::DataError;
use std::path::Path;

/// The `.flo` magic number.
pub const FLO_MAGIC: f32 = 202_021.25;
/// Components above this are unknown (Middlebury's `UNKNOWN_FLOW_THRESH`).
pub const UNKNOWN_FLOW: f32 = 1e9;
/// Largest side a flow file may declare.
const MAX_SIDE: usize = 1 << 15;

fn err(path: &Path, reason: impl Into<String>) -> DataError {
    DataError::invalid(path, reason)
}

/// Writes `flow` as a Middlebury `.flo` file.
pub fn write_flo(path: &Path, flow: &Flow) -> Result<(), DataError> {
    joca_core::fs::write_atomic(path, &flo_bytes(flow)).map_err(DataError::io(path, "write"))
}

/// The Middlebury `.flo` encoding of `flow` (what [`write_flo`] writes).
pub fn flo_bytes(flow: &Flow) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(12 + 8 * flow.data().len());
    bytes.extend_from_slice(&FLO_MAGIC.to_le_bytes());
    bytes.extend_from_slice(&(flow.width() as i32).to_le_bytes());
    bytes.extend_from_slice(&(flow.height() as i32).to_le_bytes());
    for v in flow.data() {
        bytes.extend_from_slice(&v[0].to_le_bytes());
        bytes.extend_from_slice(&v[1].to_le_bytes());
    }
    bytes
}

/// A flow field whose vectors may be unknown (`None`).
pub type KnownFlow = (usize, usize, Vec<Option<[f32; 2]>>);

fn known(v: [f32; 2]) -> Option<[f32; 2]> {
    (v[0].is_finite()
        && v[1].is_finite()
        && v[0].abs() <= UNKNOWN_FLOW
        && v[1].abs() <= UNKNOWN_FLOW)
        .then_some(v)
}

/// Reads a Middlebury `.flo` file; unknown vectors are `None`.
pub fn read_flo(path: &Path) -> Result<KnownFlow, DataError> {
    let bytes = std::fs::read(path).map_err(DataError::io(path, "read"))?;
    if bytes.len() < 12 {
        return Err(err(path, format!("{} bytes: too short for a .flo header (12)", bytes.len())));
    }
    let word = |i: usize| [bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]];
    let magic = f32::from_le_bytes(word(0));
    if magic != FLO_MAGIC {
        return Err(err(
            path,
            format!(
                "not a Middlebury .flo file: magic {magic} (bytes {:?}), expected 202021.25 (\"PIEH\")",
                word(0)
            ),
        ));
    }
    let (w, h) = (i32::from_le_bytes(word(4)), i32::from_le_bytes(word(8)));
    if !(1..=MAX_SIDE as i32).contains(&w) || !(1..=MAX_SIDE as i32).contains(&h) {
        return Err(err(path, format!("size {w}×{h}: each side must be 1 to {MAX_SIDE}")));
    }
    let (w, h) = (w as usize, h as usize);
    let expected = 12 + 8 * w * h;
    if bytes.len() != expected {
        return Err(err(
            path,
            format!("{} bytes, but a {w}×{h} field takes {expected} (12 + 8·w·h)", bytes.len()),
        ));
    }
    let data = (0..w * h)
        .map(|k| {
            let u = f32::from_le_bytes(word(12 + 8 * k));
            let v = f32::from_le_bytes(word(16 + 8 * k));
            known([u, v])
        })
        .collect();
    Ok((w, h, data))
}

/// Reads a ground-truth disparity map (`.npy` or `.pfm`) as the flow `(−d, 0)` of the left
/// image; unknown where `d` is not finite or not positive.
pub fn read_disparity(path: &Path) -> Result<KnownFlow, DataError> {
    let bytes = std::fs::read(path).map_err(DataError::io(path, "read"))?;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let (w, h, d) = match ext.as_str() {
        "npy" => parse_npy(&bytes).map_err(|r| err(path, r))?,
        "pfm" => parse_pfm(&bytes).map_err(|r| err(path, r))?,
        _ => return Err(err(path, "a disparity map must be .npy (NumPy) or .pfm")),
    };
    let data = d.into_iter().map(|d| (d.is_finite() && d > 0.0).then_some([-d, 0.0])).collect();
    Ok((w, h, data))
}

/// A 2-D float32/float64 NumPy array, C order.
fn parse_npy(b: &[u8]) -> Result<(usize, usize, Vec<f32>), String> {
    if b.len() < 10 || &b[..6] != b"\x93NUMPY" {
        return Err("not a NumPy .npy file (no \\x93NUMPY magic)".into());
    }
    let (header_len, start) = match b[6] {
        1 => (usize::from(u16::from_le_bytes([b[8], b[9]])), 10usize),
        2 | 3 if b.len() >= 12 => (u32::from_le_bytes([b[8], b[9], b[10], b[11]]) as usize, 12),
        v => return Err(format!(".npy version {v} is not supported (1 to 3)")),
    };
    let header = b
        .get(start..start.saturating_add(header_len))
        .map(String::from_utf8_lossy)
        .ok_or("the .npy header is cut short")?;
    let descr = field(&header, "descr").ok_or("the .npy header has no descr")?;
    let width = match descr.trim_matches(['\'', '"']) {
        "<f4" => 4,
        "<f8" => 8,
        other => return Err(format!("dtype {other} is not supported (<f4 or <f8)")),
    };
    if field(&header, "fortran_order").is_some_and(|v| v.starts_with("True")) {
        return Err("Fortran-ordered arrays are not supported".into());
    }
    let shape = header
        .split("'shape':")
        .nth(1)
        .and_then(|s| s.split(')').next())
        .ok_or("the .npy header has no shape")?;
    let dims: Vec<usize> = shape
        .trim_start_matches([' ', '('])
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().map_err(|_| format!("bad shape entry {s:?}")))
        .collect::<Result<_, _>>()?;
    let [h, w] = dims[..] else {
        return Err(format!("a disparity map is 2-D; this array has shape {dims:?}"));
    };
    if !(1..=MAX_SIDE).contains(&w) || !(1..=MAX_SIDE).contains(&h) {
        return Err(format!("shape ({h}, {w}): each side must be 1 to {MAX_SIDE}"));
    }
    let body = &b[start + header_len..]; // inside `b`: the header slice above exists
    let expected = sized(&[w, h, width])?;
    if body.len() != expected {
        return Err(format!(
            "{} data bytes, but {h}×{w} of {width} bytes take {expected}",
            body.len()
        ));
    }
    let values = body
        .chunks_exact(width)
        .map(|c| {
            if width == 4 {
                f32::from_le_bytes([c[0], c[1], c[2], c[3]])
            } else {
                f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]) as f32
            }
        })
        .collect();
    Ok((w, h, values))
}

fn field<'a>(header: &'a str, key: &str) -> Option<&'a str> {
    let rest = header.split(&format!("'{key}':")).nth(1)?;
    Some(rest.trim_start().split(',').next()?.trim())
}

/// The product of a header's sizes, refused (not wrapped) where it overflows.
fn sized(factors: &[usize]) -> Result<usize, String> {
    factors
        .iter()
        .try_fold(1usize, |p, &f| p.checked_mul(f))
        .ok_or_else(|| format!("sizes {factors:?} overflow: the header is corrupt"))
}

/// A one-channel PFM (`Pf`): header lines, then rows bottom first.
fn parse_pfm(b: &[u8]) -> Result<(usize, usize, Vec<f32>), String> {
    let mut lines = 0;
    let mut end = 0;
    while lines < 3 {
        let next =
            b[end..].iter().position(|&c| c == b'\n').ok_or("the PFM header is cut short")?;
        end += next + 1;
        lines += 1;
    }
    let header = String::from_utf8_lossy(&b[..end]);
    let mut tokens = header.split_whitespace();
    match tokens.next() {
        Some("Pf") => {}
        Some("PF") => return Err("a colour PFM (PF) is not a disparity map; expected Pf".into()),
        _ => return Err("not a PFM file (no Pf header)".into()),
    }
    let mut token = |what: &str| tokens.next().ok_or(format!("the PFM header has no {what}"));
    let mut side = |what: &str| -> Result<usize, String> {
        let t = token(what)?;
        t.parse::<usize>()
            .ok()
            .filter(|v| (1..=MAX_SIDE).contains(v))
            .ok_or(format!("PFM {what} {t:?}: must be a whole number from 1 to {MAX_SIDE}"))
    };
    let (w, h) = (side("width")?, side("height")?);
    let scale: f64 = tokens
        .next()
        .and_then(|t| t.parse().ok())
        .filter(|v: &f64| v.is_finite() && *v != 0.0)
        .ok_or("the PFM header has no scale (a finite number other than 0)")?;
    let body = &b[end..];
    let floats = sized(&[w, h, 4])?;
    if body.len() != floats {
        return Err(format!("{} data bytes, but {w}×{h} floats take {floats}", body.len()));
    }
    let little = scale < 0.0;
    let mut values = vec![0.0f32; w * h];
    for (k, c) in body.chunks_exact(4).enumerate() {
        let raw = [c[0], c[1], c[2], c[3]];
        let v = if little { f32::from_le_bytes(raw) } else { f32::from_be_bytes(raw) };
        let (x, row) = (k % w, k / w);
        values[(h - 1 - row) * w + x] = v;
    }
    Ok((w, h, values))
}

/// End-point error of `estimate` against `truth` over the pixels where the truth is known.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlowAccuracy {
    /// Mean end-point error, pixels.
    pub epe: f64,
    /// Share of the known pixels with an end-point error above 3 px.
    pub above_3px: f64,
    /// Pixels with known truth.
    pub known: usize,
}

/// Scores `estimate` against `truth` (same size).
pub fn accuracy(estimate: &Flow, truth: &KnownFlow) -> Result<FlowAccuracy, String> {
    let (w, h, t) = truth;
    if (estimate.width(), estimate.height()) != (*w, *h) {
        return Err(format!(
            "the flow is {}×{} but the ground truth is {w}×{h}",
            estimate.width(),
            estimate.height()
        ));
    }
    let (mut sum, mut above, mut known) = (0.0f64, 0usize, 0usize);
    for (e, t) in estimate.data().iter().zip(t) {
        if let Some(t) = t {
            let d = f64::from(e[0] - t[0]).hypot(f64::from(e[1] - t[1]));
            sum += d;
            above += usize::from(d > 3.0);
            known += 1;
        }
    }
    if known == 0 {
        return Err("the ground truth has no known pixel".into());
    }
    Ok(FlowAccuracy { epe: sum / known as f64, above_3px: above as f64 / known as f64, known })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `.flo` assembled byte by byte from the Middlebury description reads back as written,
    /// and `write_flo` produces exactly those bytes.
    #[test]
    fn flo_files_follow_the_middlebury_layout() {
        let dir = tempfile::tempdir().unwrap();
        let mut bytes = b"PIEH".to_vec();
        bytes.extend_from_slice(&3i32.to_le_bytes());
        bytes.extend_from_slice(&2i32.to_le_bytes());
        let vectors =
            [[1.5f32, -2.0], [0.0, 0.25], [1e10, 0.0], [-3.0, 4.0], [0.5, 0.5], [7.0, -7.0]];
        for v in vectors {
            bytes.extend_from_slice(&v[0].to_le_bytes());
            bytes.extend_from_slice(&v[1].to_le_bytes());
        }
        let path = dir.path().join("hand.flo");
        std::fs::write(&path, &bytes).unwrap();
        let (w, h, data) = read_flo(&path).unwrap();
        assert_eq!((w, h), (3, 2));
        assert_eq!(data[0], Some([1.5, -2.0]));
        assert_eq!(data[2], None, "a component above 1e9 is unknown");
        assert_eq!(data[5], Some([7.0, -7.0]));
        let flow = Flow::new(3, 2, vectors.to_vec());
        let out = dir.path().join("out.flo");
        write_flo(&out, &flow).unwrap();
        assert_eq!(std::fs::read(&out).unwrap(), bytes);
        assert!(!dir.path().join("out.flo.partial").exists());
    }

    #[test]
    fn a_bad_flo_is_named_with_what_is_wrong() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.flo");
        let mut bytes = b"PIEX".to_vec();
        bytes.extend_from_slice(&[0; 8]);
        std::fs::write(&path, &bytes).unwrap();
        let e = read_flo(&path).unwrap_err().to_string();
        assert!(e.contains("bad.flo") && e.contains("not a Middlebury .flo"), "{e}");
        let mut bytes = b"PIEH".to_vec();
        bytes.extend_from_slice(&4i32.to_le_bytes());
        bytes.extend_from_slice(&4i32.to_le_bytes());
        bytes.extend_from_slice(&[0; 100]);
        std::fs::write(&path, &bytes).unwrap();
        let e = read_flo(&path).unwrap_err().to_string();
        assert!(e.contains("112 bytes, but a 4×4 field takes 140"), "{e}");
    }

    #[test]
    fn disparity_maps_become_leftward_flow_and_unknown_where_invalid() {
        let dir = tempfile::tempdir().unwrap();
        // NumPy 1.0 header for a (2, 3) float32 array, padded to 64 bytes as numpy does.
        let mut header = "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }".to_owned();
        while !(10 + header.len() + 1).is_multiple_of(64) {
            header.push(' ');
        }
        header.push('\n');
        let mut npy = b"\x93NUMPY\x01\x00".to_vec();
        npy.extend_from_slice(&(header.len() as u16).to_le_bytes());
        npy.extend_from_slice(header.as_bytes());
        for d in [10.0f32, f32::INFINITY, 0.0, 2.5, 3.0, -1.0] {
            npy.extend_from_slice(&d.to_le_bytes());
        }
        let path = dir.path().join("disp.npy");
        std::fs::write(&path, &npy).unwrap();
        let (w, h, data) = read_disparity(&path).unwrap();
        assert_eq!((w, h), (3, 2));
        assert_eq!(
            data,
            [Some([-10.0, 0.0]), None, None, Some([-2.5, 0.0]), Some([-3.0, 0.0]), None]
        );
        // The same map as a little-endian PFM, bottom row first.
        let mut pfm = b"Pf\n3 2\n-1.0\n".to_vec();
        for d in [2.5f32, 3.0, -1.0, 10.0, f32::INFINITY, 0.0] {
            pfm.extend_from_slice(&d.to_le_bytes());
        }
        let path = dir.path().join("disp.pfm");
        std::fs::write(&path, &pfm).unwrap();
        assert_eq!(read_disparity(&path).unwrap().2, data);
        // Accuracy over the known pixels: errors 0, 2.5 (hypot of 1.5 and 2), 4 (above 3 px).
        let estimate = Flow::new(
            3,
            2,
            vec![[-10.0, 0.0], [0.0, 0.0], [0.0, 0.0], [-1.0, 2.0], [1.0, 0.0], [0.0, 0.0]],
        );
        let a = accuracy(&estimate, &(w, h, data)).unwrap();
        assert_eq!(a.known, 3);
        assert!((a.epe - 6.5 / 3.0).abs() < 1e-9 && (a.above_3px - 1.0 / 3.0).abs() < 1e-12);
    }
}
