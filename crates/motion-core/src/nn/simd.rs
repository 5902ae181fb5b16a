//! Which vector code the kernels run: one process-wide [`SimdPath`], the best the CPU has unless
//! chosen with the `MOTION_SIMD` environment variable or [`set_simd_path`].
//!
//! Every kernel family (row products, the panel GEMM, the gate non-linearities) dispatches on
//! [`active`], so any path the machine has can be selected, tested and timed on it: the AVX2 path
//! on an AVX-512 machine, the portable path anywhere. A path the CPU lacks is refused with
//! [`SimdError::Unsupported`], never run.
//!
//! ```
//! use motion_core::nn::simd::{self, SimdPath};
//! let best = SimdPath::best();
//! assert!(best.supported());
//! simd::set_simd_path(SimdPath::Portable).unwrap(); // always there
//! assert_eq!(simd::active(), SimdPath::Portable);
//! simd::set_simd_path(best).unwrap();
//! ```
//!
//! Choose the path before loading weights: matrices are laid out at load for the path active
//! then (the AVX-512 GEMM's column panels). A matrix loaded under one path computes the same
//! products under another, only slower.
use std::sync::atomic::{AtomicU8, Ordering};

/// The environment variable read once, at the first kernel call (or by [`init_from_env`]).
pub const ENV_VAR: &str = "MOTION_SIMD";

/// A family of vector kernels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SimdPath {
    /// x86-64 AVX-512 F, BW and VL (+ F16C for f16 weights via `vcvtph2ps` on 512-bit vectors).
    Avx512,
    /// x86-64 AVX2 + FMA + F16C: 256-bit kernels, f16 widened in registers.
    Avx2,
    /// aarch64 NEON (Advanced SIMD; f16 widened with `fcvtl`).
    Neon,
    /// Plain Rust loops compiled for the build target (what WASM and unknown CPUs run).
    Portable,
}

/// Why a path cannot be selected.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SimdError {
    /// The name is not one of `avx512`, `avx2`, `neon`, `portable`.
    #[error("unknown SIMD path {0:?}: expected avx512, avx2, neon or portable")]
    Unknown(String),
    /// This CPU (or build target) does not have the path's instructions.
    #[error("this CPU cannot run the {} path (it has: {})", .0.name(), available_names())]
    Unsupported(SimdPath),
    /// `MOTION_SIMD` holds a bad value.
    #[error("{ENV_VAR}={value}: {source}")]
    Env {
        /// The variable's value.
        value: String,
        /// What is wrong with it.
        #[source]
        source: Box<SimdError>,
    },
}

impl SimdPath {
    /// Every path, widest first.
    pub const ALL: [SimdPath; 4] = [
        SimdPath::Avx512,
        SimdPath::Avx2,
        SimdPath::Neon,
        SimdPath::Portable,
    ];

    /// The name `MOTION_SIMD` and `bench --simd` take.
    pub fn name(self) -> &'static str {
        match self {
            SimdPath::Avx512 => "avx512",
            SimdPath::Avx2 => "avx2",
            SimdPath::Neon => "neon",
            SimdPath::Portable => "portable",
        }
    }

    /// The path named `name` (case-insensitive).
    pub fn parse(name: &str) -> Result<Self, SimdError> {
        let lower = name.trim().to_ascii_lowercase();
        Self::ALL
            .into_iter()
            .find(|p| p.name() == lower)
            .ok_or_else(|| SimdError::Unknown(name.to_string()))
    }

    /// Whether this CPU runs the path (detected at run time on x86-64).
    pub fn supported(self) -> bool {
        match self {
            SimdPath::Portable => true,
            #[cfg(target_arch = "x86_64")]
            SimdPath::Avx512 => {
                std::arch::is_x86_feature_detected!("avx512f")
                    && std::arch::is_x86_feature_detected!("avx512bw")
                    && std::arch::is_x86_feature_detected!("avx512vl")
                    && std::arch::is_x86_feature_detected!("f16c")
                    && std::arch::is_x86_feature_detected!("fma")
            }
            #[cfg(target_arch = "x86_64")]
            SimdPath::Avx2 => {
                std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
                    && std::arch::is_x86_feature_detected!("f16c")
            }
            #[cfg(target_arch = "aarch64")]
            SimdPath::Neon => std::arch::is_aarch64_feature_detected!("neon"),
            #[allow(unreachable_patterns)]
            _ => false,
        }
    }

    /// The widest path this CPU runs.
    pub fn best() -> Self {
        Self::ALL
            .into_iter()
            .find(|p| p.supported())
            .unwrap_or(SimdPath::Portable)
    }

    /// Every path this CPU runs, widest first (what the kernel tests iterate over).
    pub fn available() -> Vec<SimdPath> {
        Self::ALL.into_iter().filter(|p| p.supported()).collect()
    }

    fn code(self) -> u8 {
        match self {
            SimdPath::Avx512 => 1,
            SimdPath::Avx2 => 2,
            SimdPath::Neon => 3,
            SimdPath::Portable => 4,
        }
    }

    fn from_code(code: u8) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.code() == code)
    }
}

impl std::fmt::Display for SimdPath {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for SimdPath {
    type Err = SimdError;
    fn from_str(s: &str) -> Result<Self, SimdError> {
        SimdPath::parse(s)
    }
}

fn available_names() -> String {
    SimdPath::available()
        .iter()
        .map(|p| p.name())
        .collect::<Vec<_>>()
        .join(", ")
}

/// 0 = not chosen yet; else [`SimdPath::code`].
static ACTIVE: AtomicU8 = AtomicU8::new(0);

/// Selects `path` for every kernel from now on; refuses a path this CPU lacks.
pub fn set_simd_path(path: SimdPath) -> Result<(), SimdError> {
    if !path.supported() {
        return Err(SimdError::Unsupported(path));
    }
    ACTIVE.store(path.code(), Ordering::Relaxed);
    Ok(())
}

/// The path `MOTION_SIMD` names (checked against the CPU), or the best one when it is unset or
/// empty; selects it. Applications call this at start-up to report a bad value as an error
/// (the CLI exits 2); otherwise the first kernel call does the same and, on a bad value, warns
/// once on stderr and runs the best path.
pub fn init_from_env() -> Result<SimdPath, SimdError> {
    let path = match std::env::var(ENV_VAR) {
        Ok(v) if !v.trim().is_empty() => SimdPath::parse(&v)
            .and_then(|p| {
                if p.supported() {
                    Ok(p)
                } else {
                    Err(SimdError::Unsupported(p))
                }
            })
            .map_err(|e| SimdError::Env {
                value: v.clone(),
                source: Box::new(e),
            })?,
        _ => SimdPath::best(),
    };
    ACTIVE.store(path.code(), Ordering::Relaxed);
    Ok(path)
}

/// The path the kernels run now.
#[inline]
pub fn active() -> SimdPath {
    match SimdPath::from_code(ACTIVE.load(Ordering::Relaxed)) {
        Some(p) => p,
        None => init_lazily(),
    }
}

#[cold]
fn init_lazily() -> SimdPath {
    match init_from_env() {
        Ok(p) => p,
        Err(e) => {
            let best = SimdPath::best();
            eprintln!("warning: {e}; using {best}");
            ACTIVE.store(best.code(), Ordering::Relaxed);
            best
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_bad_names_are_refused() {
        for p in SimdPath::ALL {
            assert_eq!(SimdPath::parse(p.name()), Ok(p));
            assert_eq!(p.name().parse::<SimdPath>(), Ok(p));
        }
        assert_eq!(SimdPath::parse(" AVX2 "), Ok(SimdPath::Avx2));
        assert!(matches!(
            SimdPath::parse("sse9"),
            Err(SimdError::Unknown(_))
        ));
    }

    #[test]
    fn portable_is_always_there_and_best_is_supported() {
        assert!(SimdPath::Portable.supported());
        assert!(SimdPath::best().supported());
        assert!(SimdPath::available().contains(&SimdPath::Portable));
        assert_eq!(SimdPath::available()[0], SimdPath::best());
    }

    #[test]
    fn a_path_the_cpu_lacks_is_refused() {
        let lacking = SimdPath::ALL.into_iter().find(|p| !p.supported());
        // On x86-64 NEON is always missing, on aarch64 AVX2 is.
        let lacking = lacking.expect("some path is missing on every CPU");
        let err = set_simd_path(lacking).unwrap_err();
        assert_eq!(err, SimdError::Unsupported(lacking));
        assert!(err.to_string().contains(lacking.name()));
        assert!(err.to_string().contains("portable"));
    }
}
