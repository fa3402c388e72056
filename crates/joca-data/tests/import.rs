//! Importers: KITTI tracking labels and labelme JSON written by the tests become the folder
//! format, read back by the folder source with the same boxes; bad input names the file (and
//! line) and what is wrong.
#![allow(clippy::unwrap_used)]

use joca_core::{BBox, Class};
use joca_data::folder::{FolderConfig, Recording};
use joca_data::import::{kitti_tracking, labelme};
use std::path::Path;

fn png(path: &Path, w: u32, h: u32) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    image::RgbImage::from_fn(w, h, |x, y| image::Rgb([(x * 3) as u8, (y * 5) as u8, 90]))
        .save(path)
        .unwrap();
}

fn open(dir: &Path) -> Recording {
    let config = FolderConfig { default_exposure_s: Some(0.005), ..FolderConfig::default() };
    Recording::open(dir, config).unwrap()
}

/// A KITTI tracking sequence `0007` of three 60×40 frames.
fn kitti(dir: &Path, labels: &str) -> (std::path::PathBuf, std::path::PathBuf) {
    let images = dir.join("image_02/0007");
    for k in 0..3 {
        png(&images.join(format!("{k:06}.png")), 60, 40);
    }
    let file = dir.join("label_02/0007.txt");
    std::fs::create_dir_all(file.parent().unwrap()).unwrap();
    std::fs::write(&file, labels).unwrap();
    (file, images)
}

const KITTI: &str = "\
0 1 Car 0 0 -1.5 10.5 12.0 30.0 25.0 1.5 1.6 3.9 1.0 1.5 20.0 -1.5
0 2 Pedestrian 0 1 0.2 40.0 5.0 46.0 20.0 1.8 0.6 0.8 5.0 1.6 15.0 0.1
0 -1 DontCare -1 -1 -10 50.0 30.0 59.0 39.0 -1000 -1000 -1000 -1000 -1000 -1000 -10

2 1 Van 0 0 -1.5 12.0 12.0 32.0 26.0 1.9 1.8 4.5 1.0 1.5 19.0 -1.5 0.93
";

#[test]
fn a_kitti_sequence_becomes_the_folder_format_with_its_boxes_and_ignore_regions() {
    let dir = tempfile::tempdir().unwrap();
    let (labels, images) = kitti(dir.path(), KITTI);
    let import = kitti_tracking(&labels, &images, 0.1).unwrap();
    assert_eq!(import.frames.len(), 3);
    assert_eq!(import.frames[2].timestamp_s, 0.2);
    assert_eq!(import.frames[0].file_name, "frames/0007/000000.png");
    assert_eq!(import.boxes.len(), 4);
    // KITTI's left, top, right, bottom as COCO x, y, w, h.
    assert_eq!(import.boxes[0].bbox, [10.5, 12.0, 19.5, 13.0]);
    let out = dir.path().join("folder");
    import.write_folder(&out, None).unwrap();
    let rec = open(&out);
    assert_eq!(rec.len(), 3);
    let seq = &rec.sequences()[0];
    assert_eq!(seq[0].boxes.len(), 2);
    assert_eq!(seq[0].boxes[0].bbox, BBox::new(10.5, 12.0, 30.0, 25.0));
    assert_eq!(seq[0].boxes[0].class, Class::Vehicle);
    assert_eq!(seq[0].boxes[1].class, Class::Walker);
    assert_eq!(seq[0].ignore.len(), 3, "DontCare is an ignore region of every class");
    assert!(seq[1].boxes.is_empty());
    assert_eq!(seq[2].boxes[0].class, Class::Vehicle);
    assert_eq!((seq[2].timestamp_s - seq[0].timestamp_s), 0.2);
    // The frames were copied, byte for byte.
    assert_eq!(
        std::fs::read(out.join("frames/0007/000001.png")).unwrap(),
        std::fs::read(images.join("000001.png")).unwrap()
    );
}

#[test]
fn bad_kitti_input_names_the_file_the_line_and_the_fault() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            "0 1 Bicycle 0 0 0 1 1 5 5 1 1 1 1 1 1 0\n",
            ":1: unknown type \"Bicycle\"; KITTI's are Car",
        ),
        (
            "\n0 1 Car 0 0 0 10 10 65 20 1 1 1 1 1 1 0\n",
            ":2: box [10.0, 10.0, 65.0, 20.0] reaches outside the 60×40 image",
        ),
        ("0 1 Car 0 0 0 10 10 5 20 1 1 1 1 1 1 0\n", ":1: box [10.0, 10.0, 5.0, 20.0] has no area"),
        ("5 1 Car 0 0 0 1 1 5 5 1 1 1 1 1 1 0\n", ":1: frame 5 has labels but"),
        ("0 1 Car 0 0 0 1 1 5 5\n", ":1: 10 fields; a KITTI tracking label has 17"),
    ];
    for (k, (text, want)) in cases.iter().enumerate() {
        let case = dir.path().join(format!("case{k}"));
        let (labels, images) = kitti(&case, text);
        let e = kitti_tracking(&labels, &images, 0.1).unwrap_err().to_string();
        assert!(e.contains("0007.txt") && e.contains(want), "{e}");
    }
    // A gap in the frame numbering.
    let (labels, images) = kitti(&dir.path().join("gap"), "");
    std::fs::remove_file(images.join("000001.png")).unwrap();
    let e = kitti_tracking(&labels, &images, 0.1).unwrap_err().to_string();
    assert!(e.contains("frames 1 to 1 are missing") && e.contains("gap in the numbering"), "{e}");
}

fn labelme_frame(dir: &Path, n: u32, shapes: serde_json::Value) {
    png(&dir.join(format!("{n:08}.png")), 80, 50);
    let file = serde_json::json!({
        "version": "5.8.3", "flags": {}, "shapes": shapes,
        "imagePath": format!("{n:08}.png"), "imageData": null,
        "imageHeight": 50, "imageWidth": 80,
    });
    std::fs::write(dir.join(format!("{n:08}.json")), file.to_string()).unwrap();
}

#[test]
fn labelme_polygons_rectangles_and_circles_become_boxes_and_labels_map_to_classes() {
    let dir = tempfile::tempdir().unwrap();
    let seq = dir.path().join("street");
    std::fs::create_dir_all(&seq).unwrap();
    let shapes = serde_json::json!([
        {"label": "track", "points": [[10, 20], [30, 5], [25, 40]], "shape_type": "polygon"},
        {"label": "person", "points": [[60, 30], [50, 10]], "shape_type": "rectangle"},
        {"label": "sign", "points": [[70, 10], [73, 14]], "shape_type": "circle"},
    ]);
    labelme_frame(&seq, 100, shapes);
    labelme_frame(&seq, 101, serde_json::json!([]));
    let e = labelme(&seq, 1.0 / 30.0, &[]).unwrap_err().to_string();
    assert!(e.contains("00000100.json") && e.contains("--class track=vehicle"), "{e}");
    let import = labelme(&seq, 1.0 / 30.0, &[("track".into(), "vehicle".into())]).unwrap();
    assert_eq!(import.frames.len(), 2);
    assert!((import.frames[1].timestamp_s - 1.0 / 30.0).abs() < 1e-12);
    let boxes: Vec<[f64; 4]> = import.boxes.iter().map(|b| b.bbox).collect();
    // Polygon bounds; a rectangle from either corner pair; a circle of radius 5 around (70, 10).
    assert_eq!(boxes, [[10.0, 5.0, 20.0, 35.0], [50.0, 10.0, 10.0, 20.0], [65.0, 5.0, 10.0, 10.0]]);
    let out = dir.path().join("folder");
    import.write_folder(&out, Some(0.004)).unwrap();
    let rec = open(&out);
    let frames = &rec.sequences()[0];
    assert_eq!(frames[0].exposure_s, 0.004);
    let classes: Vec<Class> = frames[0].boxes.iter().map(|a| a.class).collect();
    assert_eq!(classes, [Class::Vehicle, Class::Walker, Class::TrafficSign]);
    // A box outside the image, a shape without area, a wrong image size, a bad class.
    for (shapes, want) in [
        (
            serde_json::json!([{"label": "car", "points": [[70, 10], [95, 30]], "shape_type": "rectangle"}]),
            "reaches outside the 80×50 image",
        ),
        (
            serde_json::json!([{"label": "car", "points": [[70, 10]], "shape_type": "point"}]),
            "shape type \"point\" has no area",
        ),
    ] {
        labelme_frame(&seq, 101, shapes);
        let e = labelme(&seq, 0.1, &[("track".into(), "vehicle".into())]).unwrap_err().to_string();
        assert!(e.contains("00000101.json") && e.contains(want), "{e}");
    }
    let e = labelme(&seq, 0.1, &[("track".into(), "lorry".into())]).unwrap_err().to_string();
    assert!(e.contains("--class track=lorry") && e.contains("vehicle, walker"), "{e}");
}

/// Two labelled frames in two subfolders with one file name stay two frames (their labels on
/// their own pictures); two JSON files naming one picture are refused before anything is copied.
#[test]
fn labelme_frames_of_one_name_in_two_folders_stay_apart() {
    let dir = tempfile::tempdir().unwrap();
    let seq = dir.path().join("seq");
    for (n, sub, shade) in [(0u32, "a", 40u8), (1, "b", 200)] {
        std::fs::create_dir_all(seq.join(sub)).unwrap();
        image::RgbImage::from_pixel(80, 50, image::Rgb([shade; 3]))
            .save(seq.join(sub).join("000000.png"))
            .unwrap();
        let file = serde_json::json!({
            "version": "5.8.3", "flags": {}, "shapes": [],
            "imagePath": format!("{sub}/000000.png"), "imageData": null,
            "imageHeight": 50, "imageWidth": 80,
        });
        std::fs::write(seq.join(format!("{n:08}.json")), file.to_string()).unwrap();
    }
    let import = labelme(&seq, 0.1, &[]).unwrap();
    let out = dir.path().join("out");
    import.write_folder(&out, Some(0.005)).unwrap();
    let coco: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("annotations.json")).unwrap())
            .unwrap();
    let names: Vec<&str> = coco["images"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["file_name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["frames/seq/a/000000.png", "frames/seq/b/000000.png"]);
    let shade = |name: &str| image::open(out.join(name)).unwrap().to_rgb8().get_pixel(0, 0)[0];
    assert_eq!((shade(names[0]), shade(names[1])), (40, 200));

    // Both JSON files name the same picture: refused, nothing written.
    let text = std::fs::read_to_string(seq.join("00000001.json")).unwrap();
    std::fs::write(seq.join("00000001.json"), text.replace("b/000000.png", "a/000000.png"))
        .unwrap();
    let import = labelme(&seq, 0.1, &[]).unwrap();
    let fresh = dir.path().join("fresh");
    let e = import.write_folder(&fresh, Some(0.005)).unwrap_err().to_string();
    assert!(
        e.contains("frames/seq/a/000000.png") && e.contains("two frames would be one file"),
        "{e}"
    );
    assert!(!fresh.exists());
}
