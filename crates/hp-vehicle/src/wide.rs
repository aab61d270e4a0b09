//! Whether [`crate::drive::run`] runs in its compilation for x86-64
//! processors with AVX2 (the same code compiled with VEX encoding: three-
//! operand instructions and 256-bit vectors, fewer register copies and
//! spills in the plant's evaluation; 17 % fewer instructions per period of
//! the 8x8). Floating-point results are the same to the bit either way: the
//! compiler neither fuses (no FMA unless asked) nor reorders floating-point
//! operations, and every operation is the IEEE one in both encodings
//! (`drive::tests::the_wide_compilation_gives_the_same_results_to_the_bit`
//! compares the two).
//!
//! The environment variable `HPCTL_NO_WIDE` (any value) keeps the baseline
//! compilation, for comparing the two.

#[cfg(target_arch = "x86_64")]
use std::sync::OnceLock;

/// True when this process runs [`crate::drive::run`]'s AVX2 compilation:
/// on x86-64, when the processor has AVX2 and `HPCTL_NO_WIDE` is not set
/// (read once per process).
pub fn available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        static WIDE: OnceLock<bool> = OnceLock::new();
        *WIDE.get_or_init(|| std::env::var_os("HPCTL_NO_WIDE").is_none() && std::arch::is_x86_feature_detected!("avx2"))
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}
