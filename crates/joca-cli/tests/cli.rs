//! The `joca` binary as a user runs it: outputs, and the messages bad input gets.
#![allow(clippy::unwrap_used)] // a failed unwrap is a failed test

use joca_camera::{Calibration, DynamicSettings, ImageFormation};
use joca_core::{HdrImage, SeedStreams};
use std::path::{Path, PathBuf};

mod common;
use common::{cli, joca, stderr, stdout};

/// The detector weights the repository ships (what every preset starts from).
fn shipped_weights() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../weights/detector.safetensors")
}

#[test]
fn sensors_lists_the_catalogue_and_restricts_it() {
    let all = cli!("sensors --format json");
    assert!(all.status.success(), "{}", stderr(&all));
    let rows: serde_json::Value = serde_json::from_str(&stdout(&all)).unwrap();
    assert_eq!(rows.as_array().unwrap().len(), 43);

    let csv = cli!("sensors --format csv --fits 1920x1280 --focal-mm 2.4");
    let text = stdout(&csv);
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[0].ends_with("hfov_deg,vfov_deg"));
    // AR0134 behind 2.4 mm: 2·atan(4.8/4.8) = 90° horizontally.
    let ar = lines.iter().find(|l| l.contains("AR0134")).unwrap();
    assert!(ar.contains(",90.00,"), "{ar}");
    assert!(lines.iter().skip(1).all(|l| {
        let f: Vec<&str> = l.split(',').collect();
        f[4].parse::<usize>().unwrap() <= 1920 && f[5].parse::<usize>().unwrap() <= 1280
    }));
}

#[test]
fn bad_values_name_the_flag_and_the_range() {
    let form = "form --input x.png --gain-db 10 --out y.png";
    let cases: [(String, &[&str]); 3] = [
        (
            "sensors --focal-mm 0.5".into(),
            &["--focal-mm = 0.5 is out of range: allowed 1 to 10 mm"],
        ),
        (
            format!("{form} --exposure-ms 80 --sensor AR0134"),
            &["--exposure-ms", "allowed 0.0001 to 0.05 s"],
        ),
        (
            format!("{form} --exposure-ms 5 --sensor IMX999"),
            &["unknown sensor \"IMX999\"", "IMX172"],
        ),
    ];
    for (line, wants) in cases {
        let o = cli!(line.as_str());
        assert!(!o.status.success(), "{line}");
        assert!(wants.iter().all(|w| stderr(&o).contains(w)), "{line}: {}", stderr(&o));
    }
}

fn write_png16(path: &Path, width: u32, height: u32, f: impl Fn(u32, u32) -> u16) {
    let mut buf = image::ImageBuffer::<image::Rgb<u16>, Vec<u16>>::new(width, height);
    for (x, y, p) in buf.enumerate_pixels_mut() {
        let v = f(x, y);
        *p = image::Rgb([v, v, v]);
    }
    buf.save(path).unwrap();
}

#[test]
fn form_applies_exposure_and_reports_unreadable_files() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("grey.png");
    // 16-bit value 257·40 = 40 DN.
    write_png16(&input, 64, 48, |_, _| 257 * 40);
    let out = dir.path().join("formed.png");
    // Twice E0 at G0 on the calibration pitch: mean 80 DN.
    let o = cli!("form --input", input, "--exposure-ms 10 --gain-db 10 --sensor AR0134 --out", out);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = image::open(&out).unwrap().to_rgb8();
    let mean = img.as_raw().iter().map(|&v| f64::from(v)).sum::<f64>() / img.as_raw().len() as f64;
    assert!((mean - 80.0).abs() < 0.5, "{mean}");

    let broken = dir.path().join("broken.png");
    std::fs::write(&broken, b"not a png").unwrap();
    let o = cli!("form --input", broken, "--exposure-ms 5 --gain-db 10 --sensor AR0134 --out", out);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("cannot read image") && stderr(&o).contains("broken.png"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn a_bad_calibration_file_names_the_file_and_the_field() {
    let form_with = |cal: &Path| {
        cli!(
            "form --input x.png --exposure-ms 5 --gain-db 10 --sensor AR0134 --calibration",
            cal,
            "--out y.png"
        )
    };
    let dir = tempfile::tempdir().unwrap();
    let cal = dir.path().join("cal.toml");
    std::fs::write(
        &cal,
        "[calibration]\npixel_pitch_um = 3.75\nexposure_s = 0.005\ngain_db = 10\n\
         sigma_p2 = [0.2, 0.1, 0.3]\nsigma_r2 = [1.0, -1.0, 3.0]\n",
    )
    .unwrap();
    let o = form_with(&cal);
    let e = stderr(&o);
    assert!(e.contains("cal.toml") && e.contains("calibration.sigma_r2"), "{e}");
    // A negative pitch names its physical range, not a 300-digit bound.
    std::fs::write(
        &cal,
        "[calibration]\npixel_pitch_um = -3\nexposure_s = 0.005\ngain_db = 10\n\
         sigma_p2 = [0.2, 0.1, 0.3]\nsigma_r2 = [1.0, 1.0, 3.0]\n",
    )
    .unwrap();
    let o = form_with(&cal);
    let e = stderr(&o);
    assert!(
        e.contains("calibration.pixel_pitch_um = -3 is out of range: allowed 0.5 to 50 µm"),
        "{e}"
    );

    std::fs::write(&cal, "[calibration]\npixel_pitch = 3.75\n").unwrap();
    let o = form_with(&cal);
    let e = stderr(&o);
    assert!(e.contains("cal.toml") && e.contains("unknown field `pixel_pitch`"), "{e}");
}

#[test]
fn calibrate_noise_recovers_known_parameters_from_png_frames() {
    let dir = tempfile::tempdir().unwrap();
    let truth = Calibration {
        sigma_p2: [0.5, 0.3, 0.7],
        sigma_r2: [2.0, 1.5, 4.0],
        ..Calibration::DEFAULT
    };
    let formation = ImageFormation::new(truth).unwrap();
    let mut scene = HdrImage::zeros(320, 240);
    for y in 0..240 {
        for x in 0..320 {
            let v = 250.0 * x as f32 / 319.0;
            scene.set_pixel(x, y, [v, v, v]);
        }
    }
    let streams = SeedStreams::new(4);
    for k in 0..6 {
        let f = formation.form(
            &scene,
            DynamicSettings::new(5e-3, 10.0),
            3.75,
            &mut streams.indexed("f", k),
        );
        image::save_buffer(
            dir.path().join(format!("f{k}.png")),
            f.data(),
            320,
            240,
            image::ExtendedColorType::Rgb8,
        )
        .unwrap();
    }
    let o = cli!("calibrate-noise --frames", dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let parse = |key: &str| -> Vec<f64> {
        let line = text.lines().find(|l| l.starts_with(key)).unwrap();
        let inner = line.split('[').nth(1).unwrap().trim_end_matches(']');
        inner.split(',').map(|v| v.trim().parse().unwrap()).collect()
    };
    for (got, want) in parse("sigma_p2")
        .iter()
        .zip(truth.sigma_p2)
        .chain(parse("sigma_r2").iter().zip(truth.sigma_r2))
    {
        assert!((got / want - 1.0).abs() < 0.10, "{got} vs {want}");
    }

    let o = cli!("calibrate-noise --frames /nonexistent-dir");
    assert!(stderr(&o).contains("/nonexistent-dir"), "{}", stderr(&o));
    // A gain that is not a number is refused with its range, not printed into the TOML.
    let frames = dir.path().to_str().unwrap();
    let o = joca(&["calibrate-noise", "--frames", frames, "--gain-db", "NaN"]);
    assert!(
        !o.status.success()
            && stderr(&o).contains("gain_db = NaN is out of range: allowed -20 to 60 dB"),
        "{}",
        stderr(&o)
    );
    // Copies of one frame hold no temporal noise: refused, not fitted to a negative variance.
    let copies = tempfile::tempdir().unwrap();
    for k in 0..3 {
        std::fs::copy(dir.path().join("f0.png"), copies.path().join(format!("c{k}.png"))).unwrap();
    }
    let o = cli!("calibrate-noise --frames", copies.path());
    assert!(stderr(&o).contains("the frames are identical"), "{}", stderr(&o));
}

#[test]
fn render_writes_frames_ground_truth_and_a_contact_sheet() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let o =
        cli!("render --illumination day --frames 3 --short-px 150 --long-max-px 200 --out", out);
    assert!(o.status.success(), "{}", stderr(&o));
    for f in ["frames/000000.png", "frames/000002.png", "contact_sheet.png", "sequence.gif"] {
        assert!(out.join(f).exists(), "{f}");
    }
    let coco: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("annotations.json")).unwrap())
            .unwrap();
    assert_eq!(coco["images"].as_array().unwrap().len(), 3);
    assert_eq!(coco["categories"].as_array().unwrap().len(), 3);
    // IMX172 (4000x3000) at a 150-px short side: 200x150.
    assert_eq!(coco["images"][0]["width"], 200);

    // Rendering fewer frames into the same folder replaces the earlier output as a whole: no
    // stale frame is left beside the new annotations, and no staging folder either.
    let again = |frames: &str, out: &Path| {
        joca(&["render", "--frames", frames, "--short-px", "90", "--out", out.to_str().unwrap()])
    };
    assert!(again("2", &out).status.success());
    assert_eq!(std::fs::read_dir(out.join("frames")).unwrap().count(), 2);
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, ["r"]);
    // Notes a user put beside the frames are not lost to the next render: it is refused,
    // naming them, before anything is written.
    std::fs::write(out.join("frames/notes.txt"), "keep").unwrap();
    let o = again("1", &out);
    assert!(stderr(&o).contains("did not write (frames/notes.txt)"), "{}", stderr(&o));
    assert_eq!(std::fs::read_dir(out.join("frames")).unwrap().count(), 3);
    std::fs::remove_file(out.join("frames/notes.txt")).unwrap();
    // A folder of other files is refused and left as it was.
    let other = dir.path().join("mine");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::write(other.join("notes.txt"), "keep").unwrap();
    let o = again("1", &other);
    assert!(stderr(&o).contains("is not a joca render output"), "{}", stderr(&o));
    assert_eq!(std::fs::read_dir(&other).unwrap().count(), 1);
}

#[test]
fn render_refuses_bad_names_and_impossible_mounts() {
    let cases: [(&str, &[&str]); 4] = [
        ("--illumination dusk", &["day", "tunnel", "cycle"]),
        ("--x 5", &["--x = 5 is out of range: allowed 0 to 2.4 m"]),
        ("--focal-mm 0.2", &["--focal-mm", "1 to 10 mm"]),
        ("--sensor nope", &["unknown sensor", "AR0134"]),
    ];
    for (flags, wants) in cases {
        let o = cli!("render --out /tmp/x", flags);
        assert!(!o.status.success(), "{flags}");
        assert!(wants.iter().all(|w| stderr(&o).contains(w)), "{flags}: {}", stderr(&o));
    }
    // Lens and weather: each refusal names the flag and what is allowed, and writes nothing.
    let out = std::env::temp_dir().join(format!("joca-render-optics-{}", std::process::id()));
    let o_str = out.to_str().unwrap();
    for (flags, want) in [
        (&["--f-number", "0.5"][..], "--f-number = 0.5: allowed 1 to 32"),
        (&["--f-number", "2", "--focus-m", "0.003"][..], "--focus-m = 0.003: must exceed"),
        (&["--fog-visibility-m=-5"][..], "--fog-visibility-m = -5: allowed 10 to 100000 m"),
        (&["--focus-m", "5"][..], "--f-number"),
        (&["--rain-mm-h=-1"][..], "--rain-mm-h = -1: allowed 0.1 to 200 mm/h"),
        (&["--glare", "1"][..], "--glare 1 is invalid: allowed 0 (none) to below 1"),
        (&["--glare", "0.02", "--glare-scale-deg", "40"][..], "--glare-scale-deg 40 is invalid"),
        (&["--tunnel-drives", "entering"][..], "--tunnel-drives entering is invalid: allowed both"),
        (&["--tunnels", "places", "--tunnel-drives", "out"][..], "both, entering, leaving"),
    ] {
        let mut args = vec!["render", "--frames", "1", "--out", o_str];
        args.extend_from_slice(flags);
        let o = joca(&args);
        assert!(!o.status.success() && stderr(&o).contains(want), "{flags:?}: {}", stderr(&o));
        assert!(!out.exists(), "{flags:?} wrote {o_str}");
    }
}

#[test]
fn metrics_prints_the_pycocotools_summary_and_names_bad_fields() {
    let fixture =
        concat!(env!("CARGO_MANIFEST_DIR"), "/../joca-metrics/tests/fixtures/random_a.json");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(fixture).unwrap()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let (gt, dt) = (dir.path().join("gt.json"), dir.path().join("dt.json"));
    std::fs::write(&gt, v["gt"].to_string()).unwrap();
    std::fs::write(&dt, v["dt"].to_string()).unwrap();
    let o = cli!("metrics --gt", gt, "--dt", dt);
    assert!(o.status.success(), "{}", stderr(&o));
    let first = stdout(&o).lines().next().unwrap().to_owned();
    let want = format!("{:.3}", v["stats"][0].as_f64().unwrap());
    assert!(
        first.contains("IoU=0.50:0.95 | area=   all | maxDets=100") && first.ends_with(&want),
        "{first}"
    );
    // Then each category with ground truth, with pycocotools' AP and AP50 for it.
    let pc = &v["per_category"]["3"];
    let want = format!(
        " category 3: AP@[.50:.95] = {:.3}  AP50 = {:.3}",
        pc[0].as_f64().unwrap(),
        pc[1].as_f64().unwrap()
    );
    assert!(stdout(&o).lines().any(|l| l == want), "{want} in\n{}", stdout(&o));

    std::fs::write(&dt, r#"[{"image_id": 1, "category_id": 1, "bbox": [1, 2, 3], "score": 0.5}]"#)
        .unwrap();
    let o = cli!("metrics --gt", gt, "--dt", dt);
    assert!(
        stderr(&o).contains("dt.json")
            && stderr(&o).contains("detection 0")
            && stderr(&o).contains("bbox"),
        "{}",
        stderr(&o)
    );
    // A fractional image id is refused, as pycocotools refuses it.
    std::fs::write(
        &dt,
        r#"[{"image_id": 1.5, "category_id": 1, "bbox": [1, 2, 3, 4], "score": 1}]"#,
    )
    .unwrap();
    let o = cli!("metrics --gt", gt, "--dt", dt);
    assert!(stderr(&o).contains("`image_id` of detection 0 is 1.5"), "{}", stderr(&o));
    // Ground truth only on an undeclared image and an undeclared category: pycocotools has
    // nothing to evaluate and prints -1.000 (pycocotools 2.0.11 on this pair:
    // crates/joca-metrics/tests/fixtures/edge_cases.py).
    let lone = r#"{"images": [{"id": 1, "width": 100, "height": 100}],
        "categories": [{"id": 1, "name": "vehicle"}],
        "annotations": [
            {"id": 1, "image_id": 5, "category_id": 1, "bbox": [10, 10, 20, 20], "area": 400,
             "iscrowd": 0},
            {"id": 2, "image_id": 1, "category_id": 9, "bbox": [10, 10, 20, 20], "area": 400,
             "iscrowd": 0}]}"#;
    std::fs::write(&gt, lone).unwrap();
    std::fs::write(
        &dt,
        r#"[{"image_id": 1, "category_id": 1, "bbox": [10, 10, 20, 20], "score": 0.9}]"#,
    )
    .unwrap();
    let o = cli!("metrics --gt", gt, "--dt", dt);
    assert!(o.status.success(), "{}", stderr(&o));
    let first = stdout(&o).lines().next().unwrap().to_owned();
    assert!(first.ends_with("= -1.000"), "{first}");
    assert!(stderr(&o).contains("2 annotation(s)"), "{}", stderr(&o));
}

#[test]
fn detect_writes_coco_results_that_metrics_scores() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    let o =
        joca(&["render", "--frames", "2", "--illumination", "day", "--out", rec.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let weights = shipped_weights();
    let gt = rec.join("annotations.json");
    let dt = dir.path().join("dt.json");
    let detect = |extra: &[&str]| {
        let mut a = vec!["detect", "--weights", weights.to_str().unwrap()];
        a.extend(["--images", gt.to_str().unwrap(), "--out", dt.to_str().unwrap()]);
        a.extend(extra);
        joca(&a)
    };
    let o = detect(&[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let dets: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&dt).unwrap()).unwrap();
    let first = &dets.as_array().unwrap()[0];
    assert!(
        first["image_id"].as_u64().unwrap() >= 1 && first["bbox"].as_array().unwrap().len() == 4
    );
    let o = cli!("metrics --gt", gt, "--dt", dt);
    assert!(stdout(&o).contains("area= small"), "{}", stdout(&o));
    // Weights of another width are refused naming a tensor.
    let o = detect(&["--width", "8"]);
    assert!(!o.status.success() && stderr(&o).contains("detector.safetensors"), "{}", stderr(&o));
}

#[test]
fn eval_detector_scores_weights_and_names_a_missing_file() {
    let weights = shipped_weights();
    let o = cli!("eval-detector --weights", weights, "--episodes 1 --threads 1");
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    // One episode of 10 frames per light, each AP cell with the boxes it rests on.
    assert!(out.contains("1 episodes × 10 frames"), "{out}");
    let day = out.lines().find(|l| l.starts_with("| day |")).unwrap();
    assert!(day.trim_end().ends_with("| 10 |") && day.contains(" ("), "{day}");
    let o = cli!("eval-detector --weights /nonexistent/w.safetensors");
    assert!(
        !o.status.success() && stderr(&o).contains("/nonexistent/w.safetensors"),
        "{}",
        stderr(&o)
    );
    let o = cli!("eval-detector --weights", weights, "--episodes 0");
    assert!(
        stderr(&o).contains("eval.final_episodes") && stderr(&o).contains("1 to 10000"),
        "{}",
        stderr(&o)
    );
}
