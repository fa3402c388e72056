//! What joca may write, and who may write it: output folders claimed only when new, empty or
//! marked as the same command's (never a user's folder), one writer per run directory, `joca
//! eval` beside the run's results, and inputs read only inside their folder.
#![allow(clippy::unwrap_used)] // a failed unwrap is a failed test

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn joca(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_joca")).args(args).output().expect("joca runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Every entry of `dir` with its bytes (folders listed by name), sorted.
fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut all: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let p = e.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, if p.is_file() { std::fs::read(&p).unwrap() } else { Vec::new() })
        })
        .collect();
    all.sort();
    all
}

/// A folder a user keeps, holding the file names joca's commands write.
fn users_folder(parent: &Path) -> std::path::PathBuf {
    let dir = parent.join("mine");
    std::fs::create_dir_all(&dir).unwrap();
    for name in ["annotations.json", "config.toml", "report.md", "results.csv", "notes.txt"] {
        std::fs::write(dir.join(name), format!("my {name}")).unwrap();
    }
    dir
}

const TINY_RUN: &str = "[run]\nthreads = 1\ngenerations = 1\npopulation = 2\n\
                        steps_per_candidate = 3\ntest_episodes = 1\ntest_frames_per_episode = 2\n";

#[test]
fn no_command_takes_over_a_users_folder_or_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let mine = users_folder(dir.path());
    let before = snapshot(&mine);
    let cfg = dir.path().join("run.toml");
    std::fs::write(&cfg, TINY_RUN).unwrap();
    let exp = dir.path().join("exp.toml");
    std::fs::write(
        &exp,
        "title = \"t\"\nlabel_header = \"M\"\nscenarios = [\"calibrated\"]\n\n\
                          [[variant]]\nid = \"a\"\nlabel = \"A\"\nrun = { method = \"joca\" }\n",
    )
    .unwrap();
    let kitti = dir.path().join("0000.txt");
    std::fs::write(&kitti, "").unwrap();
    let commands: [&[&str]; 6] = [
        &["render", "--frames", "1", "--short-px", "60", "--out"],
        &["import", "kitti", "--labels", s(&kitti), "--images", s(dir.path()), "--out"],
        &["run", "--config", s(&cfg), "--out"],
        &["experiment", s(&exp), "--config", s(&cfg), "--out"],
        &["blur", s(dir.path()), "--exposure-ms", "5", "--out"],
        &["report"],
    ];
    for command in commands {
        let o = joca(&[command, &[s(&mine)]].concat());
        assert!(!o.status.success(), "{command:?} took the folder");
        let e = stderr(&o);
        // Each names the folder and what is in it (`report`, which writes into a run or an
        // experiment, names the marker it looks for).
        let named =
            if command == ["report"] { ".joca-output marker" } else { "config.toml, notes" };
        assert!(e.contains(s(&mine)) && e.contains(named), "{e}");
        assert_eq!(snapshot(&mine), before, "{command:?} changed the folder");
    }
    // A file where a folder should be is refused and left where it is (no hidden `.NAME.old`).
    let file = dir.path().join("file");
    std::fs::write(&file, "data").unwrap();
    for command in [commands[0], commands[2]] {
        let o = joca(&[command, &[s(&file)]].concat());
        assert!(stderr(&o).contains("is not a folder"), "{}", stderr(&o));
    }
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "data");
    assert!(!dir.path().join(".file.old").exists() && !dir.path().join(".file.partial").exists());
    // A sibling named like joca's staging folder, but a user's, is not deleted either.
    let out = dir.path().join("frames");
    let staging = dir.path().join(".frames.partial");
    std::fs::create_dir_all(&staging).unwrap();
    std::fs::write(staging.join("keep.txt"), "mine").unwrap();
    let o = joca(&[commands[0], &[s(&out)]].concat());
    assert!(stderr(&o).contains("in the way of the output"), "{}", stderr(&o));
    assert!(staging.join("keep.txt").is_file() && !out.exists());
    // Another command's output is named as such.
    std::fs::remove_dir_all(&staging).unwrap();
    assert!(joca(&[commands[0], &[s(&out)]].concat()).status.success());
    let o = joca(&[commands[2], &[s(&out)]].concat());
    assert!(stderr(&o).contains("holds joca render output, not run"), "{}", stderr(&o));
}

#[test]
fn one_process_writes_a_run_directory_and_a_kill_frees_it() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("run.toml");
    // Long enough that the second writer meets the first still running.
    std::fs::write(&cfg, TINY_RUN.replace("generations = 1", "generations = 40")).unwrap();
    let out = dir.path().join("run");
    let args = ["run", "--config", s(&cfg), "--out", s(&out)];
    let mut first = Command::new(env!("CARGO_BIN_EXE_joca"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let lock = out.join(".joca-lock");
    let started = Instant::now();
    while std::fs::read_to_string(&lock).map_or(true, |t| t.is_empty()) {
        assert!(started.elapsed() < Duration::from_secs(120), "the run never took its lock");
        std::thread::sleep(Duration::from_millis(50));
    }
    let second = joca(&args);
    let e = stderr(&second);
    let holder = format!("joca run, process {}", first.id());
    assert!(!second.status.success() && e.contains(&holder), "{e}");
    // Neither `--resume` nor `joca eval` gets in while the first runs.
    assert!(stderr(&joca(&[&args[..], &["--resume"]].concat())).contains(&holder));
    assert!(stderr(&joca(&["eval", s(&out)])).contains(&holder));
    // kill -9: the OS drops the lock with the process, so the next writer is not blocked.
    first.kill().unwrap();
    first.wait().unwrap();
    let resume = out.join("checkpoint").exists();
    std::fs::write(&cfg, TINY_RUN).unwrap();
    let extra: &[&str] = if resume { &["--resume"] } else { &[] };
    let next = joca(&[&args[..], extra].concat());
    // (A resumed run with a shorter schedule is refused for its configuration, not the lock.)
    assert!(!stderr(&next).contains("in use by another"), "{}", stderr(&next));
}

#[test]
fn eval_writes_its_own_results_and_keeps_the_runs() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("run.toml");
    // Weights named relative to where `joca run` starts: the run directory records where they
    // are, so `joca eval` works from any folder.
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../weights/detector.safetensors");
    std::fs::copy(shipped, dir.path().join("my.safetensors")).unwrap();
    std::fs::write(&cfg, format!("{TINY_RUN}detector_weights = \"my.safetensors\"\n")).unwrap();
    let out = dir.path().join("run");
    let o = Command::new(env!("CARGO_BIN_EXE_joca"))
        .args(["run", "--config", "run.toml", "--out", "run"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let saved = std::fs::read_to_string(out.join("config.toml")).unwrap();
    let absolute = dir.path().canonicalize().unwrap().join("my.safetensors");
    assert!(saved.contains(&format!("detector_weights = {:?}", s(&absolute))), "{saved}");
    let results = std::fs::read(out.join("results.json")).unwrap();
    let trace = std::fs::read(out.join("test/trace.jsonl")).unwrap();
    let report = std::fs::read(out.join("report.md")).unwrap();
    let o = joca(&["eval", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = joca(&["eval", s(&out), "--frames", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(out.join("results.json")).unwrap(), results);
    assert_eq!(std::fs::read(out.join("test/trace.jsonl")).unwrap(), trace);
    assert_eq!(std::fs::read(out.join("report.md")).unwrap(), report);
    // Same design, model and scenes: the re-test repeats the run's own test.
    let again: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("results-eval.json")).unwrap()).unwrap();
    let first: serde_json::Value = serde_json::from_slice(&results).unwrap();
    assert_eq!(again["test"], first["test"]);
    assert!(out.join("test-eval/trace.jsonl").is_file());
    assert!(out.join("results-frames1.json").is_file() && out.join("test-frames1").is_dir());
    // Fresh scenes: another town of the test family, with its own episode count.
    let o = joca(&["eval", s(&out), "--frames", "1", "--episodes", "4", "--town", "3"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let fresh: serde_json::Value = serde_json::from_slice(
        &std::fs::read(out.join("results-frames1-episodes4-town3.json")).unwrap(),
    )
    .unwrap();
    assert_eq!((fresh["test"]["frames"].as_u64(), fresh["test_town"].as_u64()), (Some(4), Some(3)));
    // A folder joca did not mark is not evaluated.
    let o = joca(&["eval", s(dir.path())]);
    assert!(stderr(&o).contains("is not a joca run output"), "{}", stderr(&o));
}

#[test]
fn detect_reads_only_inside_the_lists_folder_and_refuses_out_of_range_flags() {
    let dir = tempfile::tempdir().unwrap();
    let weights = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../weights/detector.safetensors");
    let list = dir.path().join("list.json");
    let out = dir.path().join("dt.json");
    let detect = |extra: &[&str]| {
        let base = ["detect", "--weights", s(&weights), "--images", s(&list), "--out", s(&out)];
        joca(&[&base[..], extra].concat())
    };
    for name in ["../../../../etc/passwd", "/etc/passwd"] {
        let text = serde_json::json!({"images": [{"id": 1, "file_name": name}]}).to_string();
        std::fs::write(&list, text).unwrap();
        let e = stderr(&detect(&[]));
        assert!(e.contains("list.json") && e.contains("not a path inside"), "{e}");
    }
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink("/etc", dir.path().join("etc")).unwrap();
        let text = r#"{"images": [{"id": 1, "file_name": "etc/passwd"}]}"#;
        std::fs::write(&list, text).unwrap();
        let e = stderr(&detect(&[]));
        assert!(e.contains("leads outside"), "{e}");
    }
    let text = r#"{"images": [{"id": 1, "file_name": "a.png"}, {"id": 1, "file_name": "b.png"}]}"#;
    std::fs::write(&list, text).unwrap();
    assert!(stderr(&detect(&[])).contains("image id 1 is listed twice"));
    for (flag, value, allowed) in [
        ("--width", "100000", "4..=128"),
        ("--threads", "100000", "1..=64"),
        ("--threads", "0", ""),
    ] {
        let e = stderr(&detect(&[flag, value]));
        assert!(e.contains(flag) && e.contains(allowed), "{e}");
    }
    assert!(!out.exists());
    let e = stderr(&joca(&["bench", "detector", "--threads", "100000"]));
    assert!(e.contains("from 1 to 64"), "{e}");
    let form = ["form", "--input", "x.png", "--exposure-ms", "5", "--gain-db", "10", "--sensor"];
    let e =
        stderr(&joca(&[&form[..], &["IMX172", "--noise-scale", "inf", "--out", "y.png"]].concat()));
    assert!(e.contains("allowed 0 to 1000"), "{e}");
}

#[test]
fn report_names_a_bad_event_line_and_keeps_the_rest() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("run.toml");
    std::fs::write(&cfg, TINY_RUN).unwrap();
    let out = dir.path().join("run");
    assert!(joca(&["run", "--config", s(&cfg), "--out", s(&out)]).status.success());
    let events = out.join("events.jsonl");
    let mut bytes = std::fs::read(&events).unwrap();
    let lines = bytes.iter().filter(|&&b| b == b'\n').count();
    bytes.extend_from_slice(b"{\"step\": \xff\xfe}\n");
    std::fs::write(&events, bytes).unwrap();
    std::fs::remove_dir_all(out.join("figures")).unwrap();
    let o = joca(&["report", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let note =
        format!("1 line(s) could not be read and are left out of the figures (line {}", lines + 1);
    assert!(stderr(&o).contains(&note), "{}", stderr(&o));
    assert!(std::fs::read_to_string(out.join("report.md")).unwrap().contains(&note));
    assert!(std::fs::read_dir(out.join("figures")).unwrap().count() > 0);
}

/// SIGTERM and SIGINT (a scheduler's stop, Ctrl-C) end a run as kill -9 does, and `--resume`
/// continues it to results byte-identical to a run never stopped.
#[test]
fn a_run_stopped_by_sigterm_or_sigint_resumes_to_the_same_results() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("run.toml");
    // Ten generations: after the first checkpoint nineteen candidates remain, so the signal
    // lands mid-run even on a fast, idle machine.
    std::fs::write(&cfg, TINY_RUN.replace("generations = 1", "generations = 10")).unwrap();
    let whole = dir.path().join("whole");
    let o = joca(&["run", "--config", s(&cfg), "--out", s(&whole)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let expected = std::fs::read(whole.join("results.json")).unwrap();
    for (name, signal) in [("term", "-TERM"), ("int", "-INT")] {
        let out = dir.path().join(name);
        let args = ["run", "--config", s(&cfg), "--out", s(&out)];
        // Under `env --default-signal`: a test harness started in the background (`cmd &`)
        // inherits SIGINT ignored, which would make the run ignore Ctrl-C here.
        let mut child = Command::new("env")
            .arg("--default-signal=INT,TERM")
            .arg(env!("CARGO_BIN_EXE_joca"))
            .args(args)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        // Stopped once the first candidate's checkpoint is written, mid-run.
        let started = Instant::now();
        while !out.join("checkpoint").exists() {
            assert!(started.elapsed() < Duration::from_secs(300), "no checkpoint was written");
            std::thread::sleep(Duration::from_millis(20));
        }
        let sent = Command::new("kill").args([signal, &child.id().to_string()]).status().unwrap();
        assert!(sent.success());
        let status = child.wait().unwrap();
        assert!(!out.join("results.json").exists(), "{name}: the run ended before the signal");
        assert!(!status.success());
        let o = joca(&[&args[..], &["--resume"]].concat());
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        assert_eq!(std::fs::read(out.join("results.json")).unwrap(), expected, "{name}");
    }
}
