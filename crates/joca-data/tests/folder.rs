//! The folder format: a generated sequence is read, resized to a camera and blurred; bad input is
//! refused or skipped with the file named.
#![allow(clippy::unwrap_used)]

use joca_core::{FrameRequest, FrameSource, PinholeCamera};
use joca_data::blur::Linearize;
use joca_data::folder::{FolderConfig, OnBadFrame, Recording};
use std::path::Path;

/// Writes `n` frames of 200×100: a bright 40×20 "vehicle" with two dark 4-px "windows" (so that
/// optical flow can see it move; a uniform block is ill-posed for any flow method) moving 4 px
/// per frame to the right over a textured background, and a 30×20 crowd region of cars at
/// (120, 10); timestamps 0.1 s apart; exposures 5 ms.
fn write_sequence(dir: &Path, n: usize, exposure: bool) {
    std::fs::create_dir_all(dir.join("frames")).unwrap();
    let mut images = Vec::new();
    let mut annotations = Vec::new();
    for k in 0..n {
        let x0 = 40 + 4 * k as u32;
        let img = image::RgbImage::from_fn(200, 100, |x, y| {
            let window = (x0 + 6..x0 + 10).contains(&x) || (x0 + 30..x0 + 34).contains(&x);
            if window && (42..50).contains(&y) {
                image::Rgb([60, 70, 90])
            } else if (x0..x0 + 40).contains(&x) && (40..60).contains(&y) {
                image::Rgb([220, 200, 180])
            } else {
                let v = (60.0 + 30.0 * ((x as f32 * 0.3).sin() + (y as f32 * 0.45).cos())) as u8;
                image::Rgb([v, v, v])
            }
        });
        let name = format!("frames/{k:03}.png");
        img.save(dir.join(&name)).unwrap();
        let mut image = serde_json::json!({"id": k + 1, "file_name": name, "width": 200,
            "height": 100, "timestamp_s": 10.0 + 0.1 * k as f64});
        if exposure {
            image["exposure_s"] = serde_json::json!(0.005);
        }
        images.push(image);
        annotations.push(serde_json::json!({"id": k + 1, "image_id": k + 1,
            "bbox": [x0, 40, 40, 20], "category_id": 7}));
        annotations.push(serde_json::json!({"id": 1000 + k, "image_id": k + 1,
            "bbox": [120, 10, 30, 20], "category_id": 7, "iscrowd": 1}));
    }
    let coco = serde_json::json!({"images": images, "annotations": annotations,
        "categories": [{"id": 7, "name": "car"},
            {"id": 8, "name": "traffic light", "joca_class": "ignore"}]});
    std::fs::write(dir.join("annotations.json"), coco.to_string()).unwrap();
}

fn camera(w: usize, h: usize) -> PinholeCamera {
    PinholeCamera::centred((w, h), (50.0, 50.0), [0.43, 0.0, 1.65])
}

#[test]
fn crowd_regions_become_ignore_regions_and_small_boxes_stay_reference_objects() {
    let dir = tempfile::tempdir().unwrap();
    write_sequence(dir.path(), 3, true);
    let src = Recording::open(dir.path(), FolderConfig::default()).unwrap();
    let sharp = FrameRequest { episode: 0, time_s: 0.0, exposure_s: 0.0, motion_scale: 1.0 };
    // 80×60: the 4:3 crop is 133⅓ px wide from x = 33⅓, scaled by 0.6; the vehicle (24×12 px)
    // stays a box.
    let f = src.render(&camera(80, 60), &sharp).unwrap();
    assert_eq!((f.boxes.len(), f.ignore.len()), (1, 1));
    let r = f.ignore[0].bbox;
    let s = 0.6;
    let crop_x = (200.0 - 100.0 * 4.0 / 3.0) / 2.0;
    assert!((r.x_min - (120.0 - crop_x) * s).abs() < 0.01 && (r.y_min - 10.0 * s).abs() < 0.01);
    assert!((r.width() - 30.0 * s).abs() < 0.01 && (r.height() - 20.0 * s).abs() < 0.01);
    // 20×15: scale 0.15; the vehicle is 6×3 px, too small to train on but still a reference
    // object (a miss if undetected), so every design is scored on the same objects.
    let f = src.render(&camera(20, 15), &sharp).unwrap();
    assert_eq!((f.boxes.len(), f.ignore.len()), (1, 1));
    assert!((f.boxes[0].bbox.width() - 40.0 * 0.15).abs() < 0.01, "{:?}", f.boxes);
    // The TP ratio still counts the vehicle as an object of the recorded frame.
    assert_eq!(f.visible_180, 1);
}

#[test]
fn a_generated_sequence_is_cropped_resized_calibrated_and_blurred() {
    let dir = tempfile::tempdir().unwrap();
    write_sequence(dir.path(), 6, true);
    let config = FolderConfig { linearize: Linearize::None, ..FolderConfig::default() };
    let src = Recording::open(dir.path(), config).unwrap();
    assert_eq!(src.sequences().len(), 1);
    assert!((src.frame_interval_s() - 0.1).abs() < 1e-9);
    assert_eq!(src.recording_size_px(), (200, 100));
    // A 4:3 camera of 80×60: the 200×100 frame is centre-cropped to 133×100 (x from 33.5) and
    // scaled by 60/100.
    let sharp = FrameRequest { episode: 0, time_s: 0.0, exposure_s: 0.0, motion_scale: 1.0 };
    let f = src.render(&camera(80, 60), &sharp).unwrap();
    assert_eq!((f.hdr.width(), f.hdr.height()), (80, 60));
    assert_eq!(f.boxes.len(), 1);
    let b = f.boxes[0].bbox;
    let s = 60.0 / 100.0;
    assert!((b.x_min - (40.0 - 33.5) * s).abs() < 0.6 && (b.y_min - 40.0 * s).abs() < 0.6, "{b:?}");
    assert!(((b.x_max - b.x_min) - 40.0 * s).abs() < 1.2);
    // Recorded at E0 and G0 (defaults), linear: the vehicle keeps its recorded value.
    let inside = f.hdr.pixel(((b.x_min + b.x_max) / 2.0) as usize, 30);
    assert!((inside[0] - 220.0).abs() < 3.0, "{inside:?}");
    // A shutter of 1.5 frame intervals smears the vehicle over 1.5 × 4 × 0.6 = 3.6 px: its edge
    // pixels fall between vehicle and background, and more sub-samples are used. The blur follows
    // the estimated flow, and DIS sees only part of the motion of a textureless box (OpenCV's
    // DIS `fast` finds 1.7 of its 4 px): with the true flow the pixel past the edge would gain
    // ~44 DN, with joca's estimate it gains 17–20; the bound asks for a clearly visible smear.
    let blurred = src.render(&camera(80, 60), &FrameRequest { exposure_s: 0.15, ..sharp }).unwrap();
    assert!(blurred.subframes > 1);
    let edge = (b.x_max as usize).min(79);
    let (a, c) = (f.hdr.pixel(edge + 1, 30)[0], blurred.hdr.pixel(edge + 1, 30)[0]);
    assert!(c > a + 12.0, "edge pixel after blur {c} vs sharp {a}");
    // Recorded with twice E0: in calibrated units (what E0, G0 would record) it is half.
    let text = std::fs::read_to_string(dir.path().join("annotations.json")).unwrap();
    std::fs::write(dir.path().join("annotations.json"), text.replace("0.005", "0.01")).unwrap();
    let src = Recording::open(
        dir.path(),
        FolderConfig { linearize: Linearize::None, ..FolderConfig::default() },
    )
    .unwrap();
    let half = src.render(&camera(80, 60), &sharp).unwrap();
    let v = half.hdr.pixel(((b.x_min + b.x_max) / 2.0) as usize, 30)[0];
    assert!((v - inside[0] / 2.0).abs() < 0.01, "{v} vs {}", inside[0]);
}

#[test]
fn missing_exposure_bad_frames_and_unknown_categories_are_named() {
    let dir = tempfile::tempdir().unwrap();
    write_sequence(dir.path(), 4, false);
    let e = Recording::open(dir.path(), FolderConfig::default()).unwrap_err().to_string();
    assert!(e.contains("has no exposure_s") && e.contains("default exposure"), "{e}");
    let ok = Recording::open(
        dir.path(),
        FolderConfig { default_exposure_s: Some(0.005), ..FolderConfig::default() },
    );
    assert!(ok.is_ok());

    write_sequence(dir.path(), 4, true);
    std::fs::write(dir.path().join("frames/002.png"), b"not a png at all").unwrap();
    let e = Recording::open(dir.path(), FolderConfig::default()).unwrap_err().to_string();
    assert!(e.contains("frames/002.png") && e.contains("cannot decode frame"), "{e}");
    let skip = Recording::open(
        dir.path(),
        FolderConfig { on_bad_frame: OnBadFrame::Skip, ..FolderConfig::default() },
    )
    .unwrap();
    assert_eq!(skip.len(), 3);
    assert!(skip.skipped[0].contains("frames/002.png"), "{:?}", skip.skipped);

    let text = std::fs::read_to_string(dir.path().join("annotations.json")).unwrap();
    std::fs::write(dir.path().join("annotations.json"), text.replace("\"car\"", "\"zeppelin\""))
        .unwrap();
    let e = Recording::open(
        dir.path(),
        FolderConfig { on_bad_frame: OnBadFrame::Skip, ..FolderConfig::default() },
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("annotations.json")
            && e.contains("\"zeppelin\" is not a joca class")
            && e.contains("joca_class"),
        "{e}"
    );
}

/// A `file_name` that points outside the dataset folder — `..`, an absolute path, or a symbolic
/// link inside the folder leading out — stops the opening with the annotation file and the
/// name, whatever `on_bad_frame` says, and nothing outside is read.
#[test]
fn file_names_leading_outside_the_dataset_folder_are_refused() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("rec");
    write_sequence(&dir, 3, true);
    let outside = root.path().join("outside");
    std::fs::create_dir_all(&outside).unwrap();
    std::fs::copy(dir.join("frames/000.png"), outside.join("x.png")).unwrap();
    std::os::unix::fs::symlink(&outside, dir.join("link")).unwrap();
    let json = dir.join("annotations.json");
    let original = std::fs::read_to_string(&json).unwrap();
    let absolute = outside.join("x.png").display().to_string();
    for name in ["../outside/x.png", absolute.as_str(), "frames/../../outside/x.png", "link/x.png"]
    {
        let text = original.replace("frames/001.png", name);
        std::fs::write(&json, text).unwrap();
        for on_bad_frame in [OnBadFrame::Stop, OnBadFrame::Skip] {
            let e = Recording::open(&dir, FolderConfig { on_bad_frame, ..FolderConfig::default() })
                .unwrap_err()
                .to_string();
            assert!(e.contains("annotations.json") && e.contains(name), "{name}: {e}");
            assert!(e.contains("dataset folder"), "{name}: {e}");
        }
    }
    // A name inside the folder still opens.
    std::fs::write(&json, original.replace("frames/001.png", "./frames/001.png")).unwrap();
    assert!(Recording::open(&dir, FolderConfig::default()).is_ok());
}

/// A box with no area, a negative size, a NaN, or one that reaches outside its image, and a box
/// of an image the file does not declare, stop the opening naming the file and the box.
#[test]
fn boxes_outside_the_image_or_without_area_are_refused() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("rec");
    write_sequence(&dir, 3, true);
    let json = dir.join("annotations.json");
    let original = std::fs::read_to_string(&json).unwrap();
    // The first frame's vehicle is at [40, 40, 40, 20] in a 200×100 image.
    for (bbox, why) in [
        ("[40,40,0,20]", "above 0"),
        ("[40,40,-40,20]", "above 0"),
        ("[180,40,40,20]", "outside the 200×100 image"),
        ("[40,-30,40,20]", "outside the 200×100 image"),
    ] {
        std::fs::write(&json, original.replacen("[40,40,40,20]", bbox, 1)).unwrap();
        let e = Recording::open(&dir, FolderConfig::default()).unwrap_err().to_string();
        assert!(e.contains("annotations.json") && e.contains(why), "{bbox}: {e}");
    }
    std::fs::write(&json, original.replacen("\"image_id\":1,", "\"image_id\":99,", 1)).unwrap();
    let e = Recording::open(&dir, FolderConfig::default()).unwrap_err().to_string();
    assert!(e.contains("image_id 99"), "{e}");
    std::fs::write(&json, &original).unwrap();
    assert!(Recording::open(&dir, FolderConfig::default()).is_ok());
}

/// Recorded settings out of any camera's range, an id declared twice and two images naming one
/// file are refused naming the image and the field (a whole run once trained on such a folder's
/// black frames without a word).
#[test]
fn impossible_settings_and_duplicate_images_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    write_sequence(dir.path(), 3, true);
    let path = dir.path().join("annotations.json");
    let good: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let open_with = |edit: &dyn Fn(&mut serde_json::Value)| {
        let mut coco = good.clone();
        edit(&mut coco);
        std::fs::write(&path, coco.to_string()).unwrap();
        Recording::open(dir.path(), FolderConfig::default()).map(|_| ()).map_err(|e| e.to_string())
    };
    assert!(open_with(&|_| {}).is_ok());
    for (field, value, shown, allowed) in [
        ("gain_db", 1e300, "1e300", "allowed from -20 to 60"),
        ("gain_db", -21.0, "-21", "allowed from -20 to 60"),
        ("exposure_s", 1e300, "1e300", "allowed above 0 to 10"),
        ("exposure_s", 0.0, "0", "allowed above 0 to 10"),
        ("timestamp_s", -1e300, "-1e300", "allowed from -1e10 to 1e10"),
    ] {
        let e = open_with(&|c| c["images"][1][field] = serde_json::json!(value)).unwrap_err();
        assert!(
            e.contains("annotations.json")
                && e.contains(&format!("image 2 (frames/001.png) has {field} = {shown};"))
                && e.contains(allowed),
            "{e}"
        );
    }
    let e = open_with(&|c| c["images"][2]["id"] = serde_json::json!(1)).unwrap_err();
    assert!(e.contains("image id 1 is declared twice"), "{e}");
    for name in ["frames/000.png", "frames/./000.png"] {
        let e = open_with(&|c| c["images"][2]["file_name"] = serde_json::json!(name)).unwrap_err();
        assert!(e.contains("image 3: file_name") && e.contains("another image's"), "{e}");
    }
}
