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
//!
//! Subnormal floats (below 1.2·10⁻³⁸) are flushed to zero by default ([`DENORMALS_ENV`]): a
//! pre-trained detector's back-propagated gradients hold many, and x86 cores take a slow
//! microcode path for each subnormal operand or result (the DF-Grad step's backward pass is a
//! fifth shorter without them: docs/results, 2026-11-25). [`select_from_env`] sets the flush
//! (MXCSR's flush-to-zero and denormals-are-zero bits) on the main thread before any other thread
//! exists; every thread started later (rayon's, libtorch's OpenMP pool) inherits it, so every
//! thread rounds alike. `JOCA_DENORMALS=keep` keeps IEEE subnormals. Library use and unit tests
//! never call it and keep them.

use std::sync::OnceLock;

use crate::NnError;

/// The environment variable that chooses the kernels: `native` (the default) or `avx2`.
pub const ENV: &str = "JOCA_CPU_KERNELS";

/// libtorch's variables and the values that pin each library to its AVX2 path.
pub const AVX2_PINS: [(&str, &str); 3] =
    [("ATEN_CPU_CAPABILITY", "avx2"), ("DNNL_MAX_CPU_ISA", "AVX2"), ("MKL_CBWR", "AVX2")];

pub use joca_core::compute::{CpuKernels, Denormals};

static CHOSEN: OnceLock<CpuKernels> = OnceLock::new();

/// The environment variable that chooses how subnormal floats are handled: `flush` (the
/// default: to zero) or `keep`.
pub const DENORMALS_ENV: &str = "JOCA_DENORMALS";

static DENORMALS: OnceLock<Denormals> = OnceLock::new();

/// What `JOCA_DENORMALS` asks for (unset or empty: `flush`).
pub fn parse_denormals(value: Option<&str>) -> Result<Denormals, NnError> {
    match value.map(str::trim) {
        None | Some("") | Some("flush") => Ok(Denormals::Flush),
        Some("keep") => Ok(Denormals::Keep),
        Some(other) => Err(NnError::Config(format!(
            "environment variable {DENORMALS_ENV} = {other:?}: allowed values are \"flush\" \
             (the default: subnormal floats become zero, much faster on x86) and \"keep\" \
             (IEEE subnormals)"
        ))),
    }
}

/// Sets flush-to-zero and denormals-are-zero on the calling thread (threads it starts later
/// inherit them). Returns whether it could (x86-64 only).
///
/// # Safety
/// Rust and LLVM assume the default floating-point environment: code evaluated at compile time
/// and at run time can then differ, though only where a subnormal value occurs. Call it before
/// any other thread exists, so that every thread computes alike.
#[allow(unsafe_code)]
unsafe fn flush_denormals() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        // Bit 15: flush-to-zero (subnormal results), bit 6: denormals-are-zero (operands).
        const FTZ_DAZ: u32 = (1 << 15) | (1 << 6);
        #[allow(deprecated)]
        // SAFETY: SSE is part of x86-64; see the function's own safety note.
        unsafe {
            std::arch::x86_64::_mm_setcsr(std::arch::x86_64::_mm_getcsr() | FTZ_DAZ);
        }
        true
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The kernels `JOCA_CPU_KERNELS` asks for (unset or empty: `native`).
pub fn parse_kernels(value: Option<&str>) -> Result<CpuKernels, NnError> {
    match value.map(str::trim) {
        None | Some("") | Some("native") => Ok(CpuKernels::Native),
        Some("avx2") => Ok(CpuKernels::Avx2),
        Some(other) => Err(NnError::Config(format!(
            "environment variable {ENV} = {other:?}: allowed values are \"native\" (the \
             default: libtorch's widest kernels for this CPU) and \"avx2\" (libtorch \
             pinned to its AVX2 paths)"
        ))),
    }
}

/// What runs on a CPU that has (`true`) or lacks AVX2 and FMA: the AVX2 paths need them.
pub fn kernels_on_cpu(asked: CpuKernels, has_avx2_fma: bool) -> CpuKernels {
    if has_avx2_fma { asked } else { CpuKernels::Native }
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
    let asked = parse_kernels(std::env::var(ENV).ok().as_deref())?;
    let chosen = kernels_on_cpu(asked, cpu_has_avx2_fma());
    if chosen == CpuKernels::Avx2 {
        for (key, value) in AVX2_PINS {
            // SAFETY: the caller guarantees no other thread reads or writes the environment.
            unsafe { std::env::set_var(key, value) };
        }
    }
    let _ = CHOSEN.set(chosen);
    let denormals = match parse_denormals(std::env::var(DENORMALS_ENV).ok().as_deref())? {
        // SAFETY: the caller guarantees that no other thread exists yet.
        Denormals::Flush if unsafe { flush_denormals() } => Denormals::Flush,
        _ => Denormals::Keep,
    };
    let _ = DENORMALS.set(denormals);
    Ok(chosen)
}

/// How this process handles subnormal floats: what [`select_from_env`] set, `keep` if it never
/// ran (library use, unit tests).
pub fn denormals() -> Denormals {
    DENORMALS.get().copied().unwrap_or(Denormals::Keep)
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
        assert_eq!(parse_kernels(None).unwrap(), CpuKernels::Native);
        assert_eq!(parse_kernels(Some("")).unwrap(), CpuKernels::Native);
        assert_eq!(parse_kernels(Some(" avx2 ")).unwrap(), CpuKernels::Avx2);
        let err = parse_kernels(Some("avx512")).unwrap_err().to_string();
        assert!(err.contains("JOCA_CPU_KERNELS") && err.contains("\"avx512\""), "{err}");
        assert!(err.contains("\"avx2\"") && err.contains("\"native\""), "{err}");
    }

    #[test]
    fn denormals_are_flushed_by_default_and_bad_values_name_the_variable() {
        assert_eq!(parse_denormals(None).unwrap(), Denormals::Flush);
        assert_eq!(parse_denormals(Some(" keep")).unwrap(), Denormals::Keep);
        let err = parse_denormals(Some("off")).unwrap_err().to_string();
        assert!(err.contains("JOCA_DENORMALS") && err.contains("\"off\""), "{err}");
        assert!(err.contains("\"flush\"") && err.contains("\"keep\""), "{err}");
    }

    /// With the flush set, a subnormal operand reads as zero and a product below the normal
    /// range is zero; threads started afterwards inherit it. Checked in a thread of its own, so
    /// the other tests keep IEEE subnormals.
    #[cfg(target_arch = "x86_64")]
    #[test]
    #[allow(unsafe_code)]
    fn the_flush_makes_subnormals_zero_in_threads_started_after_it() {
        let seen = std::thread::spawn(|| {
            let tiny = std::hint::black_box(1e-39f32); // subnormal
            // black_box on the results too: LLVM assumes a fixed floating-point environment and
            // could otherwise compute them after the flush.
            let before = std::hint::black_box((
                std::hint::black_box(tiny) * std::hint::black_box(1.5f32),
                std::hint::black_box(1e-20f32) * 1e-20,
            ));
            // SAFETY: this thread computes nothing else; the test only reads floats.
            assert!(unsafe { flush_denormals() });
            let after = (
                std::hint::black_box(tiny) * std::hint::black_box(1.5f32),
                std::hint::black_box(1e-20f32) * 1e-20,
            );
            let child = std::thread::spawn(move || {
                std::hint::black_box(tiny) * std::hint::black_box(1.5f32)
            })
            .join();
            (before, after, child.unwrap())
        })
        .join()
        .unwrap();
        let (before, after, child) = seen;
        assert!(before.0 > 0.0 && before.1 > 0.0, "{before:?}");
        assert_eq!(after, (0.0, 0.0));
        assert_eq!(child, 0.0);
    }

    #[test]
    fn without_avx2_the_native_paths_run() {
        assert_eq!(kernels_on_cpu(CpuKernels::Avx2, false), CpuKernels::Native);
        assert_eq!(kernels_on_cpu(CpuKernels::Avx2, true), CpuKernels::Avx2);
        assert_eq!(kernels_on_cpu(CpuKernels::Native, true), CpuKernels::Native);
    }
}
