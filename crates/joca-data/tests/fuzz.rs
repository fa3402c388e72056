//! Property tests of the folder reader: whatever `annotations.json` holds — random bytes, or
//! COCO-shaped JSON with wrong types, huge or negative numbers, boxes anywhere, file names that
//! point out of the folder — `Recording::open` returns a recording or an error naming the file,
//! and never panics or opens anything outside the folder.
#![allow(clippy::unwrap_used)]

use joca_data::folder::{FolderConfig, Recording};
use proptest::prelude::*;
use serde_json::{Value, json};
use std::path::Path;

/// A folder with two real 40×30 frames; `annotations.json` is written by each case.
fn folder() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("frames")).unwrap();
    for k in 0..2 {
        let img =
            image::RgbImage::from_fn(40, 30, |x, y| image::Rgb([x as u8 * 6, y as u8 * 8, 90]));
        img.save(dir.path().join(format!("frames/{k}.png"))).unwrap();
    }
    dir
}

fn number() -> impl Strategy<Value = Value> {
    prop_oneof![
        any::<i64>().prop_map(|v| json!(v)),
        any::<f64>().prop_filter("JSON has no NaN", |v| v.is_finite()).prop_map(|v| json!(v)),
        prop_oneof![Just(0.0), Just(-1.0), Just(1.5), Just(40.0), Just(1e300)]
            .prop_map(|v| json!(v)),
        Just(json!("7")),
        Just(Value::Null),
    ]
}

fn file_name() -> impl Strategy<Value = Value> {
    prop_oneof![
        Just(json!("frames/0.png")),
        Just(json!("frames/1.png")),
        Just(json!("frames/missing.png")),
        Just(json!("../outside.png")),
        Just(json!("/etc/passwd")),
        Just(json!("")),
        "[a-z./]{0,12}".prop_map(|s| json!(s)),
    ]
}

fn image() -> impl Strategy<Value = Value> {
    (number(), file_name(), number(), number(), number(), number()).prop_map(
        |(id, file_name, width, height, t, e)| {
            json!({"id": id, "file_name": file_name, "width": width, "height": height,
                   "timestamp_s": t, "exposure_s": e})
        },
    )
}

fn annotation() -> impl Strategy<Value = Value> {
    (number(), prop::collection::vec(number(), 0..6), number(), number()).prop_map(
        |(image_id, bbox, category_id, iscrowd)| {
            json!({"image_id": image_id, "bbox": bbox, "category_id": category_id,
                   "iscrowd": iscrowd})
        },
    )
}

fn coco() -> impl Strategy<Value = Value> {
    (
        prop::collection::vec(image(), 0..4),
        prop::collection::vec(annotation(), 0..6),
        prop::collection::vec((number(), "[a-z_]{0,12}"), 0..4),
    )
        .prop_map(|(images, annotations, categories)| {
            let categories: Vec<Value> =
                categories.into_iter().map(|(id, name)| json!({"id": id, "name": name})).collect();
            json!({"images": images, "annotations": annotations, "categories": categories})
        })
}

fn open(dir: &Path, text: &[u8]) {
    std::fs::write(dir.join("annotations.json"), text).unwrap();
    if let Err(e) = Recording::open(dir, FolderConfig::default()) {
        let e = e.to_string();
        assert!(!e.is_empty());
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 500, ..ProptestConfig::default() })]

    #[test]
    fn coco_shaped_annotations_never_panic(v in coco()) {
        let dir = folder();
        open(dir.path(), v.to_string().as_bytes());
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let dir = folder();
        open(dir.path(), &bytes);
    }
}

/// A header size token: ordinary, zero, negative, past the limit, past `usize`, or not a number.
fn size_token() -> impl Strategy<Value = String> {
    prop_oneof![
        (1u32..6).prop_map(|v| v.to_string()),
        Just("0".to_owned()),
        Just("-3".to_owned()),
        Just("32769".to_owned()),
        Just("4294967296".to_owned()),
        Just("18446744073709551615".to_owned()),
        Just("99999999999999999999999".to_owned()),
        Just("1e30".to_owned()),
        Just("x".to_owned()),
    ]
}

/// Reads a disparity file holding `bytes` as `name`: a map whose size matches the header, or an
/// error naming the file; never a panic or an allocation the header alone asks for.
fn read_disparity(name: &str, bytes: &[u8]) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    match joca_data::flow::read_disparity(&path) {
        Ok((w, h, values)) => assert_eq!(values.len(), w * h),
        Err(e) => assert!(e.to_string().contains(name), "{e}"),
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn pfm_headers_never_panic(
        w in size_token(),
        h in size_token(),
        scale in prop_oneof![Just("-1.0"), Just("1"), Just("0"), Just("nan"), Just("")],
        body in prop::collection::vec(any::<u8>(), 0..80),
    ) {
        let mut bytes = format!("Pf\n{w} {h}\n{scale}\n").into_bytes();
        bytes.extend_from_slice(&body);
        read_disparity("d.pfm", &bytes);
    }

    #[test]
    fn npy_headers_never_panic(
        w in size_token(),
        h in size_token(),
        body in prop::collection::vec(any::<u8>(), 0..80),
    ) {
        let header = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({h}, {w}), }}");
        let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
        bytes.extend_from_slice(&u16::try_from(header.len()).unwrap().to_le_bytes());
        bytes.extend_from_slice(header.as_bytes());
        bytes.extend_from_slice(&body);
        read_disparity("d.npy", &bytes);
    }
}

#[test]
fn a_pfm_whose_size_overflows_is_refused_naming_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("huge.pfm");
    // 2^32 × 2^32 × 4 wraps to 0 in 64 bits: the old size check accepted an empty body.
    std::fs::write(&path, b"Pf\n4294967296 4294967296\n-1.0\n").unwrap();
    let e = joca_data::flow::read_disparity(&path).unwrap_err().to_string();
    assert!(e.contains("huge.pfm") && e.contains("1 to 32768"), "{e}");
}
