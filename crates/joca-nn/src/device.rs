//! Which device a run's tensors live on: what a user asks for (`cpu`, `cuda`, `cuda:N`,
//! `auto`), what this machine and this libtorch can give, and what a record says about it.
//!
//! joca is built against libtorch's CPU libraries. The CUDA part (`libtorch_cuda.so`) is loaded
//! at run time, only when a GPU is asked for ([`cuda`]), from libtorch's own folder or the
//! loader's search path: one binary serves CPU machines and GPU machines alike, and a CPU build
//! never needs the CUDA libraries. libtorch caches whether CUDA is present the first time it is
//! asked (seeding asks), so [`crate::Engine::open`] loads it before any other libtorch call.
//!
//! On a GPU, libtorch's deterministic algorithms are switched on (warning, not failing, where an
//! operation has none), cuDNN's autotuner off, and cuBLAS given a fixed workspace
//! ([`prepare_process`]): runs repeat on one GPU model and driver where every operation has a
//! deterministic kernel; what does not is said in docs/guide/gpu.md.

pub mod cuda;

use crate::NnError;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::fmt;
use std::str::FromStr;

/// The values a device setting accepts, for error messages.
pub const DEVICE_VALUES: &str = "cpu, cuda (the first GPU), cuda:N (the GPU of index N = 0, 1, \
    …) and auto (the first GPU where libtorch can use one, else the CPU)";

/// What a user asks a run to compute on (`[run] device`, `--device`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DeviceChoice {
    /// The CPU (the default).
    #[default]
    Cpu,
    /// The GPU of this index (`cuda` is `cuda:0`).
    Cuda(usize),
    /// The first GPU where one is usable, else the CPU.
    Auto,
}

impl DeviceChoice {
    /// Whether this is the CPU (for `skip_serializing_if`).
    pub fn is_cpu(&self) -> bool {
        *self == DeviceChoice::Cpu
    }
}

impl FromStr for DeviceChoice {
    type Err = NnError;

    fn from_str(s: &str) -> Result<Self, NnError> {
        let unknown =
            || NnError::Config(format!("unknown device `{s}`: allowed are {DEVICE_VALUES}"));
        match s.trim() {
            "cpu" => Ok(DeviceChoice::Cpu),
            "cuda" => Ok(DeviceChoice::Cuda(0)),
            "auto" => Ok(DeviceChoice::Auto),
            other => match other.strip_prefix("cuda:") {
                // Digits only: `cuda:+1` and `cuda: 1` are not indices a user means.
                Some(n) if !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()) => {
                    n.parse().map(DeviceChoice::Cuda).map_err(|_| unknown())
                }
                _ => Err(unknown()),
            },
        }
    }
}

impl fmt::Display for DeviceChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DeviceChoice::Cpu => f.write_str("cpu"),
            DeviceChoice::Cuda(i) => write!(f, "cuda:{i}"),
            DeviceChoice::Auto => f.write_str("auto"),
        }
    }
}

impl Serialize for DeviceChoice {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for DeviceChoice {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

/// What this process found when it looked for GPUs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CudaProbe {
    /// libtorch's CUDA part could not be loaded (a CPU build): the loader's reasons.
    NoCudaPart(String),
    /// The CUDA part is loaded; libtorch sees this many GPUs.
    Gpus(usize),
}

/// The device `choice` resolves to, given what the machine has (`probe`, asked only when a GPU
/// may be wanted), or why it cannot be had.
pub fn resolve(
    choice: DeviceChoice,
    probe: impl FnOnce() -> CudaProbe,
) -> Result<tch::Device, NnError> {
    let index = match choice {
        DeviceChoice::Cpu => return Ok(tch::Device::Cpu),
        DeviceChoice::Auto => None,
        DeviceChoice::Cuda(i) => Some(i),
    };
    let refuse = |found: String| {
        NnError::Config(format!("device `{choice}`: {found}. {}", cuda::HOW_TO_BUILD))
    };
    match (probe(), index) {
        (CudaProbe::Gpus(n), None) if n > 0 => Ok(tch::Device::Cuda(0)),
        (_, None) => Ok(tch::Device::Cpu),
        (CudaProbe::NoCudaPart(why), Some(_)) => Err(refuse(format!(
            "this libtorch has no CUDA part (a CPU build: libtorch_cuda.so could not be loaded: \
             {why})"
        ))),
        (CudaProbe::Gpus(0), Some(_)) => Err(NnError::Config(format!(
            "device `{choice}`: libtorch's CUDA part is loaded but it finds no GPU (is the NVIDIA \
             driver installed and CUDA_VISIBLE_DEVICES not empty? `nvidia-smi` lists what the \
             driver sees); use --device cpu"
        ))),
        (CudaProbe::Gpus(n), Some(i)) if i >= n => Err(NnError::Config(format!(
            "device `{choice}`: this machine has {n} GPU{} (cuda:0{}); there is no GPU {i}",
            if n == 1 { "" } else { "s" },
            if n == 1 { String::new() } else { format!(" to cuda:{}", n - 1) }
        ))),
        (CudaProbe::Gpus(_), Some(i)) => Ok(tch::Device::Cuda(i)),
    }
}

/// Looks for GPUs: loads libtorch's CUDA part if it is not loaded yet, then counts the GPUs
/// libtorch sees. Call it before any other libtorch call of the process (see the module
/// documentation).
pub fn probe() -> CudaProbe {
    match cuda::load() {
        Err(why) => CudaProbe::NoCudaPart(why),
        Ok(()) => CudaProbe::Gpus(usize::try_from(tch::Cuda::device_count()).unwrap_or(0)),
    }
}

/// A line for records and run headers: `cpu`, or the GPU's index, name, memory, driver and the
/// CUDA runtime libtorch runs on.
pub fn describe(device: tch::Device) -> String {
    match device {
        tch::Device::Cuda(i) => cuda::describe(i),
        other => format!("{other:?}").to_lowercase(),
    }
}

/// The GPU a record's networks ran on ([`describe`]); `None` on the CPU, which a record states
/// by its CPU's name.
pub fn gpu_description(device: tch::Device) -> Option<String> {
    device.is_cuda().then(|| describe(device))
}

/// Waits for a device's queued work before a clock is read (`joca bench step`'s parts): a GPU
/// computes asynchronously, so without it one part's time would be counted in the next's.
#[derive(Debug, Clone, Copy, Default)]
pub struct DeviceSync(Option<i64>);

impl DeviceSync {
    /// For `device` (nothing to wait for on the CPU).
    pub fn of(device: tch::Device) -> Self {
        match device {
            tch::Device::Cuda(i) => Self(i64::try_from(i).ok()),
            _ => Self(None),
        }
    }

    /// Returns once the device has finished its queued work.
    pub fn wait(&self) {
        if let Some(i) = self.0 {
            tch::Cuda::synchronize(i);
        }
    }
}

/// Process-wide settings a GPU run needs before CUDA starts (cuBLAS reads its workspace size
/// once): `CUBLAS_WORKSPACE_CONFIG=:4096:8` unless the user set it. Harmless on a CPU.
///
/// # Safety
/// Changes the process environment: call it before any other thread exists (first thing in
/// `main`).
#[allow(unsafe_code)]
pub unsafe fn prepare_process() {
    if std::env::var_os(cuda::CUBLAS_WORKSPACE).is_none() {
        // SAFETY: the caller guarantees no other thread reads or writes the environment.
        unsafe { std::env::set_var(cuda::CUBLAS_WORKSPACE, ":4096:8") };
    }
}

#[cfg(test)]
mod tests;
