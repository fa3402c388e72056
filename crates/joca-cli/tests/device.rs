//! `--device` and `[run] device` as a user meets them: an unknown name, a GPU this build or
//! machine does not have, and a GPU index past the machine's, each refused naming the device,
//! what was found and the way to a CUDA build, before a run directory exists.
#![allow(clippy::unwrap_used)] // a failed unwrap is a failed test

mod common;
use common::{cli, stderr};

/// Whether the CUDA part of libtorch is present for this binary (a CUDA bootstrap, or a CUDA
/// libtorch on the loader's path): the refusals below differ there.
fn cuda_build() -> bool {
    let lib = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../.libtorch/lib");
    let on_path = std::env::var("LD_LIBRARY_PATH").unwrap_or_default();
    std::iter::once(lib)
        .chain(on_path.split(':').filter(|d| !d.is_empty()).map(std::path::PathBuf::from))
        .any(|d| d.join("libtorch_cuda.so").exists())
}

#[test]
fn unknown_device_names_are_refused_with_the_allowed_values() {
    for line in [
        "run --device gpu",
        "eval runs/none --device cuda:x",
        "headroom runs/none --device tpu",
        "bench detector --device CUDA",
        "train-detector --out /tmp/never.safetensors --device cuda:-1",
    ] {
        let o = cli!(line);
        assert!(!o.status.success(), "{line}");
        let err = stderr(&o);
        assert!(err.contains("--device") && err.contains("unknown device"), "{line}: {err}");
        assert!(
            err.contains("cpu, cuda") && err.contains("cuda:N") && err.contains("auto"),
            "{err}"
        );
    }
}

#[test]
fn a_gpu_this_build_or_machine_lacks_is_refused_before_a_run_directory_exists() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let config = dir.path().join("gpu.toml");
    std::fs::write(&config, "[run]\ndevice = \"cuda:7\"\n").unwrap();
    for o in [
        cli!("run --device cuda --out", out.clone()),
        cli!("run --config", config.clone(), "--out", out.clone()),
    ] {
        assert!(!o.status.success());
        let err = stderr(&o);
        assert!(err.contains("device") && err.contains("device `cuda:"), "{err}");
        if cuda_build() {
            // Without a GPU (as in CI with a CUDA libtorch), or with fewer than 8.
            assert!(err.contains("finds no GPU") || err.contains("there is no GPU 7"), "{err}");
        } else {
            assert!(err.contains("no CUDA part") && err.contains("libtorch_cuda.so"), "{err}");
            assert!(
                err.contains("JOCA_LIBTORCH=cuda") && err.contains("docs/guide/gpu.md"),
                "{err}"
            );
        }
        assert!(!out.exists(), "a refused device leaves no run directory");
    }
    let o = cli!("bench detector --repeats 1 --device cuda");
    assert!(!o.status.success() && stderr(&o).contains("device `cuda:0`"), "{}", stderr(&o));
}
