//! Waymo Open Dataset v2 parquet: small files with the dataset's column names and types are
//! written here (the real data cannot be downloaded in tests) and read back as a recording.
#![allow(clippy::unwrap_used)]

use joca_core::{Class, FrameRequest, FrameSource, PinholeCamera};
use joca_data::blur::Linearize;
use joca_data::folder::{FolderConfig, OnBadFrame, Recording};
use parquet::basic::{LogicalType, Repetition, Type as Physical};
use parquet::data_type::ByteArray;
use parquet::file::properties::WriterProperties;
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::types::Type;
use std::path::Path;
use std::sync::Arc;

enum Column {
    Str(Vec<String>),
    I64(Vec<i64>),
    I32(Vec<i32>),
    F32(Vec<f32>),
    F64(Vec<f64>),
    Bytes(Vec<Vec<u8>>),
}

fn write_parquet(path: &Path, columns: Vec<(&str, Column)>) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    let fields = columns
        .iter()
        .map(|(name, c)| {
            let (physical, logical) = match c {
                Column::Str(_) => (Physical::BYTE_ARRAY, Some(LogicalType::String)),
                Column::I64(_) => (Physical::INT64, None),
                Column::I32(_) => (Physical::INT32, None),
                Column::F32(_) => (Physical::FLOAT, None),
                Column::F64(_) => (Physical::DOUBLE, None),
                Column::Bytes(_) => (Physical::BYTE_ARRAY, None),
            };
            Arc::new(
                Type::primitive_type_builder(name, physical)
                    .with_repetition(Repetition::REQUIRED)
                    .with_logical_type(logical)
                    .build()
                    .unwrap(),
            )
        })
        .collect();
    let schema = Arc::new(Type::group_type_builder("schema").with_fields(fields).build().unwrap());
    let file = std::fs::File::create(path).unwrap();
    let mut writer =
        SerializedFileWriter::new(file, schema, Arc::new(WriterProperties::builder().build()))
            .unwrap();
    let mut group = writer.next_row_group().unwrap();
    let mut data = columns.into_iter();
    while let Some(mut col) = group.next_column().unwrap() {
        let (_, values) = data.next().unwrap();
        use parquet::column::writer::ColumnWriter as W;
        match (col.untyped(), values) {
            (W::ByteArrayColumnWriter(w), Column::Str(v)) => {
                let v: Vec<ByteArray> =
                    v.into_iter().map(|s| ByteArray::from(s.as_str())).collect();
                w.write_batch(&v, None, None).unwrap();
            }
            (W::ByteArrayColumnWriter(w), Column::Bytes(v)) => {
                let v: Vec<ByteArray> = v.into_iter().map(ByteArray::from).collect();
                w.write_batch(&v, None, None).unwrap();
            }
            (W::Int64ColumnWriter(w), Column::I64(v)) => {
                w.write_batch(&v, None, None).unwrap();
            }
            (W::Int32ColumnWriter(w), Column::I32(v)) => {
                w.write_batch(&v, None, None).unwrap();
            }
            (W::FloatColumnWriter(w), Column::F32(v)) => {
                w.write_batch(&v, None, None).unwrap();
            }
            (W::DoubleColumnWriter(w), Column::F64(v)) => {
                w.write_batch(&v, None, None).unwrap();
            }
            _ => panic!("column type mismatch"),
        }
        col.close().unwrap();
    }
    group.close().unwrap();
    writer.close().unwrap();
}

/// A 160×80 JPEG with a bright block at `x0`.
fn jpeg(x0: u32) -> Vec<u8> {
    let img = image::RgbImage::from_fn(160, 80, |x, y| {
        if (x0..x0 + 30).contains(&x) && (30..50).contains(&y) {
            image::Rgb([230, 210, 190])
        } else {
            let v = (70.0 + 25.0 * ((x as f32 * 0.3).sin() + (y as f32 * 0.4).cos())) as u8;
            image::Rgb([v, v, v])
        }
    });
    let mut bytes = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, 95).encode_image(&img).unwrap();
    bytes
}

/// Two segments × 4 frames for FRONT_LEFT (2), plus FRONT (1) rows that must be ignored.
fn write_dataset(dir: &Path, with_shutter: bool, corrupt: Option<usize>) {
    let (mut seg, mut ts, mut cam, mut img, mut shutter) = (vec![], vec![], vec![], vec![], vec![]);
    let (mut bseg, mut bts, mut bcam, mut cx, mut cy, mut sx, mut sy, mut ty) =
        (vec![], vec![], vec![], vec![], vec![], vec![], vec![], vec![]);
    for s in 0..2 {
        for k in 0..4 {
            for camera in [1, 2] {
                let row = seg.len();
                seg.push(format!("segment-{s}"));
                ts.push(1_000_000 + 100_000 * k as i64);
                cam.push(camera);
                img.push(if corrupt == Some(row) {
                    b"not a jpeg".to_vec()
                } else {
                    jpeg(30 + 5 * k as u32)
                });
                shutter.push(0.004f32);
                // One vehicle and one object of an unknown type per frame and camera.
                for (t, x) in [(1, 45.0 + 5.0 * k as f64), (9, 120.0)] {
                    bseg.push(format!("segment-{s}"));
                    bts.push(1_000_000 + 100_000 * k as i64);
                    bcam.push(camera);
                    cx.push(x);
                    cy.push(40.0);
                    sx.push(30.0);
                    sy.push(20.0);
                    ty.push(t);
                }
            }
        }
    }
    let mut image_cols = vec![
        ("key.segment_context_name", Column::Str(seg)),
        ("key.frame_timestamp_micros", Column::I64(ts)),
        ("key.camera_name", Column::I32(cam)),
        ("[CameraImageComponent].image", Column::Bytes(img)),
    ];
    if with_shutter {
        image_cols
            .push(("[CameraImageComponent].rolling_shutter_params.shutter", Column::F32(shutter)));
    }
    write_parquet(&dir.join("camera_image/part-0.parquet"), image_cols);
    write_parquet(
        &dir.join("camera_box/part-0.parquet"),
        vec![
            ("key.segment_context_name", Column::Str(bseg)),
            ("key.frame_timestamp_micros", Column::I64(bts)),
            ("key.camera_name", Column::I32(bcam)),
            ("[CameraBoxComponent].box.center.x", Column::F64(cx)),
            ("[CameraBoxComponent].box.center.y", Column::F64(cy)),
            ("[CameraBoxComponent].box.size.x", Column::F64(sx)),
            ("[CameraBoxComponent].box.size.y", Column::F64(sy)),
            ("[CameraBoxComponent].type", Column::I32(ty)),
        ],
    );
}

fn config() -> FolderConfig {
    FolderConfig { linearize: Linearize::Srgb, ..FolderConfig::default() }
}

#[test]
fn segments_frames_exposures_and_boxes_are_read_for_one_camera() {
    let dir = tempfile::tempdir().unwrap();
    write_dataset(dir.path(), true, None);
    let rec = Recording::open_waymo(dir.path(), 2, config()).unwrap();
    assert_eq!(rec.sequences().len(), 2);
    assert_eq!(rec.len(), 8);
    assert!((rec.frame_interval_s() - 0.1).abs() < 1e-9);
    assert_eq!(rec.recording_size_px(), (160, 80));
    let f = &rec.sequences()[1][2];
    assert!((f.exposure_s - 0.004).abs() < 1e-9 && (f.timestamp_s - 1.2).abs() < 1e-9);
    // The vehicle (type 1) is kept, type 9 is not; the box is centre ± size/2.
    assert_eq!(f.boxes.len(), 1);
    assert_eq!(f.boxes[0].class, Class::Vehicle);
    assert_eq!((f.boxes[0].bbox.x_min, f.boxes[0].bbox.x_max), (40.0, 70.0));
    // It renders like a folder recording: a 2:1 camera keeps the whole frame.
    let camera = PinholeCamera {
        width_px: 80,
        height_px: 40,
        fx_px: 40.0,
        fy_px: 40.0,
        cx_px: 40.0,
        cy_px: 20.0,
        mount_m: [0.43, 0.0, 1.65],
        lens: None,
    };
    let frame = rec
        .render(
            &camera,
            &FrameRequest { episode: 1, time_s: 0.2, exposure_s: 0.004, motion_scale: 1.0 },
        )
        .unwrap();
    assert_eq!(frame.boxes.len(), 1);
    assert!((frame.boxes[0].bbox.x_min - 20.0).abs() < 0.01);
    assert_eq!(frame.visible_180, 1);
}

#[test]
fn a_missing_column_and_a_bad_jpeg_name_the_file_and_the_frame() {
    let dir = tempfile::tempdir().unwrap();
    write_dataset(dir.path(), false, None);
    let e = Recording::open_waymo(dir.path(), 2, config()).unwrap_err().to_string();
    assert!(
        e.contains("camera_image/part-0.parquet")
            && e.contains("no column `[CameraImageComponent].rolling_shutter_params.shutter`"),
        "{e}"
    );

    // Row 3 is segment-0's second frame of FRONT_LEFT.
    write_dataset(dir.path(), true, Some(3));
    let e = Recording::open_waymo(dir.path(), 2, config()).unwrap_err().to_string();
    assert!(
        e.contains("segment segment-0, timestamp 1100000 µs, camera 2")
            && e.contains("cannot decode the JPEG"),
        "{e}"
    );
    let skip = Recording::open_waymo(
        dir.path(),
        2,
        FolderConfig { on_bad_frame: OnBadFrame::Skip, ..config() },
    )
    .unwrap();
    assert_eq!(skip.len(), 7);
    assert!(skip.skipped[0].contains("timestamp 1100000"), "{:?}", skip.skipped);
}
