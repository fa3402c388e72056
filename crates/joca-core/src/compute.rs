//! How a run computed: the names a configuration, the environment and `results.json` use for
//! the scoring precision, libtorch's CPU kernels and the handling of subnormal floats. The
//! choices themselves (what the CPU has, what the environment asks) are made by `joca-nn`.

crate::named_enum! {
    /// Floating-point type a network computes in.
    #[derive(Default)]
    pub enum Precision("precision") {
        /// float32 throughout.
        #[default]
        Fp32 = "fp32",
        /// bfloat16 convolutions (float32 accumulation, weights, outputs and optimiser).
        Bf16 = "bf16",
    }
}

crate::named_enum! {
    /// Which CPU kernels libtorch runs (`JOCA_CPU_KERNELS`).
    pub enum CpuKernels("CPU kernels") {
        /// The AVX2 paths of ATen, oneDNN and MKL, whatever wider units the CPU has: the same
        /// inference on the machine types checked, training still machine-dependent.
        Avx2 = "avx2",
        /// The widest paths the CPU has (the default): numbers depend on the machine type.
        Native = "native",
    }
}

crate::named_enum! {
    /// How the process handles subnormal floats (`JOCA_DENORMALS`).
    pub enum Denormals("denormals") {
        /// Flushed to zero, as operands and as results (the default of `joca`).
        Flush = "flush",
        /// Kept (IEEE 754; library use and tests).
        Keep = "keep",
    }
}
