use super::*;
use tch::Device;

#[test]
fn device_names_parse_and_print_back() {
    for (text, choice, shown) in [
        ("cpu", DeviceChoice::Cpu, "cpu"),
        ("cuda", DeviceChoice::Cuda(0), "cuda:0"),
        ("cuda:0", DeviceChoice::Cuda(0), "cuda:0"),
        (" cuda:3 ", DeviceChoice::Cuda(3), "cuda:3"),
        ("auto", DeviceChoice::Auto, "auto"),
    ] {
        let parsed: DeviceChoice = text.parse().unwrap();
        assert_eq!(parsed, choice, "{text}");
        assert_eq!(parsed.to_string(), shown);
        assert_eq!(shown.parse::<DeviceChoice>().unwrap(), choice);
    }
}

#[test]
fn unknown_device_names_are_refused_naming_the_allowed_values() {
    for bad in ["gpu", "CUDA", "cuda:", "cuda:-1", "cuda:+1", "cuda: 1", "cuda:x", "mps", ""] {
        let err = bad.parse::<DeviceChoice>().unwrap_err().to_string();
        assert!(err.contains(&format!("`{bad}`")), "{err}");
        assert!(
            err.contains("cpu, cuda") && err.contains("cuda:N") && err.contains("auto"),
            "{err}"
        );
    }
}

#[test]
fn a_device_reads_from_toml_and_a_bad_one_names_the_value() {
    #[derive(serde::Deserialize, serde::Serialize)]
    struct Table {
        device: DeviceChoice,
    }
    let t: Table = toml::from_str("device = \"cuda:1\"").unwrap();
    assert_eq!(t.device, DeviceChoice::Cuda(1));
    assert_eq!(toml::to_string(&t).unwrap().trim(), "device = \"cuda:1\"");
    let err = toml::from_str::<Table>("device = \"tpu\"").err().unwrap().to_string();
    assert!(err.contains("device") && err.contains("`tpu`") && err.contains("cuda:N"), "{err}");
}

/// Each way a GPU request meets a machine, with the machine's answer given: the CPU is never
/// probed, `auto` falls back to the CPU, and each refusal names the device asked for, what was
/// found and how to get a CUDA build.
#[test]
fn requests_resolve_or_are_refused_naming_what_was_found() {
    let never = || -> CudaProbe { panic!("the CPU needs no probe") };
    assert_eq!(resolve(DeviceChoice::Cpu, never).unwrap(), Device::Cpu);
    let gpus = |n| move || CudaProbe::Gpus(n);
    let cpu_build = || CudaProbe::NoCudaPart("libtorch_cuda.so: cannot open shared object".into());
    assert_eq!(resolve(DeviceChoice::Auto, gpus(2)).unwrap(), Device::Cuda(0));
    assert_eq!(resolve(DeviceChoice::Auto, gpus(0)).unwrap(), Device::Cpu);
    assert_eq!(resolve(DeviceChoice::Auto, cpu_build).unwrap(), Device::Cpu);
    assert_eq!(resolve(DeviceChoice::Cuda(1), gpus(2)).unwrap(), Device::Cuda(1));

    let err = resolve(DeviceChoice::Cuda(0), cpu_build).unwrap_err().to_string();
    assert!(err.contains("device `cuda:0`") && err.contains("no CUDA part"), "{err}");
    assert!(err.contains("cannot open shared object"), "{err}");
    assert!(err.contains("JOCA_LIBTORCH=cuda") && err.contains("LD_LIBRARY_PATH"), "{err}");

    let err = resolve(DeviceChoice::Cuda(0), gpus(0)).unwrap_err().to_string();
    assert!(err.contains("finds no GPU") && err.contains("--device cpu"), "{err}");

    let err = resolve(DeviceChoice::Cuda(7), gpus(1)).unwrap_err().to_string();
    assert!(err.contains("device `cuda:7`") && err.contains("has 1 GPU (cuda:0)"), "{err}");
    assert!(err.contains("no GPU 7"), "{err}");
    let err = resolve(DeviceChoice::Cuda(4), gpus(4)).unwrap_err().to_string();
    assert!(err.contains("has 4 GPUs (cuda:0 to cuda:3)"), "{err}");
}

/// On a build whose libtorch folder holds no CUDA part (the bootstrap's CPU libtorch, as in
/// CI), the real probe says so, naming the library and the loader's reason; `auto` runs on the
/// CPU. Where the folder has the CUDA part, the probe must load it and count the GPUs instead.
#[test]
fn the_real_probe_finds_what_this_libtorch_folder_holds() {
    let _serial = crate::torch_serial();
    let dir = cuda::libtorch_dir().expect("libtorch_cpu.so is loaded and exports its context");
    assert!(dir.join("libtorch_cpu.so").exists(), "{}", dir.display());
    let has_cuda = dir.join("libtorch_cuda.so").exists()
        || std::env::var("LD_LIBRARY_PATH")
            .unwrap_or_default()
            .split(':')
            .any(|d| !d.is_empty() && std::path::Path::new(d).join("libtorch_cuda.so").exists());
    let found = probe();
    eprintln!("libtorch in {}: {found:?}", dir.display());
    match found {
        CudaProbe::NoCudaPart(why) => {
            assert!(!has_cuda, "libtorch_cuda.so is there but did not load: {why}");
            assert!(why.contains("libtorch_cuda.so"), "{why}");
            let engine = crate::Engine::open(DeviceChoice::Auto, 1).unwrap();
            assert_eq!(engine.device(), Device::Cpu);
            let err = crate::Engine::open(DeviceChoice::Cuda(0), 1).unwrap_err().to_string();
            assert!(err.contains("no CUDA part") && err.contains("docs/guide/gpu.md"), "{err}");
        }
        CudaProbe::Gpus(n) => {
            assert!(has_cuda);
            assert_eq!(n, usize::try_from(tch::Cuda::device_count()).unwrap());
            if n == 0 {
                // The hooks are CUDA's own, not libtorch's stub: a tensor on a GPU fails for
                // want of a driver or device, not for want of the CUDA library.
                let t = tch::Tensor::f_zeros([1], (tch::Kind::Float, Device::Cuda(0)));
                let why = t.err().map(|e| e.to_string()).unwrap_or_default();
                eprintln!("a tensor on cuda:0: {}", why.lines().next().unwrap_or(""));
                assert!(!why.is_empty() && !why.contains("ATen_cuda"), "{why}");
                let err = crate::Engine::open(DeviceChoice::Cuda(0), 1).unwrap_err().to_string();
                assert!(err.contains("finds no GPU"), "{err}");
                assert_eq!(
                    crate::Engine::open(DeviceChoice::Auto, 1).unwrap().device(),
                    Device::Cpu
                );
            } else {
                let engine = crate::Engine::open(DeviceChoice::Auto, 1).unwrap();
                assert_eq!(engine.device(), Device::Cuda(0));
                assert!(engine.describe().starts_with("cuda:0: "), "{}", engine.describe());
            }
        }
    }
    assert_eq!(describe(Device::Cpu), "cpu");
}

/// The switch reaches libtorch's own flag (read back through libtorch's getter), so the calls
/// by mangled name have the right signatures; it is left off as the other tests expect.
#[test]
fn deterministic_algorithms_switch_on_and_off_in_libtorch() {
    let _serial = crate::torch_serial();
    assert!(!cuda::deterministic().unwrap(), "off by default");
    cuda::set_deterministic(true).unwrap();
    let on = cuda::deterministic().unwrap();
    // A convolution still runs (warn-only mode never fails an operation).
    let x = tch::Tensor::ones([1, 1, 5, 5], (tch::Kind::Float, Device::Cpu));
    let w = tch::Tensor::ones([1, 1, 3, 3], (tch::Kind::Float, Device::Cpu));
    let y = x.conv2d(&w, None::<tch::Tensor>, [1, 1], [0, 0], [1, 1], 1);
    cuda::set_deterministic(false).unwrap();
    assert!(on);
    assert!(!cuda::deterministic().unwrap());
    assert_eq!(y.double_value(&[0, 0, 1, 1]), 9.0);
}

#[test]
fn cuda_versions_read_as_major_minor() {
    assert_eq!(cuda::version(13000), "13.0");
    assert_eq!(cuda::version(12080), "12.8");
    assert_eq!(cuda::version(11020), "11.2");
}
