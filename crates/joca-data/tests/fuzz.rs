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
