//! The `config` and `provenance` metadata of a motion-weights file (schema: weights/README.md).
use crate::formats::bvh::parse_bvh;
use crate::nn::GruConvention;
use crate::seed::rescale_bvh;
use crate::skeleton::{Skeleton, H36M_ACTIONS, H36M_DIMS_USED, H36M_FRAME_DIMS};
use serde::{Deserialize, Serialize};
use std::path::Path;

use super::weights::{WeightStore, WeightsError};
use super::{ArchConfig, Architecture};

/// The metadata `format` value of a motion-weights file.
pub const FORMAT_NAME: &str = "motion-weights";
/// The one `format_version` this crate reads.
pub const FORMAT_VERSION: u32 = 1;
/// The `skeleton` of a model on H3.6M's 32 joints.
pub const H36M_SKELETON: &str = "h36m-32";
/// The `skeleton` of a model on the rig its file holds (`rig_bvh`).
pub const RIG_SKELETON: &str = "rig";

/// The only derivative padding defined by the schema.
pub const DERIVATIVE_PADDING: &str = "repeat-first";

/// The `config` JSON object: everything an engine needs to build and drive the model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelConfig {
    /// The architecture (`vgru-d`, `gru-d`, `dae-lstm` or `intention`, the `architecture` key)
    /// and the fields only it has.
    #[serde(flatten)]
    pub arch: ArchConfig,
    /// Width of a full frame as callers see it (99 for H3.6M).
    pub frame_dims: usize,
    /// Indices of the full-frame dims the model predicts; the others are restored to the mean.
    pub dims_used: Vec<usize>,
    /// Body GRU units (`vgru-d`) or units per recurrent layer (`gru-d`, `dae-lstm`, the pose
    /// decoder of `intention`).
    pub hidden: usize,
    /// Stacked GRU (`gru-d`, `intention`'s pose decoder) or LSTM (`dae-lstm`) layers; 1 for
    /// `vgru-d`.
    pub layers: usize,
    /// Candidate convention of every GRU cell in the file (no GRU in `dae-lstm`: ignored there).
    pub gru_convention: GruConvention,
    /// How `norm.mean` / `norm.std` were computed: `standard` (mean and standard deviation) or
    /// `min-max` (minimum and max - min, features in [0, 1] on the training set). The arithmetic
    /// is the same `(x - mean) / std` either way; the field says what the numbers are.
    #[serde(default = "standard_normalization")]
    pub normalization: String,
    /// Output = input frame (normalized used dims) + decoder.
    pub residual: bool,
    /// 0 (plain frames) or up to 3 (frame + backward differences of order 1..=n).
    pub derivative_order: usize,
    /// `repeat-first` (the only padding defined).
    pub derivative_padding: String,
    /// Frame rate the model was trained at.
    pub fps: f64,
    /// Skeleton name: `h36m-32` (H3.6M's 32 joints, 99 values per frame) or `rig` (the BVH
    /// hierarchy in [`rig_bvh`](Self::rig_bvh), `3 + 3 * joints` values per frame, the root as
    /// per-frame deltas: `motion_core::takes::training`'s layout).
    pub skeleton: String,
    /// With `skeleton: "rig"`: the rig as BVH text (hierarchy in the rig file's units, one frame).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rig_bvh: Option<String>,
    /// With `skeleton: "rig"`: millimetres per unit of [`rig_bvh`](Self::rig_bvh).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mm_per_unit: Option<f64>,
    /// A pose prior in the closed loop (`prior.*` tensors, [`crate::model::prior`]): its radius
    /// in standard deviations; `None`: no prior.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior_radius: Option<f64>,
    /// Action labels in one-hot order (empty for unconditioned models). VGRU-d feeds the one-hot
    /// to its plan GRU, DAE-LSTM appends it to the first LSTM layer's input.
    #[serde(default)]
    pub actions: Vec<String>,
    /// Seed length used in training.
    pub seed_frames: usize,
    /// Predicted frames per plan in training; a VGRU plan covers `seed + horizon` steps.
    pub horizon: usize,
}

/// Upper bounds of a model file's sizes ([`ModelConfig::validate`]): far above any model of the
/// papers, low enough that every buffer they size is allocatable and no product of them wraps.
pub mod limits {
    /// Values per frame.
    pub const FRAME_DIMS: usize = 1 << 16;
    /// Units of a recurrent or autoencoder layer.
    pub const UNITS: usize = 1 << 16;
    /// Stacked layers.
    pub const LAYERS: usize = 64;
    /// Seed frames and plan horizon (frames).
    pub const FRAMES: usize = 100_000;
    /// Action labels.
    pub const ACTIONS: usize = 10_000;
    /// Intention labels (`intentions`) and pose clusters (`clusters`).
    pub const INTENTIONS: usize = 10_000;
    /// Look-ahead of the intention model (frames).
    pub const LOOKAHEAD: usize = 10_000;
    /// The intention model's `noise_scale`: 0 ..= this.
    pub const NOISE_SCALE: f32 = 100.0;
    /// Values of one row's window of intention probabilities, `lookahead * intentions`.
    pub const WINDOW_VALUES: usize = 1 << 20;
    /// Frames per second: 1 ..= this.
    pub const FPS: f64 = 1000.0;
    /// Values in a plan's frames, `(seed_frames + horizon) * frame_dims` (a generator keeps
    /// that many per character).
    pub const PLAN_VALUES: usize = 1 << 26;
}

impl ModelConfig {
    /// Parses and validates the `config` metadata value of `path`.
    pub fn from_json(json: &str, path: &Path) -> Result<Self, WeightsError> {
        let bad = |problem: String| WeightsError::BadConfig {
            path: path.to_path_buf(),
            key: "config".into(),
            problem,
        };
        // The architecture first, so that a file of another kind (an action classifier) is named
        // as such rather than by the first field it lacks.
        let value: serde_json::Value =
            serde_json::from_str(json).map_err(|e| bad(e.to_string()))?;
        match value.get("architecture") {
            Some(serde_json::Value::String(name)) if Architecture::from_name(name).is_none() => {
                let known: Vec<&str> = Architecture::ALL.iter().map(|a| a.name()).collect();
                return Err(bad(format!(
                    "unknown architecture `{name}`, expected one of `{}`",
                    known.join("`, `")
                )));
            }
            None => return Err(bad("missing field `architecture`".into())),
            _ => {}
        }
        let config: ModelConfig = serde_json::from_value(value).map_err(|e| bad(e.to_string()))?;
        config.validate().map_err(bad)?;
        Ok(config)
    }

    /// Checks the fields against each other; returns what is wrong.
    pub fn validate(&self) -> Result<(), String> {
        let at_most = |what: &str, value: usize, limit: usize| {
            if value > limit {
                Err(format!("{what} {value} is over the limit of {limit}"))
            } else {
                Ok(())
            }
        };
        at_most("frame_dims", self.frame_dims, limits::FRAME_DIMS)?;
        at_most("hidden", self.hidden, limits::UNITS)?;
        at_most("layers", self.layers, limits::LAYERS)?;
        at_most("seed_frames", self.seed_frames, limits::FRAMES)?;
        at_most("horizon", self.horizon, limits::FRAMES)?;
        at_most("actions", self.actions.len(), limits::ACTIONS)?;
        at_most(
            "(seed_frames + horizon) * frame_dims",
            (self.seed_frames + self.horizon) * self.frame_dims,
            limits::PLAN_VALUES,
        )?;
        validate_dims_used(&self.dims_used, self.frame_dims)?;
        if self.seed_frames == 0 {
            return Err("seed_frames is 0: the model needs at least one seed frame".into());
        }
        for (i, name) in self.actions.iter().enumerate() {
            if name.trim().is_empty() {
                return Err(format!("action label {i} is empty"));
            }
            if self.actions[..i].contains(name) {
                return Err(format!(
                    "action label {name:?} appears twice (labels {} and {i})",
                    self.actions[..i]
                        .iter()
                        .position(|a| a == name)
                        .unwrap_or(0)
                ));
            }
        }
        if self.hidden == 0 {
            return Err("hidden is 0".into());
        }
        validate_derivatives(self.derivative_order, &self.derivative_padding)?;
        if !(self.fps.is_finite() && (1.0..=limits::FPS).contains(&self.fps)) {
            return Err(format!(
                "fps {} is outside 1 ..= {} frames per second",
                crate::motion::compact_number(self.fps),
                limits::FPS
            ));
        }
        self.arch.validate(self)?;
        self.skeleton()?;
        if !matches!(self.normalization.as_str(), "standard" | "min-max") {
            return Err(format!(
                "normalization {:?} is neither \"standard\" nor \"min-max\"",
                self.normalization
            ));
        }
        Ok(())
    }

    /// The skeleton the frames are on: H3.6M's, or the rig the file holds; its exp-map width
    /// must be `frame_dims`.
    ///
    /// # Errors
    /// An unknown skeleton name, a rig that is missing or unreadable, or a frame width that is
    /// not the skeleton's.
    pub fn skeleton(&self) -> Result<Skeleton, String> {
        let skeleton = match self.skeleton.as_str() {
            H36M_SKELETON => Skeleton::h36m(),
            RIG_SKELETON => {
                let text = self
                    .rig_bvh
                    .as_deref()
                    .ok_or("skeleton \"rig\" without rig_bvh (the rig as BVH text)")?;
                let mm = self.mm_per_unit.unwrap_or(1.0);
                if !(mm.is_finite() && mm > 0.0) {
                    return Err(format!("mm_per_unit {mm:e} is not a positive length"));
                }
                let rig = parse_bvh(text, Path::new("config.rig_bvh"))
                    .map_err(|e| format!("rig_bvh: {e}"))?;
                rescale_bvh(&rig, mm)
                    .map_err(|e| format!("rig_bvh: {e}"))?
                    .skeleton
            }
            other => {
                return Err(format!(
                    "unknown skeleton {other:?}: this crate knows \"{H36M_SKELETON}\" and \"{RIG_SKELETON}\" (a BVH rig in rig_bvh)"
                ))
            }
        };
        if skeleton.expmap_width() != self.frame_dims {
            return Err(format!(
                "frame_dims {} is not the {} skeleton's {} (3 + 3 per joint)",
                self.frame_dims,
                self.skeleton,
                skeleton.expmap_width()
            ));
        }
        Ok(skeleton)
    }

    /// Source frames each frame's root delta spans: H3.6M's deltas are per 50 Hz source frame
    /// (2 at 25 Hz); a rig model's per frame (1).
    pub fn root_step(&self) -> usize {
        if self.skeleton == H36M_SKELETON {
            ((crate::skeleton::H36M_SOURCE_FPS / self.fps).round() as usize).max(1)
        } else {
            1
        }
    }

    /// Model output width `O` (= number of used dims).
    pub fn output_dims(&self) -> usize {
        self.dims_used.len()
    }

    /// Model input width `I = O * (1 + derivative_order)` (features of one frame; a DAE-LSTM's
    /// first layer also reads the action one-hot, see [`rnn_input_dims`](Self::rnn_input_dims)).
    pub fn input_dims(&self) -> usize {
        self.output_dims() * (1 + self.derivative_order)
    }

    /// Width of the first recurrent layer's input: the features, plus what the architecture
    /// appends (a DAE-LSTM with actions: the action one-hot).
    pub fn rnn_input_dims(&self) -> usize {
        self.arch.rnn_input_dims(self)
    }

    /// A configuration over H3.6M frames at 25 Hz (99 values, the 54 varying ones used; 50 seed
    /// and 100 predicted frames), with `hidden` units in `layers` layers, standard
    /// normalization, PyTorch GRUs, no residual, plain poses and no actions: the base the
    /// architectures' paper configurations change.
    pub fn h36m(arch: ArchConfig, hidden: usize, layers: usize) -> Self {
        ModelConfig {
            arch,
            frame_dims: H36M_FRAME_DIMS,
            dims_used: H36M_DIMS_USED.to_vec(),
            hidden,
            layers,
            gru_convention: GruConvention::PyTorch,
            normalization: standard_normalization(),
            residual: false,
            derivative_order: 0,
            derivative_padding: DERIVATIVE_PADDING.into(),
            fps: 25.0,
            skeleton: H36M_SKELETON.into(),
            rig_bvh: None,
            mm_per_unit: None,
            prior_radius: None,
            actions: Vec::new(),
            seed_frames: 50,
            horizon: 100,
        }
    }

    /// The H3.6M action labels in one-hot order (the multi-action models' `actions`).
    pub fn h36m_actions() -> Vec<String> {
        H36M_ACTIONS.iter().map(|a| a.to_string()).collect()
    }

    /// The configuration of `architecture`'s paper ([`ArchFields::paper`]).
    ///
    /// [`ArchFields::paper`]: super::arch::ArchFields::paper
    pub fn paper(architecture: Architecture) -> Self {
        architecture.paper_config()
    }

    /// Every tensor name and shape this configuration implies (schema order: norm, network,
    /// decoder).
    pub fn tensor_shapes(&self) -> Vec<(String, Vec<usize>)> {
        let f = self.frame_dims;
        let mut shapes = vec![
            ("norm.mean".to_string(), vec![f]),
            ("norm.std".to_string(), vec![f]),
        ];
        self.arch.tensor_shapes(self, &mut shapes);
        shapes.push((
            "decoder.weight".into(),
            vec![self.output_dims(), self.hidden],
        ));
        shapes.push(("decoder.bias".into(), vec![self.output_dims()]));
        shapes
    }

    /// Which architecture (the `architecture` key).
    pub fn architecture(&self) -> Architecture {
        self.arch.architecture()
    }

    /// The index of an action label in one-hot order.
    pub fn action_index(&self, label: &str) -> Option<usize> {
        self.actions.iter().position(|a| a == label)
    }
}

fn standard_normalization() -> String {
    "standard".into()
}

/// The `provenance` JSON object (data, iterations, date, command, best_validation, seed), kept as
/// JSON so fields the engine does not interpret survive untouched.
pub type Provenance = serde_json::Map<String, serde_json::Value>;

/// Parses the `provenance` metadata value of `path` (must be a JSON object).
pub fn parse_provenance(json: &str, path: &Path) -> Result<Provenance, WeightsError> {
    serde_json::from_str::<Provenance>(json).map_err(|e| WeightsError::BadConfig {
        path: path.to_path_buf(),
        key: "provenance".into(),
        problem: e.to_string(),
    })
}

/// Checks the schema's `format` and `format_version` metadata of a motion-weights file (any
/// architecture, predictor or classifier).
pub fn check_format(store: &WeightStore) -> Result<(), WeightsError> {
    let path = store.path().to_path_buf();
    let format = store.require_metadata("format")?;
    if format != FORMAT_NAME {
        return Err(WeightsError::UnknownFormat {
            path,
            found: format.to_string(),
        });
    }
    let version = store.require_metadata("format_version")?;
    if version.trim() != FORMAT_VERSION.to_string() {
        return Err(WeightsError::UnsupportedVersion {
            path,
            found: version.to_string(),
            supported: FORMAT_VERSION,
        });
    }
    Ok(())
}

/// The `architecture` field of a `config` metadata value, read without validating the rest (to
/// tell predictor files from classifier files before parsing them).
pub fn architecture_name(store: &WeightStore) -> Result<String, WeightsError> {
    let json = store.require_metadata("config")?;
    let value: serde_json::Value =
        serde_json::from_str(json).map_err(|e| WeightsError::BadConfig {
            path: store.path().to_path_buf(),
            key: "config".into(),
            problem: e.to_string(),
        })?;
    value
        .get("architecture")
        .and_then(|a| a.as_str())
        .map(str::to_string)
        .ok_or_else(|| WeightsError::BadConfig {
            path: store.path().to_path_buf(),
            key: "config".into(),
            problem: "no `architecture` string".into(),
        })
}

/// Checks `dims_used` against `frame_dims`: not empty, every index inside the frame, no repeats.
pub fn validate_dims_used(dims_used: &[usize], frame_dims: usize) -> Result<(), String> {
    if dims_used.is_empty() {
        return Err("dims_used is empty".into());
    }
    if let Some(&d) = dims_used.iter().find(|&&d| d >= frame_dims) {
        return Err(format!(
            "dims_used holds {d}, beyond frame_dims {frame_dims}"
        ));
    }
    let mut sorted = dims_used.to_vec();
    sorted.sort_unstable();
    if sorted.windows(2).any(|w| w[0] == w[1]) {
        return Err("dims_used holds a repeated index".into());
    }
    Ok(())
}

/// Checks the derivative features' order (0..=3) and padding (only `repeat-first` is defined).
pub fn validate_derivatives(order: usize, padding: &str) -> Result<(), String> {
    if order > 3 {
        return Err(format!("derivative_order {order} (expected 0..=3)"));
    }
    if padding != DERIVATIVE_PADDING {
        return Err(format!(
            "derivative_padding `{padding}` (only `{DERIVATIVE_PADDING}` is defined)"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{IntentionFields, VgruDFields};

    fn vgru() -> ModelConfig {
        ModelConfig {
            arch: ArchConfig::VgruD(VgruDFields { plan_hidden: 4 }),
            frame_dims: 99,
            dims_used: (6..99).collect(),
            hidden: 8,
            layers: 1,
            gru_convention: serde_json::from_str("\"pytorch\"").unwrap(),
            normalization: "standard".into(),
            residual: true,
            derivative_order: 3,
            derivative_padding: DERIVATIVE_PADDING.into(),
            fps: 25.0,
            skeleton: "h36m-32".into(),
            rig_bvh: None,
            mm_per_unit: None,
            prior_radius: None,
            actions: vec!["walking".into()],
            seed_frames: 50,
            horizon: 100,
        }
    }

    #[test]
    fn unknown_skeletons_and_rigs_that_do_not_fit_are_refused() {
        let mut c = vgru();
        c.skeleton = "cmu".into();
        assert!(c
            .validate()
            .unwrap_err()
            .contains("unknown skeleton \"cmu\""));
        c.skeleton = RIG_SKELETON.into();
        assert!(c.validate().unwrap_err().contains("without rig_bvh"));
        let rig = "HIERARCHY\nROOT hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n JOINT knee\n {\n  OFFSET 0 -40 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n  End Site\n  {\n   OFFSET 0 -40 0\n  }\n }\n}\nMOTION\nFrames: 1\nFrame Time: 0.04\n0 0 0 0 0 0 0 0 0\n";
        c.rig_bvh = Some(rig.into());
        c.mm_per_unit = Some(10.0);
        assert!(c
            .validate()
            .unwrap_err()
            .contains("frame_dims 99 is not the rig skeleton's 12"));
        c.frame_dims = 12;
        c.dims_used = (0..12).collect();
        assert_eq!(c.validate(), Ok(()));
        assert_eq!(c.skeleton().unwrap().joint(1).offset, [0.0, -400.0, 0.0]);
        assert_eq!(c.root_step(), 1);
        c.mm_per_unit = Some(f64::NAN);
        assert!(c.validate().unwrap_err().contains("mm_per_unit"));
        c.rig_bvh = Some("HIERARCHY\nROOT".into());
        c.mm_per_unit = None;
        assert!(c.validate().unwrap_err().contains("rig_bvh"));
        assert_eq!(vgru().root_step(), 2);
    }

    #[test]
    fn sizes_beyond_the_limits_are_refused_by_validate() {
        assert_eq!(vgru().validate(), Ok(()));
        type Break = fn(&mut ModelConfig);
        let cases: [(&str, Break); 9] = [
            ("(seed_frames + horizon)", |c| {
                c.horizon = 90_000;
                c.frame_dims = 60_000;
            }),
            ("horizon", |c| c.horizon = 1 << 62),
            ("seed_frames", |c| c.seed_frames = usize::MAX),
            ("fps", |c| c.fps = 1e9),
            ("fps", |c| c.fps = 0.5),
            ("hidden", |c| c.hidden = usize::MAX / 2),
            ("plan_hidden", |c| {
                c.arch = ArchConfig::VgruD(VgruDFields {
                    plan_hidden: 1 << 40,
                })
            }),
            ("frame_dims", |c| c.frame_dims = 1 << 62),
            ("layers", |c| c.layers = 1000),
        ];
        for (field, break_it) in cases {
            let mut c = vgru();
            break_it(&mut c);
            let e = c.validate().unwrap_err();
            assert!(e.starts_with(field), "{field}: {e}");
        }
    }

    #[test]
    fn intention_fields_are_checked() {
        let good = ModelConfig::paper(Architecture::Intention);
        assert_eq!(good.validate(), Ok(()));
        let json = serde_json::to_string(&good).unwrap();
        assert!(json.contains(r#""architecture":"intention""#), "{json}");
        assert!(json.contains(r#""lookahead":10"#), "{json}");
        assert_eq!(ModelConfig::from_json(&json, Path::new("x")).unwrap(), good);
        // Other architectures do not write the fields.
        let vgru_json = serde_json::to_string(&vgru()).unwrap();
        assert!(!vgru_json.contains("noise_dims"), "{vgru_json}");
        // Missing fields are refused by the parser, naming them.
        let mut missing: serde_json::Value = serde_json::from_str(&json).unwrap();
        missing.as_object_mut().unwrap().remove("noise_dims");
        let e = ModelConfig::from_json(&missing.to_string(), Path::new("x")).unwrap_err();
        assert!(e.to_string().contains("noise_dims"), "{e}");
        type Break = fn(&mut ModelConfig);
        fn fields(c: &mut ModelConfig) -> &mut IntentionFields {
            match &mut c.arch {
                ArchConfig::Intention(f) => f,
                _ => unreachable!(),
            }
        }
        let cases: [(&str, Break); 13] = [
            ("0 < noise_dims < hidden", |c| fields(c).noise_dims = 0),
            ("0 < noise_dims < hidden", |c| fields(c).noise_dims = 256),
            ("intention needs lookahead >= 1", |c| {
                fields(c).lookahead = 0
            }),
            ("intention needs intentions >= 1", |c| {
                fields(c).intentions = 0
            }),
            ("intention needs clusters >= 1", |c| fields(c).clusters = 0),
            ("intention needs label_hidden", |c| {
                fields(c).label_hidden = 0
            }),
            ("intention with 0 GRU layers", |c| c.layers = 0),
            ("intention is residual", |c| c.residual = false),
            ("intention reads plain poses", |c| c.derivative_order = 1),
            ("intention's GRUs use the pytorch", |c| {
                c.gru_convention = GruConvention::Paper
            }),
            ("lookahead 20000 is over", |c| fields(c).lookahead = 20_000),
            ("intentions 20000 is over", |c| {
                fields(c).intentions = 20_000
            }),
            ("lookahead * intentions", |c| {
                let f = fields(c);
                (f.lookahead, f.intentions) = (5_000, 5_000)
            }),
        ];
        for (needle, break_it) in cases {
            let mut c = good.clone();
            break_it(&mut c);
            let e = c.validate().unwrap_err();
            assert!(e.contains(needle), "{needle}: {e}");
        }
    }

    #[test]
    fn zero_seed_frames_and_repeated_or_empty_labels_are_refused() {
        let good = ModelConfig::paper(Architecture::VgruD);
        assert!(good.validate().is_ok());
        let mut c = good.clone();
        c.seed_frames = 0;
        assert!(c.validate().unwrap_err().contains("seed_frames is 0"));
        let mut c = good.clone();
        c.actions[1] = c.actions[0].clone();
        assert!(c.validate().unwrap_err().contains("appears twice"));
        let mut c = good;
        c.actions[2] = " ".into();
        assert!(c.validate().unwrap_err().contains("empty"));
    }
}
