//! The motion models: load, inspect, predict samples, stream frames.
use std::path::PathBuf;
use std::sync::Arc;

use motion_core::formats::expmap_bvh::ExpMapTarget;
use motion_core::grounding::GroundingConfig;
pub use motion_core::model::builtin::BuiltIn;
use motion_core::model::samples::check_sample_size;
use motion_core::model::{generate_samples, Generator as CoreGenerator, MotionModel, Noise};
use motion_core::seed::{
    load_seed, model_window, seed_from_expmap, WrittenClip, DEFAULT_EXPMAP_FILE_FPS,
};
use ndarray::{Array2, Ix2};
use numpy::{IntoPyArray, PyArray1, PyArray3};
use pyo3::prelude::*;

use crate::arrays::{dims, f64_array};
use crate::errors::{seed as seed_error, value, weights};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Model>()?;
    m.add_class::<Generator>()?;
    Ok(())
}

/// A motion model (self-describing safetensors weights, or the built-in default).
#[pyclass(module = "motion._motion", frozen)]
pub struct Model {
    pub(crate) model: Arc<MotionModel>,
}

impl Model {
    /// A built-in model: the game default (`Model.default()`) or the forecasting default
    /// (`motion.evaluate`).
    pub(crate) fn builtin(which: BuiltIn) -> PyResult<Model> {
        match which.model() {
            Some(Ok(model)) => Ok(Model {
                model: Arc::new(model),
            }),
            Some(Err(e)) => Err(weights(e)),
            None => Err(value("this build has no built-in weights")),
        }
    }

    fn target(&self) -> PyResult<ExpMapTarget> {
        let dims = self.model.config().frame_dims;
        ExpMapTarget::for_frame_dims(dims).ok_or_else(|| {
            value(format!(
                "the model's {dims}-dim frames are on no built-in skeleton"
            ))
        })
    }
}

/// Seed frames at the model's rate from a file path or an array of exp-map frames.
fn seed_frames(
    py: Python<'_>,
    model: &Model,
    seed: &Bound<'_, PyAny>,
    input_fps: Option<f64>,
) -> PyResult<Array2<f64>> {
    let config = model.model.config();
    let target = model.target()?;
    if let Some(fps) = input_fps {
        if !(fps.is_finite() && fps > 0.0) {
            return Err(value(format!("input_fps {fps}: must be positive")));
        }
    }
    let loaded = if let Ok(path) = seed.extract::<PathBuf>() {
        // Exp-map files carry no rate: the front ends' one default unless input_fps says otherwise.
        let input = input_fps.unwrap_or(DEFAULT_EXPMAP_FILE_FPS);
        py.detach(|| load_seed(&path, target, config.fps, input, None))
    } else {
        let array = f64_array(seed, "seed")?;
        let frames = dims::<Ix2>(array.as_array(), "seed", "T x D exp-map frames")?.to_owned();
        let input = input_fps.unwrap_or(config.fps);
        py.detach(|| seed_from_expmap(frames, "seed".as_ref(), target, input, config.fps))
    };
    Ok(loaded.map_err(seed_error)?.frames)
}

#[pymethods]
impl Model {
    /// Loads a motion-weights `.safetensors` file.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Model> {
        let model = py.detach(|| MotionModel::load(&path)).map_err(weights)?;
        Ok(Model {
            model: Arc::new(model),
        })
    }

    /// The built-in default model (the shipped weights).
    #[staticmethod]
    fn default() -> PyResult<Model> {
        Model::builtin(BuiltIn::Game)
    }

    /// The configuration and provenance: `{"config": {...}, "provenance": {...}, "parameters": n}`.
    fn info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let json = serde_json::json!({
            "config": self.model.config(),
            "provenance": self.model.provenance(),
            "parameters": self.model.parameter_count(),
        });
        py.import("json")?
            .call_method1("loads", (json.to_string(),))
    }

    /// The actions the model is conditioned on (empty for unconditioned models).
    #[getter]
    fn actions(&self) -> Vec<String> {
        self.model.config().actions.clone()
    }

    /// Frames per second.
    #[getter]
    fn fps(&self) -> f64 {
        self.model.config().fps
    }

    /// Seed frames the model reads.
    #[getter]
    fn seed_frames(&self) -> usize {
        self.model.config().seed_frames
    }

    /// Values per frame.
    #[getter]
    fn frame_dims(&self) -> usize {
        self.model.config().frame_dims
    }

    /// `samples x frames x dims` predictions after `seed` (a file path: BVH, exp-map text or
    /// `.npy`; or a `T x dims` array of exp-map frames at the model's rate unless `input_fps`),
    /// whose last `seed_frames` frames the model reads. Sample `i` draws noise from
    /// `rng_seed + i`, as `motion-cli predict --samples` does. Grounded like
    /// `motion-cli predict --prediction-only` (the first frame's root absolute, on the seed's
    /// floor); `grounding=False` returns the model's raw frames.
    #[pyo3(signature = (seed, action = None, frames = 100, samples = 1, rng_seed = 0, input_fps = None, grounding = true))]
    #[allow(clippy::too_many_arguments)]
    fn predict<'py>(
        &self,
        py: Python<'py>,
        seed: &Bound<'py, PyAny>,
        action: Option<&str>,
        frames: usize,
        samples: usize,
        rng_seed: u64,
        input_fps: Option<f64>,
        grounding: bool,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        if samples == 0 {
            return Err(value("samples must be at least 1"));
        }
        check_sample_size(samples, frames, self.model.config().frame_dims).map_err(value)?;
        let all = seed_frames(py, self, seed, input_fps)?;
        let needed = self.model.config().seed_frames.max(1);
        let total = all.nrows();
        if total < needed {
            return Err(value(format!(
                "seed: {total} frames at {} Hz, the model needs at least {needed}",
                self.model.config().fps
            )));
        }
        let target = self.target()?;
        let window = model_window(&all, total - needed, total, target);
        let out = py
            .detach(|| {
                generate_samples(
                    &self.model,
                    window.view(),
                    action,
                    frames,
                    samples,
                    rng_seed,
                )
            })
            .map_err(|e| value(format!("seed: {e}")))?;
        if !grounding {
            return Ok(out.into_pyarray(py));
        }
        let rule = WrittenClip {
            target,
            fps: self.model.config().fps,
            seed: total - needed..total,
            first_written: total,
            action,
            grounding: GroundingConfig::default(),
            anchor: None,
        };
        let mut grounded = out.clone();
        for (k, sample) in out.outer_iter().enumerate() {
            let rows = rule
                .frames(all.view(), sample, true)
                .map_err(|e| value(format!("seed: {e}")))?;
            grounded.index_axis_mut(ndarray::Axis(0), k).assign(&rows);
        }
        Ok(grounded.into_pyarray(py))
    }

    /// A streaming generator on this model (`start`, then `step` per frame).
    #[pyo3(signature = (rng_seed = 0))]
    fn generator(&self, rng_seed: u64) -> Generator {
        Generator {
            inner: CoreGenerator::new(Arc::clone(&self.model)),
            rng_seed,
        }
    }

    fn __repr__(&self) -> String {
        let c = self.model.config();
        format!(
            "Model({:?}, {} fps, {} seed frames, {} actions)",
            c.architecture(),
            c.fps,
            c.seed_frames,
            c.actions.len()
        )
    }
}

/// One character generated frame by frame.
#[pyclass(module = "motion._motion")]
pub struct Generator {
    inner: CoreGenerator,
    rng_seed: u64,
}

#[pymethods]
impl Generator {
    /// Seeds it with `seed` (`S x dims` exp-map frames at the model's rate; all are read),
    /// conditioned on `action`.
    #[pyo3(signature = (seed, action = None))]
    fn start(&mut self, seed: &Bound<'_, PyAny>, action: Option<&str>) -> PyResult<()> {
        let array = f64_array(seed, "seed")?;
        let frames = dims::<Ix2>(array.as_array(), "seed", "S x D exp-map frames")?;
        self.inner
            .start(frames, action, Noise::Seed(self.rng_seed))
            .map_err(value)
    }

    /// The next frame (`dims` values, float64).
    fn step<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let frame = self.inner.step().map_err(value)?;
        Ok(frame
            .iter()
            .map(|&v| f64::from(v))
            .collect::<Vec<f64>>()
            .into_pyarray(py))
    }

    /// Switches the action from the next frame (`crossfade` frames of one-hot blend for
    /// DAE-LSTM).
    #[pyo3(signature = (action, crossfade = 0))]
    fn set_action(&mut self, action: &str, crossfade: usize) -> PyResult<()> {
        self.inner.set_action(action, crossfade).map_err(value)
    }

    /// Tells a `goal-gru` model where its root goes over the next second from the next step
    /// on (before `start`: the seed too): `[forward, side, turn]`, m/s along and across the
    /// pelvis heading and radians. Without it the model keeps doing what its last second did.
    /// ValueError for another model or a bad vector.
    fn set_control(&mut self, control: Vec<f32>) -> PyResult<()> {
        self.inner.set_control(&control).map_err(value)
    }
}
