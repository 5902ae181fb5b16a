//! Neural-network layers (Linear, GRU cells in both conventions, body GRU, LSTM, MLP).
//!
//! Every layer is a `Config` plus `load(store, prefix, config)` reading PyTorch state-dict names
//! from a [`WeightStore`](crate::weights::WeightStore). Weights are immutable after loading
//! (share them with `Arc`); recurrent state and per-step scratch buffers belong to the caller and
//! are sized once, so a step allocates nothing. Weight matrices are [`PackedMatrix`]es kept in
//! their stored dtype (f32, f16 or bf16); all arithmetic is f32.
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

pub use body_gru::{BodyGruCell, BodyGruConfig};
pub use gru::{GruCell, GruConfig, GruConvention, GruScratch};
pub use linear::{Linear, LinearConfig};
pub use lstm::{LstmCell, LstmConfig, LstmScratch};
pub use mlp::{Mlp, MlpConfig, MlpScratch};
pub use packed::{PackedMatrix, RowDtype};
pub use simd::{set_simd_path, SimdError, SimdPath};
