//! What the detector computes in, and what bfloat16 means on this CPU.

use tch::Kind;

/// Floating-point type the network computes in (see the module documentation). bfloat16: on a
/// CPU with AVX-512 BF16 a training step takes about 0.7–0.75× the float32 time (`joca bench
/// detector`).
pub use joca_core::compute::Precision;

/// Whether libtorch computes bfloat16 natively here: the CPU has AVX-512 BF16 and the process
/// runs libtorch's native kernels ([`crate::kernels`]; the AVX2 paths emulate bfloat16).
/// Emulated, a training step took 17× the float32 time on a 2-core AVX2 EPYC (`joca bench
/// detector`).
pub fn native_bf16() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512bf16")
            && crate::kernels::chosen() == crate::kernels::CpuKernels::Native
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// What a [`Precision`] means to libtorch on this process.
pub trait PrecisionExt {
    /// The precision to compute in on this CPU: bfloat16 only where it is native
    /// ([`native_bf16`]), float32 otherwise.
    fn on_this_cpu(self) -> Precision;
    /// The precision to compute in on `device`: on a GPU as asked (bfloat16 is native on
    /// every GPU libtorch 2.13's CUDA 13 build supports), on the CPU [`Self::on_this_cpu`].
    fn on_device(self, device: tch::Device) -> Precision;
    /// The tensor type of activations.
    fn kind(self) -> Kind;
}

impl PrecisionExt for Precision {
    fn on_this_cpu(self) -> Precision {
        if self == Precision::Bf16 && !native_bf16() { Precision::Fp32 } else { self }
    }

    fn on_device(self, device: tch::Device) -> Precision {
        if device.is_cuda() { self } else { self.on_this_cpu() }
    }

    fn kind(self) -> Kind {
        match self {
            Precision::Fp32 => Kind::Float,
            Precision::Bf16 => Kind::BFloat16,
        }
    }
}
