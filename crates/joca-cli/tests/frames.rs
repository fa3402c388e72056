//! Frames from outside the simulator: optical flow, exposure blur along it, runs on a recorded
//! folder and the KITTI importer; and `joca bench render`'s tables.
#![allow(clippy::unwrap_used)] // a failed unwrap is a failed test

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::{TINY_RUN, cli, joca, stderr, stdout};

/// Three 96×64 frames of a smooth pattern shifted 2 px to the right from one to the next.
fn shifted_frames(dir: &Path) -> PathBuf {
    let frame = |shift: f32| {
        image::RgbImage::from_fn(96, 64, |x, y| {
            let v = 128.0 + 60.0 * ((x as f32 - shift) * 0.21).sin() * (y as f32 * 0.17).cos();
            image::Rgb([v as u8, v as u8, v as u8])
        })
    };
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for k in 0..3 {
        frame(2.0 * k as f32).save(frames.join(format!("{k:03}.png"))).unwrap();
    }
    frames
}

#[test]
fn flow_reports_motion_and_refuses_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let frames = shifted_frames(dir.path());
    let a = frames.join("000.png");
    let b = frames.join("001.png");
    let out = dir.path().join("flow.png");
    let o = cli!("flow", a, b, "--out", out);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("mean displacement 2.0"), "{}", stdout(&o));
    assert!(out.is_file());
    // The flow written as .flo and scored against itself (EPE 0), and against the true motion,
    // (2, 0) everywhere, written as a .flo.
    let flo = dir.path().join("flow.flo");
    let truth = dir.path().join("truth.flo");
    let mut bytes = b"PIEH".to_vec();
    bytes.extend_from_slice(&96i32.to_le_bytes());
    bytes.extend_from_slice(&64i32.to_le_bytes());
    for _ in 0..96 * 64 {
        bytes.extend_from_slice(&2.0f32.to_le_bytes());
        bytes.extend_from_slice(&0.0f32.to_le_bytes());
    }
    std::fs::write(&truth, &bytes).unwrap();
    let args = [a.to_str().unwrap(), b.to_str().unwrap(), "--out", out.to_str().unwrap()];
    let o = joca(&[&["flow"], &args[..], &["--flo", flo.to_str().unwrap()]].concat());
    assert!(o.status.success() && flo.is_file(), "{}", stderr(&o));
    // All outputs or none: a --flo that cannot be written (a folder; a path below a file)
    // leaves no --out or --warped behind, nor a temporary.
    let fresh = dir.path().join("fresh.png");
    let warped = dir.path().join("warped.png");
    let (f, w) = (fresh.to_str().unwrap(), warped.to_str().unwrap());
    let below_a_file = a.join("x.flo");
    for bad in [dir.path(), below_a_file.as_path()] {
        let (x, y) = (a.to_str().unwrap(), b.to_str().unwrap());
        let o = joca(&["flow", x, y, "--out", f, "--warped", w, "--flo", bad.to_str().unwrap()]);
        assert!(!o.status.success(), "{}", stdout(&o));
        let left: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains("fresh") || n.contains("warped"))
            .collect();
        assert!(left.is_empty(), "{left:?}: {}", stderr(&o));
    }
    let o = joca(&[&["flow"], &args[..], &["--gt", flo.to_str().unwrap()]].concat());
    assert!(stdout(&o).contains("end-point error 0.000 px, 0.00 %"), "{}", stdout(&o));
    let o = joca(&[&["flow"], &args[..], &["--gt", truth.to_str().unwrap()]].concat());
    let line = stdout(&o);
    let epe: f64 = line
        .split("end-point error ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    assert!(epe < 0.25, "{line}");
    assert!(line.contains("(6144 known pixels)"), "{line}");
    // `bench flow` on the same pair and truth: every preset and thread count is timed and
    // scored; without a Python that has OpenCV, the reference columns say so and stay empty.
    let o = joca(&[
        "bench",
        "flow",
        "--repeats",
        "1",
        "--pair",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--gt",
        truth.to_str().unwrap(),
        "--python",
        "/nonexistent/python",
    ]);
    let table = stdout(&o);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        table.contains("(OpenCV reference not run: cannot start /nonexistent/python"),
        "{table}"
    );
    let rows: Vec<&str> = table
        .lines()
        .filter(|l| ["ultrafast", "fast", "medium"].iter().any(|p| l.starts_with(p)))
        .collect();
    assert_eq!(rows.len(), 6, "{table}");
    for row in rows {
        let epe: f64 = row.split_whitespace().nth(5).and_then(|s| s.parse().ok()).unwrap();
        assert!(epe < 0.25, "{row}");
    }
    // A file that is not a .flo is named, and nothing is computed.
    let o = joca(&[&["flow"], &args[..], &["--gt", a.to_str().unwrap()]].concat());
    assert!(
        !o.status.success()
            && stderr(&o).contains("000.png")
            && stderr(&o).contains("not a Middlebury .flo"),
        "{}",
        stderr(&o)
    );

    let o = joca(&[
        "flow",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--out",
        "x.png",
        "--preset",
        "slow",
    ]);
    assert!(
        stderr(&o).contains("unknown flow preset \"slow\"; valid: ultrafast, fast, medium"),
        "{}",
        stderr(&o)
    );
    let small = dir.path().join("small.png");
    image::RgbImage::new(10, 10).save(&small).unwrap();
    let o = cli!("flow", a, small, "--out x.png");
    assert!(stderr(&o).contains("96×64 but") && stderr(&o).contains("10×10"), "{}", stderr(&o));
}

#[test]
fn blur_smears_along_the_flow_and_refuses_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let frames = shifted_frames(dir.path());
    let blurred = dir.path().join("blurred");
    let o = cli!("blur", frames, "--exposure-ms 50 --out", blurred);
    assert!(o.status.success(), "{}", stderr(&o));
    // 2 px per 100 ms frame interval, 50 ms exposure: a 1 px smear.
    assert!(stdout(&o).contains("mean smear 1.0"), "{}", stdout(&o));
    // Two blurred frames and joca's output marker.
    assert_eq!(std::fs::read_dir(&blurred).unwrap().count(), 3);
    assert!(blurred.join(".joca-output").is_file());

    let o = cli!("blur", frames, "--exposure-ms 5 --linearize gamma --out x");
    assert!(stderr(&o).contains("valid: srgb, none"), "{}", stderr(&o));
}

#[test]
fn a_run_on_a_recorded_folder_reports_the_real_image_layout() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    // `joca render` writes the folder format: frames plus annotations.json with timestamp_s and
    // exposure_s. Its frames are linear 8-bit values, hence linearize = "none" below.
    let o =
        cli!("render --frames 8 --short-px 600 --long-max-px 800 --illumination day --out", rec);
    assert!(o.status.success(), "{}", stderr(&o));
    let cfg = dir.path().join("real.toml");
    std::fs::write(&cfg, format!("{TINY_RUN}[run.real]\nlinearize = \"none\"\n")).unwrap();
    let out = dir.path().join("run");
    let source = format!("folder:{}", rec.display());
    let args = [
        "run",
        "--source",
        &source,
        "--config",
        cfg.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    let o = joca(&args);
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        md.contains("| Scenario | Method | w×h (mm) | p (µm) | sensor | mAP@[.5:.95] ↑ | AP50 ↑ |"),
        "{md}"
    );
    assert!(md.contains("Test on recorded frames (folder:"), "{md}");
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    // Only sensors whose grid fits inside the 800×600 recording can be chosen.
    let sensor = results["design"]["sensor"].as_str().unwrap().to_owned();
    let o = cli!("sensors --format csv --fits 800x600");
    assert!(stdout(&o).contains(&format!(",{sensor},")), "{sensor} does not fit 800x600");
    // Recorded frames have no towns: `eval --town` is refused, naming the flag and the run.
    let o = joca(&["eval", out.to_str().unwrap(), "--town", "2"]);
    let e = stderr(&o);
    assert!(!o.status.success() && e.contains("--town = 2 is invalid: 0 only"), "{e}");
    assert!(e.contains("recorded frames") && !out.join("results-town2.json").exists(), "{e}");

    // Frames without exposure are refused with the fix; a bad setting names the field.
    let text = std::fs::read_to_string(rec.join("annotations.json")).unwrap();
    std::fs::write(rec.join("annotations.json"), text.replace("\"exposure_s\"", "\"exposure\""))
        .unwrap();
    let o = joca(&[&args[..5], &["--out", dir.path().join("run2").to_str().unwrap()]].concat());
    assert!(
        stderr(&o).contains("has no exposure_s") && stderr(&o).contains("default exposure"),
        "{}",
        stderr(&o)
    );
    std::fs::write(&cfg, format!("{TINY_RUN}[run.real]\non_bad_frame = \"ignore\"\n")).unwrap();
    let o = joca(&args);
    assert!(
        stderr(&o).contains("[run]")
            && stderr(&o).contains("real.on_bad_frame")
            && stderr(&o).contains("`skip` or `stop`")
            && stderr(&o).contains(cfg.to_str().unwrap()),
        "{}",
        stderr(&o)
    );
}

/// `joca import kitti` writes a folder the folder source reads; a bad label file stops it with
/// the file, line and fault named, and writes nothing.
#[test]
fn import_writes_the_folder_format_or_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let images = dir.path().join("image_02/0003");
    std::fs::create_dir_all(&images).unwrap();
    for k in 0..2 {
        image::RgbImage::from_pixel(40, 30, image::Rgb([90, 90, 90]))
            .save(images.join(format!("{k:06}.png")))
            .unwrap();
    }
    let labels = dir.path().join("0003.txt");
    std::fs::write(&labels, "1 4 Cyclist 0 0 0 5 6 15 26 1 1 1 1 1 1 0\n").unwrap();
    let out = dir.path().join("imported");
    let (l, i, o) = (labels.to_str().unwrap(), images.to_str().unwrap(), out.to_str().unwrap());
    let ok = joca(&["import", "kitti", "--labels", l, "--images", i, "--out", o]);
    assert!(ok.status.success(), "{}", stderr(&ok));
    assert!(stdout(&ok).contains("wrote 2 frames with 1 objects"), "{}", stdout(&ok));
    let coco: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("annotations.json")).unwrap())
            .unwrap();
    assert_eq!(coco["annotations"][0]["bbox"], serde_json::json!([5.0, 6.0, 10.0, 20.0]));
    assert_eq!(coco["categories"][0]["joca_class"], "walker");

    std::fs::write(&labels, "1 4 Scooter 0 0 0 5 6 15 26 1 1 1 1 1 1 0\n").unwrap();
    let fresh = dir.path().join("never");
    let bad =
        joca(&["import", "kitti", "--labels", l, "--images", i, "--out", fresh.to_str().unwrap()]);
    assert!(!bad.status.success());
    assert!(stderr(&bad).contains("0003.txt:1: unknown type \"Scooter\""), "{}", stderr(&bad));
    assert!(!fresh.exists(), "nothing is written for a refused import");

    // A FIFO among the frames (or listed by a folder's annotations) is refused, not waited on.
    std::fs::write(
        &labels,
        "1 4 Cyclist 0 0 0 5 6 15 26 1 1 1 1 1 1 0
",
    )
    .unwrap();
    // (Under `timeout`, so that a regression fails the test instead of hanging it.)
    let bounded = |args: &[&str]| {
        Command::new("timeout").arg("120").arg(env!("CARGO_BIN_EXE_joca")).args(args).output()
    };
    let fifo = images.join("000002.png");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let bad = bounded(&[
        "import",
        "kitti",
        "--labels",
        l,
        "--images",
        i,
        "--out",
        fresh.to_str().unwrap(),
    ])
    .unwrap();
    assert!(stderr(&bad).contains("000002.png: is not a regular file"), "{}", stderr(&bad));
    assert!(!fresh.exists());
    let listed = out.join(coco["images"][1]["file_name"].as_str().unwrap());
    std::fs::remove_file(&listed).unwrap();
    assert!(Command::new("mkfifo").arg(&listed).status().unwrap().success());
    let weights = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../weights/detector.safetensors");
    let list = out.join("annotations.json");
    let dt = dir.path().join("dt.json");
    let (w, li, d) = (weights.to_str().unwrap(), list.to_str().unwrap(), dt.to_str().unwrap());
    let o = bounded(&["detect", "--weights", w, "--images", li, "--out", d]).unwrap();
    assert!(stderr(&o).contains("is not a regular file"), "{}", stderr(&o));
}

/// `joca bench render` names the machine, then prints every table, the last pricing every light
/// at once: a row per light and one per light left out by day, each with a positive, finite
/// ratio.
#[test]
fn bench_render_prices_every_light_at_once() {
    let o = joca(&["bench", "render", "--repeats", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let table = stdout(&o);
    // The machine first: the CPU as `results.json` names it, with its family and model where
    // the CPU reports them.
    let machine = table.lines().next().unwrap_or_default();
    assert!(machine.starts_with("machine: ") && machine.contains("logical CPUs"), "{machine}");
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    if cpuinfo.lines().any(|l| l.starts_with("cpu family")) {
        assert!(machine.contains(" model ") && machine.contains("(family "), "{machine}");
    }
    let every = table.split("every light at once").nth(1).unwrap_or_else(|| panic!("{table}"));
    let ratio = |row: &str| -> f64 {
        let r = row.split_whitespace().last().and_then(|s| s.strip_suffix('x'));
        r.and_then(|s| s.parse().ok()).unwrap_or_else(|| panic!("{row}"))
    };
    let starts = ["day ", "night ", "tunnel ", "cast shadows", "the low sun", "the sun's disc"];
    let more = ["glare ", "tunnels as places "];
    for start in starts.iter().chain(&more) {
        let row = every.lines().find(|l| l.starts_with(start)).unwrap_or_else(|| panic!("{every}"));
        let r = ratio(row);
        assert!(r.is_finite() && r > 0.0, "{row}");
    }
}
