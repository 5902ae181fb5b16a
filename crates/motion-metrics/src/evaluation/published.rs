//! The published H3.6M numbers that `eval` prints beside its own, as code.
//!
//! Citations: Gopalakrishnan, Mali, Kifer, Giles, Ororbia, "A Neural Temporal Model for Human
//! Motion Prediction", CVPR 2019 (Gopalakrishnan et al. 2019), Tables 4-7; Ghosh, Song, Aksan, Hilliges,
//! "Learning Human Motion Models for Long-term Predictions", 3DV 2017 (Ghosh et al. 2017), Table 2; Tanke, Zaveri, Gall, "Intention-based
//! Long-Term Human Motion Anticipation", 3DV 2021 (Tanke et al. 2021), Tables 1-2. Model names are
//! normalized ("GRU-d (ours)" -> "GRU-d"); Tanke et al. 2021 methods keep their reference numbers.
//! Every published NPSS was computed with the authors' code, i.e. the reference variant
//! (`Re(DFT)²`, see metrics.md).
// Table cells such as 0.318 are published numbers, not approximations of 1/π.
#![allow(clippy::approx_constant)]

use std::collections::BTreeMap;

use serde::Serialize;

/// The actions of Gopalakrishnan et al. 2019's tables, in column order.
pub const PAPER000_ACTIONS: [&str; 4] = ["walking", "eating", "smoking", "discussion"];
/// The columns of Tanke et al. 2021 Table 1 (the last is the mean over the four actions).
pub const PAPER003_TABLE1_COLUMNS: [&str; 5] =
    ["walking", "eating", "smoking", "discussion", "average"];
/// The horizons of Gopalakrishnan et al. 2019 Table 6, in milliseconds.
pub const TABLE6_HORIZONS_MS: [u32; 4] = [80, 160, 320, 400];
/// The horizons of Ghosh et al. 2017 Table 2, in milliseconds.
pub const P002_TABLE2_HORIZONS_MS: [u32; 5] = [80, 160, 320, 560, 1000];
/// The horizons of Gopalakrishnan et al. 2019 Table 7, in milliseconds.
pub const TABLE7_HORIZONS_MS: [u32; 6] = [80, 160, 320, 400, 560, 1000];

/// One model's numbers, one per table column.
#[derive(Debug, Clone, Copy)]
pub struct ModelRow<const N: usize> {
    /// The model as the paper names it.
    pub model: &'static str,
    /// One value per column.
    pub values: [f64; N],
}

/// One model's errors at `H` horizons, per action of [`PAPER000_ACTIONS`]: Gopalakrishnan et al. 2019 Table 7 at
/// [`TABLE7_HORIZONS_MS`] (`H` = 6), Ghosh et al. 2017 Table 2 at [`P002_TABLE2_HORIZONS_MS`] (`H` = 5).
#[derive(Debug, Clone, Copy)]
pub struct EulerRow<const H: usize = 6> {
    /// The model as the paper names it.
    pub model: &'static str,
    /// `values[action][horizon]`.
    pub values: [[f64; H]; 4],
}

/// One method's NDMS over the 0.4 s bins of one action (Tanke et al. 2021 Table 2).
#[derive(Debug, Clone, Copy)]
pub struct NdmsRow {
    /// The method as Tanke et al. 2021 names it.
    pub method: &'static str,
    /// The action, or `average` (over all 15 actions).
    pub action: &'static str,
    /// Bins ending at 0.4, 0.8, ..., 4.0 s; `None` where the paper has no value.
    pub bins: [Option<f64>; 10],
}

/// Gopalakrishnan et al. 2019 Table 4: NPSS over 4 s (published code, i.e. the reference variant), per model, columns [`PAPER000_ACTIONS`].
#[rustfmt::skip]
pub const P000_TABLE4_NPSS: [ModelRow<4>; 6] = [
    ModelRow { model: "VGRU-r1 (SA)", values: [1.217, 1.312, 1.736, 4.884] },
    ModelRow { model: "MBR-unsup (SA)", values: [1.809, 1.481, 2.794, 2.258] },
    ModelRow { model: "MBR-long", values: [1.499, 1.621, 4.741, 2.882] },
    ModelRow { model: "VGRU-ac", values: [1.032, 0.842, 1.426, 1.651] },
    ModelRow { model: "GRU-d", values: [0.931, 0.836, 1.274, 1.688] },
    ModelRow { model: "VGRU-d", values: [0.887, 0.846, 1.235, 1.777] },
];
/// Gopalakrishnan et al. 2019 Table 5: NPSS (reference variant) on the 0-1 s window, columns [`PAPER000_ACTIONS`].
#[rustfmt::skip]
pub const P000_TABLE5_NPSS_SHORT: [ModelRow<4>; 6] = [
    ModelRow { model: "VGRU-r1 (SA)", values: [0.12, 0.091, 0.052, 0.258] },
    ModelRow { model: "MBR-unsup (SA)", values: [0.238, 0.249, 0.183, 0.416] },
    ModelRow { model: "MBR-long", values: [0.161, 0.214, 0.265, 0.703] },
    ModelRow { model: "VGRU-ac", values: [0.118, 0.113, 0.075, 0.256] },
    ModelRow { model: "GRU-d", values: [0.127, 0.095, 0.126, 0.185] },
    ModelRow { model: "VGRU-d", values: [0.117, 0.121, 0.084, 0.194] },
];
/// Gopalakrishnan et al. 2019 Table 5: NPSS (reference variant) on the 1-2 s window, columns [`PAPER000_ACTIONS`].
#[rustfmt::skip]
pub const P000_TABLE5_NPSS_MEDIUM: [ModelRow<4>; 6] = [
    ModelRow { model: "VGRU-r1 (SA)", values: [0.194, 0.093, 0.079, 0.375] },
    ModelRow { model: "MBR-unsup (SA)", values: [0.206, 0.178, 0.237, 0.439] },
    ModelRow { model: "MBR-long", values: [0.237, 0.16, 0.405, 0.477] },
    ModelRow { model: "VGRU-ac", values: [0.188, 0.103, 0.097, 0.298] },
    ModelRow { model: "GRU-d", values: [0.17, 0.096, 0.083, 0.258] },
    ModelRow { model: "VGRU-d", values: [0.179, 0.08, 0.067, 0.331] },
];
/// Gopalakrishnan et al. 2019 Table 5: NPSS (reference variant) on the 2-4 s window, columns [`PAPER000_ACTIONS`].
#[rustfmt::skip]
pub const P000_TABLE5_NPSS_LONG: [ModelRow<4>; 6] = [
    ModelRow { model: "VGRU-r1 (SA)", values: [0.544, 0.764, 0.948, 2.72] },
    ModelRow { model: "MBR-unsup (SA)", values: [0.884, 0.684, 1.077, 0.943] },
    ModelRow { model: "MBR-long", values: [0.549, 0.754, 1.403, 1.245] },
    ModelRow { model: "VGRU-ac", values: [0.46, 0.459, 1.051, 0.811] },
    ModelRow { model: "GRU-d", values: [0.406, 0.332, 0.723, 0.785] },
    ModelRow { model: "VGRU-d", values: [0.359, 0.288, 0.577, 1.001] },
];
/// Gopalakrishnan et al. 2019 Table 6: the zero-velocity baseline's Euler error at 80, 160, 320, 400 ms, rows [`PAPER000_ACTIONS`].
#[rustfmt::skip]
pub const P000_TABLE6_ZERO_VELOCITY: [[f64; 4]; 4] = [
    [0.39, 0.68, 0.99, 1.15],
    [0.27, 0.48, 0.73, 0.86],
    [0.26, 0.48, 0.97, 0.95],
    [0.31, 0.67, 0.94, 1.04],
];
/// Gopalakrishnan et al. 2019 Table 7: Euler error of the long-term models at 80, 160, 320, 400, 560, 1000 ms, per action of [`PAPER000_ACTIONS`].
#[rustfmt::skip]
pub const P000_TABLE7_EULER: [EulerRow; 2] = [
    EulerRow { model: "GRU-d", values: [
        [1.311, 1.333, 1.369, 1.364, 1.35, 1.37],
        [1.275, 1.305, 1.386, 1.466, 1.53, 1.702],
        [1.943, 2.062, 2.201, 2.255, 2.342, 2.486],
        [1.744, 1.98, 2.026, 1.994, 2.214, 2.172],
    ] },
    EulerRow { model: "VGRU-d", values: [
        [1.108, 1.146, 1.211, 1.2, 1.22, 1.28],
        [1.09, 1.16, 1.24, 1.33, 1.37, 1.56],
        [1.67, 1.8, 1.94, 1.98, 2.06, 2.32],
        [1.749, 2.037, 2.011, 1.868, 2.088, 2.318],
    ] },
];
/// Ghosh et al. 2017 Table 2: "the Euclidean norm (L2) of un-normalized ground truth and predicted MOCAP
/// vectors" (exp-map, H3.6M) at [`P002_TABLE2_HORIZONS_MS`], per action of [`PAPER000_ACTIONS`]; the
/// baselines' rows are the paper's copies of SRNN \[19\]'s. Printed beside the Euler error of the
/// standard protocol, its closest measured counterpart (the paper does not say how it averaged).
#[rustfmt::skip]
pub const P002_TABLE2_L2: [EulerRow<5>; 4] = [
    EulerRow { model: "LSTM3LR", values: [
        [1.18, 1.50, 1.67, 1.81, 2.20],
        [1.36, 1.79, 2.29, 2.49, 2.82],
        [2.05, 2.34, 3.10, 3.24, 3.42],
        [2.25, 2.33, 2.45, 2.48, 2.93],
    ] },
    EulerRow { model: "ERD", values: [
        [1.30, 1.56, 1.84, 2.00, 2.38],
        [1.66, 1.93, 2.28, 2.36, 2.41],
        [2.34, 2.74, 3.73, 3.68, 3.82],
        [2.67, 2.97, 3.23, 3.47, 2.92],
    ] },
    EulerRow { model: "S-RNN", values: [
        [1.08, 1.34, 1.60, 1.90, 2.13],
        [1.35, 1.71, 2.12, 2.28, 2.58],
        [1.90, 2.30, 2.90, 3.21, 3.23],
        [1.67, 2.03, 2.20, 2.39, 2.43],
    ] },
    EulerRow { model: "DAE-LSTM", values: [
        [1.00, 1.11, 1.39, 1.55, 1.39],
        [1.31, 1.49, 1.86, 1.76, 2.01],
        [0.92, 1.03, 1.15, 1.38, 1.77],
        [1.11, 1.20, 1.38, 1.53, 1.73],
    ] },
];
/// Tanke et al. 2021 Table 1: NPSS (public implementation = reference variant) on the 2-4 s window, columns [`PAPER003_TABLE1_COLUMNS`].
#[rustfmt::skip]
pub const P003_TABLE1_NPSS_LONG: [ModelRow<5>; 6] = [
    ModelRow { model: "Seq2Seq [23] (MBR-long)", values: [0.549, 0.754, 1.403, 1.245, 0.987] },
    ModelRow { model: "VGRU-d [10] (paper 000)", values: [0.359, 0.288, 0.577, 1.001, 0.556] },
    ModelRow { model: "Trajectory [22]", values: [0.841, 0.909, 0.824, 1.733, 1.077] },
    ModelRow { model: "History [21]", values: [0.59, 0.821, 0.491, 1.616, 0.879] },
    ModelRow { model: "Grammar [28]", values: [0.467, 0.301, 0.751, 0.945, 0.616] },
    ModelRow { model: "Ours (paper 003)", values: [0.367, 0.621, 0.363, 0.795, 0.536] },
];
/// Tanke et al. 2021 Table 2: NDMS per 0.4 s bin (0.4 .. 4.0 s); `None` where the paper has no value.
#[rustfmt::skip]
pub const P003_TABLE2_NDMS: [NdmsRow; 36] = [
    NdmsRow { method: "Seq2Seq [23]", action: "walking", bins: [Some(0.891), Some(0.66), Some(0.673), Some(0.67), Some(0.647), Some(0.617), Some(0.562), Some(0.537), Some(0.515), Some(0.418)] },
    NdmsRow { method: "Seq2Seq [23]", action: "eating", bins: [Some(0.794), Some(0.517), Some(0.504), Some(0.514), Some(0.483), Some(0.493), Some(0.428), Some(0.428), Some(0.395), Some(0.409)] },
    NdmsRow { method: "Trajectory [22]", action: "walking", bins: [Some(0.899), Some(0.657), Some(0.605), Some(0.597), Some(0.58), Some(0.463), Some(0.494), Some(0.519), Some(0.461), Some(0.453)] },
    NdmsRow { method: "Trajectory [22]", action: "eating", bins: [Some(0.877), Some(0.622), Some(0.567), Some(0.56), Some(0.549), Some(0.543), Some(0.505), Some(0.565), Some(0.555), Some(0.53)] },
    NdmsRow { method: "History [21]", action: "walking", bins: [Some(0.929), Some(0.694), Some(0.647), Some(0.668), Some(0.641), Some(0.657), Some(0.638), Some(0.646), Some(0.646), Some(0.63)] },
    NdmsRow { method: "History [21]", action: "eating", bins: [Some(0.884), Some(0.46), Some(0.418), Some(0.426), Some(0.405), Some(0.406), Some(0.392), Some(0.415), Some(0.394), Some(0.395)] },
    NdmsRow { method: "Grammar [28]", action: "walking", bins: [Some(0.839), Some(0.429), Some(0.413), Some(0.415), Some(0.315), Some(0.291), Some(0.268), Some(0.186), Some(0.172), Some(0.131)] },
    NdmsRow { method: "Grammar [28]", action: "eating", bins: [Some(0.826), Some(0.421), Some(0.347), Some(0.315), Some(0.227), Some(0.21), Some(0.192), Some(0.167), Some(0.166), Some(0.171)] },
    NdmsRow { method: "Mix&Match [4]", action: "walking", bins: [Some(0.847), Some(0.645), Some(0.607), Some(0.625), Some(0.573), Some(0.564), Some(0.541), None, None, None] },
    NdmsRow { method: "Mix&Match [4]", action: "eating", bins: [Some(0.83), Some(0.534), Some(0.524), Some(0.534), Some(0.506), Some(0.494), Some(0.474), None, None, None] },
    NdmsRow { method: "Ours (paper 003)", action: "walking", bins: [Some(0.902), Some(0.647), Some(0.619), Some(0.63), Some(0.586), Some(0.592), Some(0.574), Some(0.604), Some(0.577), Some(0.603)] },
    NdmsRow { method: "Ours (paper 003)", action: "eating", bins: [Some(0.878), Some(0.625), Some(0.53), Some(0.56), Some(0.52), Some(0.521), Some(0.531), Some(0.525), Some(0.546), Some(0.534)] },
    NdmsRow { method: "Seq2Seq [23]", action: "smoking", bins: [Some(0.685), Some(0.491), Some(0.446), Some(0.422), Some(0.426), Some(0.432), Some(0.42), Some(0.38), Some(0.365), Some(0.367)] },
    NdmsRow { method: "Seq2Seq [23]", action: "discussion", bins: [Some(0.833), Some(0.503), Some(0.484), Some(0.472), Some(0.404), Some(0.415), Some(0.43), Some(0.399), Some(0.34), Some(0.3)] },
    NdmsRow { method: "Trajectory [22]", action: "smoking", bins: [Some(0.824), Some(0.476), Some(0.468), Some(0.411), Some(0.406), Some(0.381), Some(0.415), Some(0.402), Some(0.39), Some(0.39)] },
    NdmsRow { method: "Trajectory [22]", action: "discussion", bins: [Some(0.852), Some(0.417), Some(0.361), Some(0.314), Some(0.302), Some(0.293), Some(0.272), Some(0.29), Some(0.267), Some(0.273)] },
    NdmsRow { method: "History [21]", action: "smoking", bins: [Some(0.874), Some(0.455), Some(0.389), Some(0.404), Some(0.404), Some(0.394), Some(0.388), Some(0.399), Some(0.397), Some(0.367)] },
    NdmsRow { method: "History [21]", action: "discussion", bins: [Some(0.893), Some(0.418), Some(0.318), Some(0.317), Some(0.289), Some(0.29), Some(0.267), Some(0.279), Some(0.262), Some(0.276)] },
    NdmsRow { method: "Grammar [28]", action: "smoking", bins: [Some(0.659), Some(0.229), Some(0.221), Some(0.201), Some(0.182), Some(0.179), Some(0.171), Some(0.179), Some(0.183), Some(0.185)] },
    NdmsRow { method: "Grammar [28]", action: "discussion", bins: [Some(0.758), Some(0.187), Some(0.162), Some(0.155), Some(0.162), Some(0.198), Some(0.171), Some(0.191), Some(0.189), Some(0.164)] },
    NdmsRow { method: "Mix&Match [4]", action: "smoking", bins: [Some(0.646), Some(0.42), Some(0.429), Some(0.419), Some(0.408), Some(0.404), Some(0.411), None, None, None] },
    NdmsRow { method: "Mix&Match [4]", action: "discussion", bins: [Some(0.799), Some(0.481), Some(0.449), Some(0.428), Some(0.411), Some(0.395), Some(0.38), None, None, None] },
    NdmsRow { method: "Ours (paper 003)", action: "smoking", bins: [Some(0.8), Some(0.474), Some(0.456), Some(0.412), Some(0.446), Some(0.477), Some(0.452), Some(0.433), Some(0.445), Some(0.417)] },
    NdmsRow { method: "Ours (paper 003)", action: "discussion", bins: [Some(0.838), Some(0.503), Some(0.497), Some(0.466), Some(0.474), Some(0.467), Some(0.492), Some(0.498), Some(0.463), Some(0.449)] },
    NdmsRow { method: "Seq2Seq [23]", action: "posing", bins: [Some(0.819), Some(0.497), Some(0.443), Some(0.403), Some(0.381), Some(0.367), Some(0.335), Some(0.313), Some(0.296), Some(0.285)] },
    NdmsRow { method: "Seq2Seq [23]", action: "average", bins: [Some(0.806), Some(0.53), Some(0.508), Some(0.478), Some(0.445), Some(0.438), Some(0.414), Some(0.383), Some(0.361), Some(0.339)] },
    NdmsRow { method: "Trajectory [22]", action: "posing", bins: [Some(0.827), Some(0.476), Some(0.454), Some(0.374), Some(0.406), Some(0.328), Some(0.303), Some(0.317), Some(0.281), Some(0.307)] },
    NdmsRow { method: "Trajectory [22]", action: "average", bins: [Some(0.84), Some(0.485), Some(0.452), Some(0.391), Some(0.389), Some(0.364), Some(0.344), Some(0.367), Some(0.334), Some(0.338)] },
    NdmsRow { method: "History [21]", action: "posing", bins: [Some(0.896), Some(0.419), Some(0.343), Some(0.317), Some(0.246), Some(0.224), Some(0.218), Some(0.211), Some(0.204), Some(0.198)] },
    NdmsRow { method: "History [21]", action: "average", bins: [Some(0.884), Some(0.434), Some(0.359), Some(0.35), Some(0.337), Some(0.326), Some(0.32), Some(0.318), Some(0.315), Some(0.309)] },
    NdmsRow { method: "Grammar [28]", action: "posing", bins: [Some(0.782), Some(0.267), Some(0.246), Some(0.213), Some(0.224), Some(0.22), Some(0.208), Some(0.202), Some(0.209), Some(0.16)] },
    NdmsRow { method: "Grammar [28]", action: "average", bins: [Some(0.746), Some(0.262), Some(0.245), Some(0.236), Some(0.212), Some(0.205), Some(0.202), Some(0.19), Some(0.191), Some(0.181)] },
    NdmsRow { method: "Mix&Match [4]", action: "posing", bins: [Some(0.777), Some(0.528), Some(0.486), Some(0.453), Some(0.421), Some(0.402), Some(0.378), None, None, None] },
    NdmsRow { method: "Mix&Match [4]", action: "average", bins: [Some(0.77), Some(0.5), Some(0.48), Some(0.465), Some(0.444), Some(0.43), Some(0.419), None, None, None] },
    NdmsRow { method: "Ours (paper 003)", action: "posing", bins: [Some(0.726), Some(0.509), Some(0.539), Some(0.471), Some(0.478), Some(0.43), Some(0.421), Some(0.439), Some(0.407), Some(0.393)] },
    NdmsRow { method: "Ours (paper 003)", action: "average", bins: [Some(0.826), Some(0.531), Some(0.507), Some(0.491), Some(0.484), Some(0.478), Some(0.474), Some(0.477), Some(0.467), Some(0.465)] },
];

/// The column of `action` in `columns`.
fn column(columns: &[&str], action: &str) -> Option<usize> {
    columns.iter().position(|a| *a == action)
}

/// `{model: value}`: one column of a table.
pub type ByModel = BTreeMap<String, f64>;
/// `{horizon_ms: value}`.
pub type ByHorizon = BTreeMap<String, f64>;

/// Every published number for one action, keyed by table (a table without the action is left
/// out).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct ForAction {
    /// Gopalakrishnan et al. 2019 Table 4: NPSS (reference variant) over 0-4 s, per model.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper000_table4_npss_reference_0_4s: Option<ByModel>,
    /// Gopalakrishnan et al. 2019 Table 5: NPSS (reference variant) per window label, per model.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper000_table5_npss_reference_windows: Option<BTreeMap<String, ByModel>>,
    /// Gopalakrishnan et al. 2019 Table 6: the zero-velocity Euler error per horizon.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper000_table6_zero_velocity_euler: Option<ByHorizon>,
    /// Gopalakrishnan et al. 2019 Table 7: the Euler error per model and horizon.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper000_table7_euler: Option<BTreeMap<String, ByHorizon>>,
    /// Ghosh et al. 2017 Table 2: the error per model and horizon.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper002_table2_l2: Option<BTreeMap<String, ByHorizon>>,
    /// Tanke et al. 2021 Table 1: NPSS (reference variant) over 2-4 s, per method.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper003_table1_npss_reference_2_4s: Option<ByModel>,
    /// Tanke et al. 2021 Table 2: NDMS per 0.4 s bin, per method (`null` where the paper has none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper003_table2_ndms_bins: Option<BTreeMap<String, Vec<Option<f64>>>>,
}

/// The published averages over actions.
#[derive(Debug, Clone, Serialize)]
pub struct Averages {
    /// Tanke et al. 2021 Table 1's NPSS average over its four actions, per method.
    pub paper003_table1_npss_reference_2_4s_average_of_4_actions: ByModel,
    /// Tanke et al. 2021 Table 2's NDMS bins averaged over all 15 actions, per method.
    pub paper003_table2_ndms_bins_average_of_15_actions: BTreeMap<String, Vec<Option<f64>>>,
    /// Tanke et al. 2021 Table 5: APD on Human3.6M, per method.
    pub paper003_table5_apd_h36m: ByModel,
}

/// `{model: value}` of one column of a table.
fn column_object<const N: usize>(rows: &[ModelRow<N>], col: usize) -> ByModel {
    rows.iter()
        .map(|r| (r.model.to_string(), r.values[col]))
        .collect()
}

/// `{horizon_ms: value}`.
fn horizons_object(horizons: &[u32], values: &[f64]) -> ByHorizon {
    horizons
        .iter()
        .zip(values)
        .map(|(ms, v)| (ms.to_string(), *v))
        .collect()
}

/// `{model: {horizon_ms: value}}` of one action column of an error table.
fn models_by_horizon<const H: usize>(
    rows: &[EulerRow<H>],
    horizons: &[u32; H],
    col: usize,
) -> BTreeMap<String, ByHorizon> {
    rows.iter()
        .map(|r| {
            (
                r.model.to_string(),
                horizons_object(horizons, &r.values[col]),
            )
        })
        .collect()
}

/// `{method: bins}` of Tanke et al. 2021 Table 2's rows for `action` (`average`: over 15 actions).
fn ndms_bins_by_method(action: &str) -> BTreeMap<String, Vec<Option<f64>>> {
    ndms_rows(action)
        .map(|r| (r.method.to_string(), r.bins.to_vec()))
        .collect()
}

/// Tanke et al. 2021 Table 5: diversity (APD) on Human3.6M, per method as the paper names it. The paper
/// does not state the unit or joint set of these numbers (DLow's are "taken from \[3\]"); `eval`'s
/// APD is over world positions of all 32 joints in mm, so only the ranking is comparable.
pub const P003_TABLE5_APD_H36M: [(&str, f64); 6] = [
    ("[36]", 0.26),
    ("[34]", 1.70),
    ("[5]", 0.48),
    ("Mix&Match [4]", 3.52),
    ("DLow [37]", 4.71),
    ("Ours (paper 003)", 3.07),
];

/// The published NDMS rows of `action` (Tanke et al. 2021 Table 2).
pub fn ndms_rows(action: &str) -> impl Iterator<Item = &'static NdmsRow> + '_ {
    P003_TABLE2_NDMS.iter().filter(move |r| r.action == action)
}

/// Gopalakrishnan et al. 2019's published NPSS (reference variant, 0-4 s) of `model` for `action`.
pub fn table4_npss(model: &str, action: &str) -> Option<f64> {
    let col = column(&PAPER000_ACTIONS, action)?;
    P000_TABLE4_NPSS
        .iter()
        .find(|r| r.model == model)
        .map(|r| r.values[col])
}

/// Gopalakrishnan et al. 2019's published NPSS (reference variant) of `model` for `action` on window `w`
/// (0 = 0-1 s, 1 = 1-2 s, 2 = 2-4 s).
pub fn table5_npss(model: &str, action: &str, w: usize) -> Option<f64> {
    let col = column(&PAPER000_ACTIONS, action)?;
    let table: &[ModelRow<4>] = match w {
        0 => &P000_TABLE5_NPSS_SHORT,
        1 => &P000_TABLE5_NPSS_MEDIUM,
        2 => &P000_TABLE5_NPSS_LONG,
        _ => return None,
    };
    table
        .iter()
        .find(|r| r.model == model)
        .map(|r| r.values[col])
}

/// Gopalakrishnan et al. 2019 Table 6's zero-velocity Euler error of `action` at [`TABLE6_HORIZONS_MS`].
pub fn table6_zero_velocity(action: &str) -> Option<[f64; 4]> {
    column(&PAPER000_ACTIONS, action).map(|col| P000_TABLE6_ZERO_VELOCITY[col])
}

/// Gopalakrishnan et al. 2019 Table 7's Euler error of `model` for `action` at [`TABLE7_HORIZONS_MS`].
pub fn table7_euler(model: &str, action: &str) -> Option<[f64; 6]> {
    let col = column(&PAPER000_ACTIONS, action)?;
    P000_TABLE7_EULER
        .iter()
        .find(|r| r.model == model)
        .map(|r| r.values[col])
}

/// Ghosh et al. 2017 Table 2's error of `model` for `action` at `ms` (one of [`P002_TABLE2_HORIZONS_MS`]).
pub fn table2_p002(model: &str, action: &str, ms: u32) -> Option<f64> {
    let col = column(&PAPER000_ACTIONS, action)?;
    let h = P002_TABLE2_HORIZONS_MS.iter().position(|h| *h == ms)?;
    P002_TABLE2_L2
        .iter()
        .find(|r| r.model == model)
        .map(|r| r.values[col][h])
}

/// Every published number for `action`, keyed by table (empty if no table has it).
pub fn for_action(action: &str) -> ForAction {
    let mut out = ForAction::default();
    if let Some(col) = column(&PAPER000_ACTIONS, action) {
        out.paper000_table4_npss_reference_0_4s = Some(column_object(&P000_TABLE4_NPSS, col));
        out.paper000_table5_npss_reference_windows = Some(
            [
                ("0-1 s", column_object(&P000_TABLE5_NPSS_SHORT, col)),
                ("1-2 s", column_object(&P000_TABLE5_NPSS_MEDIUM, col)),
                ("2-4 s", column_object(&P000_TABLE5_NPSS_LONG, col)),
            ]
            .into_iter()
            .map(|(label, values)| (label.to_string(), values))
            .collect(),
        );
        out.paper000_table6_zero_velocity_euler = Some(horizons_object(
            &TABLE6_HORIZONS_MS,
            &P000_TABLE6_ZERO_VELOCITY[col],
        ));
        out.paper000_table7_euler = Some(models_by_horizon(
            &P000_TABLE7_EULER,
            &TABLE7_HORIZONS_MS,
            col,
        ));
        out.paper002_table2_l2 = Some(models_by_horizon(
            &P002_TABLE2_L2,
            &P002_TABLE2_HORIZONS_MS,
            col,
        ));
    }
    if let Some(col) = column(&PAPER003_TABLE1_COLUMNS, action) {
        out.paper003_table1_npss_reference_2_4s = Some(column_object(&P003_TABLE1_NPSS_LONG, col));
    }
    let ndms = ndms_bins_by_method(action);
    if !ndms.is_empty() {
        out.paper003_table2_ndms_bins = Some(ndms);
    }
    out
}

/// The published averages over actions: Tanke et al. 2021 Table 1's NPSS average over the four actions
/// and Table 2's NDMS average over all 15 actions.
pub fn averages() -> Averages {
    Averages {
        paper003_table1_npss_reference_2_4s_average_of_4_actions: column_object(
            &P003_TABLE1_NPSS_LONG,
            4,
        ),
        paper003_table2_ndms_bins_average_of_15_actions: ndms_bins_by_method("average"),
        paper003_table5_apd_h36m: P003_TABLE5_APD_H36M
            .iter()
            .map(|(m, v)| (m.to_string(), *v))
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::{json, Value};

    #[test]
    fn lookups_match_the_papers() {
        assert_eq!(table4_npss("VGRU-d", "walking"), Some(0.887));
        assert_eq!(table4_npss("GRU-d", "smoking"), Some(1.274));
        assert_eq!(table5_npss("VGRU-d", "eating", 2), Some(0.288));
        assert_eq!(
            table6_zero_velocity("smoking"),
            Some([0.26, 0.48, 0.97, 0.95])
        );
        assert_eq!(table7_euler("VGRU-d", "walking").unwrap()[5], 1.28);
        assert_eq!(table4_npss("VGRU-d", "greeting"), None);
        assert_eq!(table2_p002("DAE-LSTM", "smoking", 1000), Some(1.77));
        assert_eq!(table2_p002("LSTM3LR", "discussion", 80), Some(2.25));
        assert_eq!(table2_p002("DAE-LSTM", "walking", 400), None);
        let for_action = |action: &str| serde_json::to_value(for_action(action)).unwrap();
        assert_eq!(
            for_action("eating")["paper002_table2_l2"]["DAE-LSTM"]["560"],
            json!(1.76)
        );
        // Tanke et al. 2021 Table 1's VGRU-d row is Gopalakrishnan et al. 2019's Table 5 long-term row.
        for (col, action) in PAPER000_ACTIONS.iter().enumerate() {
            assert_eq!(
                P003_TABLE1_NPSS_LONG[1].values[col],
                table5_npss("VGRU-d", action, 2).unwrap()
            );
        }
        assert_eq!(ndms_rows("posing").count(), 6);
        assert_eq!(ndms_rows("average").count(), 6);
        assert!(for_action("greeting").as_object().unwrap().is_empty());
        assert_eq!(
            for_action("walking")["paper003_table2_ndms_bins"]["Mix&Match [4]"][9],
            Value::Null
        );
    }
}

/// One published MPJPE row (mm) of the 3-D protocols (`protocols_modern.md` §1.6).
#[derive(Debug, Clone, Copy)]
pub struct MpjpeRow {
    /// The method and how it was measured.
    pub method: &'static str,
    /// The window set: `8` or `256`.
    pub set: &'static str,
    /// At 80, 160, 320, 400, 560, 720, 880, 1000 ms (`None` where none is published).
    pub values: [Option<f64>; 8],
    /// Where the number was read.
    pub source: &'static str,
}

/// The published 15-action averages of the MPJPE protocols. Citations: Mao, Liu, Salzmann, Li,
/// "Learning Trajectory Dependencies for Human Motion Prediction", ICCV 2019 (LTD); Mao, Liu,
/// Salzmann, "History Repeats Itself", ECCV 2020 (HRI); Guo, Du, Moreno-Noguer, Alameda-Pineda,
/// "Back to MLP: A Simple Baseline for Human Motion Prediction", WACV 2023 (siMLPe).
#[rustfmt::skip]
pub const MPJPE_ROWS: [MpjpeRow; 5] = [
    MpjpeRow { method: "zero-velocity", set: "256",
        values: [Some(23.8), Some(44.4), Some(76.1), Some(88.2), Some(107.4), Some(121.6), Some(131.6), Some(136.6)],
        source: "posepred COMMANDS.md @c0c04345 (the pUAL paper's table as the authors' toolbox tabulates it)" },
    MpjpeRow { method: "HRI (released model)", set: "256",
        values: [Some(10.4), Some(22.6), Some(47.1), Some(58.3), Some(77.3), Some(91.8), Some(104.1), Some(112.1)],
        source: "HRI checkpoint/pretrained/h36m_3d_in50_out10_dctn20/test_pre_action.csv @0451c844, average row" },
    MpjpeRow { method: "siMLPe (paper)", set: "256",
        values: [Some(9.6), Some(21.7), Some(46.3), Some(57.3), Some(75.7), Some(90.1), Some(101.8), Some(109.4)],
        source: "siMLPe Table 1 as quoted in dulucas/siMLPe issue #12" },
    MpjpeRow { method: "siMLPe (released checkpoint, re-measured)", set: "256",
        values: [Some(13.4), Some(24.0), Some(47.7), Some(58.4), Some(78.6), Some(92.1), Some(105.2), Some(112.0)],
        source: "dulucas/siMLPe issue #12 (a user's re-run)" },
    MpjpeRow { method: "LTD (pre-trained, 3-D, 10 observed frames)", set: "8",
        values: [Some(12.1), Some(25.0), Some(51.0), Some(61.3), None, None, None, None],
        source: "LTD README.md @b81bef95, results table" },
];

/// HRI's released model on the 256-set, per action (the actions whose row is copied in
/// `protocols_modern.md` §1.6; HRI's CSV, same source as [`MPJPE_ROWS`]).
#[rustfmt::skip]
pub const HRI_256_PER_ACTION: [(&str, [f64; 8]); 8] = [
    ("walking", [10.0, 19.5, 34.2, 39.8, 47.4, 52.1, 55.5, 58.1]),
    ("eating", [6.4, 14.0, 28.7, 36.2, 50.0, 61.4, 70.6, 75.7]),
    ("smoking", [7.0, 14.9, 29.9, 36.4, 47.6, 56.6, 64.4, 69.5]),
    ("discussion", [10.2, 23.4, 52.1, 65.4, 86.6, 102.2, 113.2, 119.8]),
    ("greeting", [13.7, 30.1, 63.8, 78.1, 101.9, 118.4, 132.7, 138.8]),
    ("phoning", [8.6, 18.3, 39.0, 49.2, 67.4, 82.9, 96.5, 105.0]),
    ("posing", [10.2, 24.2, 58.5, 75.8, 107.6, 136.8, 161.4, 178.2]),
    ("walkingdog", [20.1, 40.3, 73.3, 86.3, 108.2, 120.6, 135.9, 146.9]),
];

/// HRI's published 256-set row of `action`, if copied.
pub fn hri_256_action(action: &str) -> Option<[f64; 8]> {
    HRI_256_PER_ACTION
        .iter()
        .find(|(a, _)| *a == action)
        .map(|(_, v)| *v)
}
