//! Which of libtorch's CPU code paths a process runs.
//!
//! libtorch picks its kernels by what the CPU has: ATen's vectorised operators by its "CPU
//! capability" (AVX2 or AVX-512), oneDNN's convolutions by the widest instruction set, and MKL's
//! matrix products likewise. Each path rounds differently, so the same configuration, seed and
//! thread count give different detectors, and through the genetic algorithm different designs,
//! on different machine types. By default (`native`) libtorch uses the widest units the CPU has.
//! `JOCA_CPU_KERNELS=avx2` pins the three libraries to their AVX2 paths
//! (`ATEN_CPU_CAPABILITY=avx2`, `DNNL_MAX_CPU_ISA=AVX2`, `MKL_CBWR=AVX2`). That makes inference
//! (`joca detect`, the test of a trained checkpoint) give the same bits on the machines it was
//! checked on (an AVX2-only AMD EPYC and an AVX-512/AMX Intel Xeon), but it does NOT make
//! training reproducible across machine types: MKL documents that its AVX2 branch runs on
//! Intel CPUs only (its AUTO branch elsewhere), and oneDNN promises no identical results across
//! CPU models. Training is reproducible per machine type, with either setting. Where the CPU lacks
//! AVX2 or FMA, the choice is `native` whatever was asked, and the run's header and
//! `results.json` say `native`.
//!
//! The variables are read by libtorch when it first computes, so [`select_from_env`] runs first
//! thing in `main`; child processes (`joca cell`, the Python references of `joca bench`) inherit
//! them.

use std::sync::OnceLock;

use crate::NnError;

/// The environment variable that chooses the kernels: `native` (the default) or `avx2`.
pub const ENV: &str = "JOCA_CPU_KERNELS";

/// libtorch's variables and the values that pin each library to its AVX2 path.
pub const AVX2_PINS: [(&str, &str); 3] =
    [("ATEN_CPU_CAPABILITY", "avx2"), ("DNNL_MAX_CPU_ISA", "AVX2"), ("MKL_CBWR", "AVX2")];

/// Which CPU kernels libtorch runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CpuKernels {
    /// The AVX2 paths of ATen, oneDNN and MKL, whatever wider units the CPU has: the same
    /// inference on the machine types checked, training still machine-dependent.
    Avx2,
    /// The widest paths the CPU has (the default): numbers depend on the machine type.
    Native,
}

static CHOSEN: OnceLock<CpuKernels> = OnceLock::new();

impl CpuKernels {
    /// The name `JOCA_CPU_KERNELS`, run headers and `results.json` use.
    pub fn name(self) -> &'static str {
        match self {
            Self::Avx2 => "avx2",
            Self::Native => "native",
        }
    }

    /// The kernels `JOCA_CPU_KERNELS` asks for (unset or empty: `native`).
    pub fn parse(value: Option<&str>) -> Result<Self, NnError> {
        match value.map(str::trim) {
            None | Some("") | Some("native") => Ok(Self::Native),
            Some("avx2") => Ok(Self::Avx2),
            Some(other) => Err(NnError::Config(format!(
                "environment variable {ENV} = {other:?}: allowed values are \"native\" (the \
                 default: libtorch's widest kernels for this CPU) and \"avx2\" (libtorch \
                 pinned to its AVX2 paths)"
            ))),
        }
    }

    /// What runs on a CPU that has (`true`) or lacks AVX2 and FMA: the AVX2 paths need them.
    pub fn on_cpu(self, has_avx2_fma: bool) -> Self {
        if has_avx2_fma { self } else { Self::Native }
    }
}

/// Whether this CPU has AVX2 and FMA.
pub fn cpu_has_avx2_fma() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The CPU's widest vector units as libtorch sees them, e.g. `AVX-512, AVX-512 BF16` or
/// `AVX2, FMA`.
pub fn vector_units() -> String {
    #[cfg(target_arch = "x86_64")]
    {
        let has = [
            (std::arch::is_x86_feature_detected!("avx512f"), "AVX-512"),
            (std::arch::is_x86_feature_detected!("avx512bf16"), "AVX-512 BF16"),
        ];
        let wide: Vec<&str> = has.iter().filter(|h| h.0).map(|h| h.1).collect();
        if !wide.is_empty() {
            wide.join(", ")
        } else if cpu_has_avx2_fma() {
            "AVX2, FMA".to_owned()
        } else {
            "below AVX2".to_owned()
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        std::env::consts::ARCH.to_owned()
    }
}

/// Reads [`ENV`], sets libtorch's variables for the choice, and returns what will run.
///
/// # Safety
/// Changes the process environment: call it before any other thread exists and before
/// libtorch computes anything (first thing in `main`).
#[allow(unsafe_code)]
pub unsafe fn select_from_env() -> Result<CpuKernels, NnError> {
    let asked = CpuKernels::parse(std::env::var(ENV).ok().as_deref())?;
    let chosen = asked.on_cpu(cpu_has_avx2_fma());
    if chosen == CpuKernels::Avx2 {
        for (key, value) in AVX2_PINS {
            // SAFETY: the caller guarantees no other thread reads or writes the environment.
            unsafe { std::env::set_var(key, value) };
        }
    }
    let _ = CHOSEN.set(chosen);
    Ok(chosen)
}

/// The kernels this process runs: what [`select_from_env`] chose, `native` if it never ran
/// (library use, unit tests).
pub fn chosen() -> CpuKernels {
    CHOSEN.get().copied().unwrap_or(CpuKernels::Native)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_is_native_and_bad_values_name_the_variable() {
        assert_eq!(CpuKernels::parse(None).unwrap(), CpuKernels::Native);
        assert_eq!(CpuKernels::parse(Some("")).unwrap(), CpuKernels::Native);
        assert_eq!(CpuKernels::parse(Some(" avx2 ")).unwrap(), CpuKernels::Avx2);
        let err = CpuKernels::parse(Some("avx512")).unwrap_err().to_string();
        assert!(err.contains("JOCA_CPU_KERNELS") && err.contains("\"avx512\""), "{err}");
        assert!(err.contains("\"avx2\"") && err.contains("\"native\""), "{err}");
    }

    #[test]
    fn without_avx2_the_native_paths_run() {
        assert_eq!(CpuKernels::Avx2.on_cpu(false), CpuKernels::Native);
        assert_eq!(CpuKernels::Avx2.on_cpu(true), CpuKernels::Avx2);
        assert_eq!(CpuKernels::Native.on_cpu(true), CpuKernels::Native);
    }
}
