//! The deep-learning side of joca, on libtorch through `tch`.
//!
//! This is the only crate of the workspace that depends on the deep-learning engine (see
//! ARCHITECTURE.md): the detector, the NeuralAE adaptive-camera-control network, the
//! differentiable image formation and the optimisers live here, so the rest of joca stays free
//! of framework types.
//!
//! - [`Engine`] fixes the device and the thread count that every reproducible run records.
//! - [`device`] — which device a run computes on (`cpu`, `cuda:N`, `auto`) and what it is.
//! - [`kernels`] — which of libtorch's CPU code paths run (AVX2 by default, on every machine).
//! - [`detector`] — the CenterNet-style detector, its loss and decoding.
//! - [`acc`] — NeuralAE, the adaptive camera control network.
//! - [`formation`] — image formation on tensors (Eq. 2–3), differentiable in exposure and gain.
//! - [`Adam`] — Adam/AdamW with checkpointable state.
//! - [`save_weights`] / [`load_weights`] — safetensors weight files, checked tensor by tensor.
//!
//! ```
//! use joca_nn::detector::{Detector, DetectorConfig};
//! let engine = joca_nn::Engine::cpu(1);
//! let vs = tch::nn::VarStore::new(engine.device());
//! let detector = Detector::new(&vs.root(), DetectorConfig::default());
//! let image = tch::Tensor::zeros([1, 3, 48, 64], (tch::Kind::Float, engine.device()));
//! let out = detector.forward(&image);
//! assert_eq!(out.heatmap.size(), vec![1, 3, 12, 16]);
//! ```
#![deny(missing_docs)]

pub mod acc;
pub mod detector;
pub mod device;
mod error;
pub mod formation;
pub mod joint;
pub mod kernels;
mod optim;
mod weights;

pub use error::NnError;
pub use optim::{Adam, AdamConfig, grad_norm};
pub use weights::{load_weights, save_weights};

use tch::Device;

/// libtorch's generator and thread count are process-wide: unit tests that create networks
/// hold this lock so that each sees the seed it set.
#[cfg(test)]
static TORCH_SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Holds [`TORCH_SERIAL`] for the rest of a test (a test that panicked while holding it does
/// not poison it for the others).
#[cfg(test)]
pub(crate) fn torch_serial() -> std::sync::MutexGuard<'static, ()> {
    TORCH_SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// The device and thread count that every tensor of a run uses.
#[derive(Debug, Clone, Copy)]
pub struct Engine {
    device: Device,
    threads: usize,
}

impl Engine {
    /// A CPU engine with `threads` intra-op threads (libtorch's global setting).
    ///
    /// Results are reproducible for a fixed thread count; a different count may change the
    /// order of floating-point reductions and so the last bits of a result.
    pub fn cpu(threads: usize) -> Self {
        let threads = threads.max(1);
        tch::set_num_threads(i32::try_from(threads).unwrap_or(i32::MAX));
        tch::manual_seed(0);
        Self { device: Device::Cpu, threads }
    }

    /// An engine on the device `choice` resolves to on this machine ([`device::resolve`]), with
    /// `threads` intra-op threads for the CPU's share of the work. On a GPU, libtorch's
    /// deterministic algorithms are switched on. Call it before any other libtorch call of the
    /// process: libtorch looks for its CUDA part once.
    pub fn open(choice: device::DeviceChoice, threads: usize) -> Result<Self, NnError> {
        let device = device::resolve(choice, device::probe)?;
        if device.is_cuda() {
            device::cuda::set_deterministic(true).map_err(NnError::Config)?;
        }
        let engine = Self::cpu(threads);
        Ok(Self { device, ..engine })
    }

    /// The device as a record states it: `cpu`, or the GPU's index, name, memory and driver.
    pub fn describe(&self) -> String {
        device::describe(self.device)
    }

    /// Waits until the device has finished the work queued so far (a GPU computes
    /// asynchronously; the CPU has nothing to wait for): call it before reading a clock.
    pub fn synchronize(&self) {
        device::DeviceSync::of(self.device).wait();
    }

    /// The device tensors are placed on.
    pub fn device(&self) -> Device {
        self.device
    }

    /// The number of intra-op threads.
    pub fn threads(&self) -> usize {
        self.threads
    }

    /// Seeds libtorch's generator (weight initialisation) from a run stream.
    pub fn seed(&self, seed: u64) {
        tch::manual_seed(seed as i64);
    }

    /// Runs `f` with `threads` intra-op threads, then returns to this engine's count.
    pub fn with_threads<R>(&self, threads: usize, f: impl FnOnce() -> R) -> R {
        tch::set_num_threads(i32::try_from(threads.max(1)).unwrap_or(i32::MAX));
        let result = f();
        tch::set_num_threads(i32::try_from(self.threads).unwrap_or(i32::MAX));
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tch::{Kind, Tensor};

    /// The smoke test that proves libtorch is linked and runs: a matrix product and a gradient,
    /// both checked against values computed by hand.
    #[test]
    fn libtorch_computes_a_product_and_its_gradient() {
        // `Engine::cpu` reseeds the process-wide generator: not while another test draws from it.
        let _serial = torch_serial();
        let engine = Engine::cpu(1);
        let a =
            Tensor::from_slice(&[1.0f32, 2.0, 3.0, 4.0]).view([2, 2]).to_device(engine.device());
        let b = Tensor::from_slice(&[5.0f32, 6.0, 7.0, 8.0]).view([2, 2]);
        let c = a.matmul(&b);
        let got: Vec<f32> = Vec::try_from(c.flatten(0, 1)).unwrap();
        assert_eq!(got, vec![19.0, 22.0, 43.0, 50.0]);

        // d/dx sum(x^2) = 2x.
        let x = Tensor::from_slice(&[1.5f32, -2.0]).set_requires_grad(true);
        let y = (&x * &x).sum(Kind::Float);
        y.backward();
        let grad: Vec<f32> = Vec::try_from(x.grad()).unwrap();
        assert_eq!(grad, vec![3.0, -4.0]);
    }
}
