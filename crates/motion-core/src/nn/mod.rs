//! Neural-network layers (Linear, GRU cells in both conventions, body GRU, LSTM, MLP) and
//! [`Stack`], the stacked recurrent layers every multi-layer model runs.
//!
//! Every layer is a `Config` plus `load(store, prefix, config)` reading PyTorch state-dict names
//! from a [`WeightStore`](crate::weights::WeightStore). Weights are immutable after loading
//! (share them with `Arc`); recurrent state and per-step scratch buffers belong to the caller and
//! are sized once, so a step allocates nothing. Weight matrices are [`PackedMatrix`]es kept in
//! their stored dtype (f32, f16 or bf16); all arithmetic is f32.
//!
//! The arithmetic:
//! - [`gemm`]: `Y = X Wᵀ`, the one matrix product every layer uses; it picks the row kernels
//!   (small batches) or the panel GEMM (large batches) and splits products over threads;
//! - `kernels`: the row kernels, one module per SIMD path (`kernels::{portable, avx2, avx512,
//!   neon}`, each supplying its register tiles) and the driver they share, with the per-path
//!   tests of every kernel family;
//! - [`sgemm_panels`]: the panel GEMM (weights packed into column panels at load) and its AVX-512,
//!   AVX2 and portable kernels;
//! - [`gates`]: the vectorized GRU gate non-linearities, compiled once per SIMD path;
//! - [`simd`]: which [`SimdPath`] all of them run (`MOTION_SIMD`);
//! - [`packed`]: the weight layout chosen at load; [`parallel`]: how many threads they may use.
pub mod activation;
pub mod body_gru;
pub mod gates;
pub mod gemm;
pub mod gru;
mod kernels;
mod layout;
pub mod linear;
pub mod lstm;
pub mod mlp;
pub mod packed;
pub mod parallel;
pub mod sgemm_panels;
pub mod simd;
pub mod stack;

pub use body_gru::{BodyGruCell, BodyGruConfig};
pub use gru::{GruCell, GruConfig, GruConvention, GruScratch};
pub use linear::{Linear, LinearConfig};
pub use lstm::{LstmCell, LstmConfig, LstmScratch};
pub use mlp::{Mlp, MlpConfig, MlpScratch};
pub use packed::{PackedMatrix, RowDtype};
pub use simd::{set_simd_path, SimdError, SimdPath};
pub use stack::{Recurrent, Stack, StackState};
