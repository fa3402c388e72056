//! The `joca` binary as a user runs it: outputs, and the messages bad input gets.
#![allow(clippy::unwrap_used)] // a failed unwrap is a failed test

use joca_camera::{Calibration, DynamicSettings, ImageFormation};
use joca_core::{HdrImage, SeedStreams};
use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::{TINY_RUN, cli, joca, stderr, stdout};

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
fn run_refuses_unknown_methods_scenarios_presets_and_config_fields() {
    let o = cli!("run --method magic --out /tmp/joca-never");
    assert!(
        stderr(&o).contains("unknown method \"magic\"")
            && stderr(&o).contains("tacos-average, fixed-neural"),
        "{}",
        stderr(&o)
    );
    let o = cli!("run --scenario fog --out /tmp/joca-never");
    assert!(
        stderr(&o).contains("unknown scenario \"fog\"") && stderr(&o).contains("noise10"),
        "{}",
        stderr(&o)
    );
    let o = cli!("run --preset huge --out /tmp/joca-never");
    assert!(
        stderr(&o).contains("unknown preset \"huge\"")
            && stderr(&o).contains("quick, standard, paper"),
        "{}",
        stderr(&o)
    );
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("mine.toml");
    std::fs::write(&cfg, "[run]\ngenerations = 2\npopulaton = 4\n").unwrap();
    let o = cli!("run --config", cfg, "--out /tmp/joca-never");
    assert!(
        stderr(&o).contains("mine.toml") && stderr(&o).contains("unknown field `populaton`"),
        "{}",
        stderr(&o)
    );
    // `joca experiment --seeds 0` is refused before anything is written.
    let exp_dir = dir.path().join("exp");
    let o = cli!("experiment ablation --seeds 0 --out", exp_dir);
    let e = stderr(&o);
    assert!(!o.status.success() && e.contains("--seeds = 0 is invalid: 1 to 100"), "{e}");
    assert!(!exp_dir.exists());
    // A misspelt table is refused, not ignored.
    std::fs::write(&cfg, "[runn]\ngenerations = 2\n").unwrap();
    let o = cli!("run --config", cfg, "--out /tmp/joca-never");
    assert!(
        !o.status.success()
            && stderr(&o).contains("mine.toml")
            && stderr(&o).contains("`runn`")
            && stderr(&o).contains("[run], [pretrain]"),
        "{}",
        stderr(&o)
    );
    // `--resume` where nothing ran is refused, and so is `--out` at a folder of other files,
    // which is left untouched.
    let empty = dir.path().join("empty");
    let o = cli!("run --resume --out", empty);
    assert!(stderr(&o).contains("nothing to resume"), "{}", stderr(&o));
    let other = dir.path().join("other");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::write(other.join("notes.txt"), "mine").unwrap();
    let o = cli!("run --out", other);
    assert!(stderr(&o).contains("is not a joca run output"), "{}", stderr(&o));
    let left: Vec<_> = std::fs::read_dir(&other).unwrap().collect();
    assert_eq!(left.len(), 1);
    // A speed that is not a number is refused before anything runs.
    let o = cli!("render --max-speed-mps NaN --frames 1 --out /tmp/joca-never");
    assert!(stderr(&o).contains("--max-speed-mps = NaN is out of range"), "{}", stderr(&o));
}

#[test]
fn run_refuses_bad_config_values_naming_the_field_and_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("mine.toml");
    // The detector input: a size past its maximum, a long side below the short side, an unknown
    // resampler, hardware mutation or perturbation score or step, a fixed design outside the
    // catalogue or the design space, each named with what is allowed and the file; nothing is
    // written.
    let cases = [
        (
            "input = { short_px = 2000, long_max_px = 3000 }",
            "run.input.short_px = 2000 is invalid: 16 to 1024 px",
        ),
        (
            "input = { short_px = 0, long_max_px = 400 }",
            "run.input.short_px = 0 is invalid: 16 to 1024 px",
        ),
        (
            "input = { short_px = 240, long_max_px = 200 }",
            "run.input.long_max_px = 200 is invalid: 240 to 2048 px",
        ),
        (
            "input = { short_px = 240, long_max_px = 400, resampler = \"lanczos\" }",
            "unknown variant `lanczos`, expected `bilinear` or `area`",
        ),
        (
            "hardware_mutation = \"gaussian\"",
            "unknown variant `gaussian`, expected `tacos` or `paper`",
        ),
        ("perturbation_score = \"median\"", "unknown variant `median`, expected `ap50` or `loss`"),
        ("perturbation_steps = \"log\"", "unknown variant `log`, expected `linear` or `relative`"),
        (
            "design = { sensor = \"IMX999\", focal_length_mm = 4.0, x_m = 0.5, z_m = 1.5 }",
            "run.design.sensor = \"IMX999\" is invalid: a catalogue sensor: ",
        ),
        (
            "design = { sensor = \"IMX172\", focal_length_mm = 25.0, x_m = 0.5, z_m = 1.5 }",
            "run.design.focal_length_mm = 25 is invalid: 1 to 10 mm (the paper's design space)",
        ),
        (
            "design = { sensor = \"IMX172\", focal_length_mm = 4.0, x_m = 0.5 }",
            "missing field `z_m`",
        ),
        // The lens, its aperture range and the weather (issue 41).
        ("lens = \"fisheye\"", "unknown variant `fisheye`, expected `pinhole` or `thin`"),
        ("weather = \"snow\"", "unknown weather \"snow\"; allowed: \"clear\", \"fog:V\""),
        ("weather = \"fog:-3\"", "fog visibility_m = -3: allowed 10 to 100000 m"),
        (
            "lens = \"thin\"\nf_number = { min = 0.7, max = 16.0 }",
            "run.f_number.min = 0.7 is invalid: 1 to 32, min at most max",
        ),
        (
            "f_number = { min = 2.0, max = 16.0 }",
            "run.f_number = { min = 2, max = 16 } is invalid: 16 to 16 with lens = \"pinhole\"",
        ),
        ("aperture = \"iris\"", "unknown variant `iris`, expected `fixed` or `dynamic`"),
        (
            "aperture = \"dynamic\"",
            "run.aperture = \"dynamic\" is invalid: \"fixed\" unless lens = \"thin\"",
        ),
        (
            "lens = \"thin\"\naperture = \"dynamic\"\nmethod = \"tacos-average\"",
            "run.aperture = \"dynamic\" is invalid: \"fixed\" unless lens = \"thin\" and the method's",
        ),
    ];
    for (line, message) in cases {
        std::fs::write(&cfg, format!("[run]\n{line}\n")).unwrap();
        let out = dir.path().join("r");
        let o = cli!("run --config", cfg, "--out", out);
        assert!(!o.status.success());
        assert!(stderr(&o).contains(message) && stderr(&o).contains("mine.toml"), "{}", stderr(&o));
        assert!(!out.exists(), "{line}: the run directory was created");
    }
    // An unknown perturbation mutation names the field and the values it may take.
    std::fs::write(&cfg, "[run]\nperturbation_mutation = \"gaussian\"\n").unwrap();
    let o = cli!("run --config", cfg, "--out /tmp/joca-never");
    let e = stderr(&o);
    assert!(
        e.contains("perturbation_mutation") && e.contains("`paper`") && e.contains("`additive`"),
        "{e}"
    );
    // So does an unknown scoring precision.
    std::fs::write(&cfg, "[run]\nscoring_precision = \"fp16\"\n").unwrap();
    let o = cli!("run --config", cfg, "--out /tmp/joca-never");
    let e = stderr(&o);
    assert!(e.contains("scoring_precision") && e.contains("`fp32`") && e.contains("`bf16`"), "{e}");
    // A reference range of zero (or less) names the field, the allowed range and the file,
    // before a run directory exists; the other ranges of a partial table keep their defaults.
    std::fs::write(&cfg, "[run.reference]\nwalker_m = 0.0\n").unwrap();
    let never = dir.path().join("never");
    let o = cli!("run --config", cfg, "--out", never);
    let e = stderr(&o);
    assert!(
        !o.status.success()
            && e.contains("run.reference.walker_m = 0 is invalid: above 0 m, at most 200 m")
            && e.contains(cfg.to_str().unwrap()),
        "{e}"
    );
    assert!(!never.exists(), "a refused config left {}", never.display());
}

/// A grid small enough for a test: 2 variants × 2 scenarios of a 1-generation run.
const TINY_EXPERIMENT: &str = r#"
title = "tiny"
label_header = "Method"
scenarios = ["calibrated", "blur4"]

[[variant]]
id = "tacos"
label = "TaCOS + AverageAE"
run = { method = "tacos-average" }

[[variant]]
id = "joca"
label = "Ours"
run = { method = "joca" }
"#;

#[test]
fn experiment_files_with_unknown_methods_or_scenarios_name_them_and_the_valid_ones() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("mine.toml");
    std::fs::write(&file, TINY_EXPERIMENT.replace("tacos-average", "tacos-magic")).unwrap();
    let o = cli!("experiment", file, "--out /tmp/joca-never");
    let e = stderr(&o);
    assert!(
        e.contains("mine.toml")
            && e.contains("variant \"tacos\"")
            && e.contains("unknown method \"tacos-magic\"")
            && e.contains("tacos-average, fixed-neural"),
        "{e}"
    );
    std::fs::write(&file, TINY_EXPERIMENT.replace("\"blur4\"", "\"fog\"")).unwrap();
    let o = cli!("experiment", file, "--out /tmp/joca-never");
    let e = stderr(&o);
    assert!(
        e.contains("mine.toml: scenarios: unknown scenario \"fog\"") && e.contains("noise10"),
        "{e}"
    );
    let o = cli!("experiment table9 --out /tmp/joca-never");
    let e = stderr(&o);
    assert!(
        e.contains("unknown experiment \"table9\"") && e.contains("table1, ablation, sweep-weight"),
        "{e}"
    );
    // Slurm that is not there is said plainly (PATH without sbatch).
    let cfg = dir.path().join("tiny.toml");
    std::fs::write(&cfg, TINY_RUN).unwrap();
    std::fs::write(&file, TINY_EXPERIMENT).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_joca"))
        .args(["experiment", file.to_str().unwrap(), "--config", cfg.to_str().unwrap(), "--slurm"])
        .arg("--out")
        .arg(dir.path().join("exp"))
        .env("PATH", "/nonexistent")
        .output()
        .unwrap();
    assert!(
        stderr(&o).contains("Slurm is not reachable: `sbatch` is not on PATH"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn an_experiment_runs_its_grid_skips_finished_cells_and_resumes_a_killed_one() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("tiny.toml");
    let cfg = dir.path().join("run.toml");
    std::fs::write(&file, TINY_EXPERIMENT).unwrap();
    std::fs::write(&cfg, TINY_RUN).unwrap();
    let exp = dir.path().join("exp");
    let args = [
        "experiment",
        file.to_str().unwrap(),
        "--config",
        cfg.to_str().unwrap(),
        "--out",
        exp.to_str().unwrap(),
    ];
    let o = joca(&[&args[..], &["--jobs", "2"]].concat());
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    let csv = std::fs::read_to_string(exp.join("results.csv")).unwrap();
    assert_eq!(csv.lines().count(), 5, "{csv}");
    let md = std::fs::read_to_string(exp.join("report.md")).unwrap();
    assert!(
        md.contains("4 of 4 cells finished")
            && md.contains("| Motion blur×4 | TaCOS + AverageAE |"),
        "{md}"
    );
    for f in [
        "calibrated-settings.png",
        "calibrated-frames.png",
        "calibrated-fov.png",
        "motion-blur-4-tunnel.gif",
    ] {
        assert!(exp.join("figures").join(f).is_file(), "{f}");
    }
    let html = std::fs::read_to_string(exp.join("report.html")).unwrap();
    assert!(html.matches("src=\"").count() == html.matches("src=\"data:image/").count());

    // A killed cell: results gone, checkpoint kept -> "partial", and the next invocation
    // resumes it (its checkpoint is newer than the first three cells' results) and reports all.
    let cell = exp.join("cells/joca-blur4");
    std::fs::remove_file(cell.join("results.json")).unwrap();
    let status = joca(&[&args[..], &["--status"]].concat());
    assert!(stdout(&status).contains("partial  joca-blur4"), "{}", stdout(&status));
    assert!(stdout(&status).contains("3 done, 1 partial, 0 missing of 4"), "{}", stdout(&status));
    let before = std::fs::read_to_string(exp.join("cells/joca-calibrated/results.json")).unwrap();
    let o = joca(&args);
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    assert!(stdout(&o).contains("4 cells, 1 to run"), "{}", stdout(&o));
    assert!(cell.join("results.json").is_file());
    assert_eq!(
        std::fs::read_to_string(exp.join("cells/joca-calibrated/results.json")).unwrap(),
        before
    );
    assert_eq!(std::fs::read_to_string(exp.join("results.csv")).unwrap(), csv);

    // A cell restored from its compact results (docs/results/ keeps results.json and the
    // configuration only), first of its group: the report still has every figure, its row
    // of the frames figure empty.
    let compact = exp.join("cells/tacos-calibrated");
    for entry in std::fs::read_dir(&compact).unwrap() {
        let path = entry.unwrap().path();
        let keep = ["results.json", "config.toml", "cell.toml", "best_design.json"];
        if !keep.iter().any(|k| path.ends_with(k)) {
            if path.is_dir() {
                std::fs::remove_dir_all(&path).unwrap();
            } else {
                std::fs::remove_file(&path).unwrap();
            }
        }
    }
    std::fs::remove_dir_all(exp.join("figures")).unwrap();
    let o = joca(&["report", exp.to_str().unwrap()]);
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    assert!(exp.join("figures/calibrated-frames.png").is_file());

    // The same directory with another configuration is refused, naming the field.
    std::fs::write(&cfg, TINY_RUN.replace("steps_per_candidate = 3", "steps_per_candidate = 4"))
        .unwrap();
    let o = joca(&args);
    assert!(
        stderr(&o).contains("another configuration") && stderr(&o).contains("steps_per_candidate"),
        "{}",
        stderr(&o)
    );
}

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
}
