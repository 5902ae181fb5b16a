//! One engine character, as `motion_core::model::Character` is: a learned model or a
//! motion-matching database, seeded from a file, steered by goals, advanced at any rate.
use std::path::PathBuf;

use motion_core::formats::bvh::read_bvh;
use motion_core::formats::expmap_bvh::ExpMapTarget;
use motion_core::grounding::GroundingConfig;
use motion_core::model::builtin::BuiltIn;
use motion_core::model::{Character as CoreCharacter, MotionSource, Noise};
use motion_core::seed::load_seed;
use motion_core::steering::{Goal, Vec2};
use motion_core::takes::seed_poses_on_rig;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;

use crate::errors::{format, seed as seed_error, value, weights};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Character>()?;
    m.add_class::<Rig>()
}

/// A character's own skeleton (`motion_core::rig_target`): joint names, parents (-1 for the
/// root; parents first) and rest local rotations (`n x 4`, `x, y, z, w`) and translations (`n x
/// 3`, metres), +y up, right-handed, facing +z, mapped from `character`'s skeleton by the built-in
/// maps or `joint_map` (JSON text). `pose(character)` gives the local rotation to write into each
/// joint for the character's current pose and the hips' translation in the hips' parent space.
/// `Rig.from_gltf(path, character)` reads a `.glb`/`.gltf` skin.
#[pyclass(module = "motion._motion")]
pub struct Rig {
    target: motion_core::rig_target::RigTarget,
    out: motion_core::rig_target::RigPose,
}

#[pymethods]
impl Rig {
    #[new]
    #[pyo3(signature = (names, parents, rest_rotations, rest_translations, character, joint_map = None))]
    fn new(
        names: Vec<String>,
        parents: Vec<i64>,
        rest_rotations: &Bound<'_, PyAny>,
        rest_translations: &Bound<'_, PyAny>,
        character: &Character,
        joint_map: Option<&str>,
    ) -> PyResult<Rig> {
        use motion_core::rig_target::{RigJoint, RigTarget};
        let rot = crate::arrays::f64_array(rest_rotations, "rest_rotations")?;
        let tr = crate::arrays::f64_array(rest_translations, "rest_translations")?;
        let (rot, tr) = (rot.as_array(), tr.as_array());
        let n = names.len();
        if rot.shape() != [n, 4] || tr.shape() != [n, 3] {
            return Err(value(format!(
                "{n} names need rest_rotations {n} x 4 and rest_translations {n} x 3; got {:?} and {:?}",
                rot.shape(),
                tr.shape()
            )));
        }
        let flat =
            |a: ndarray::ArrayViewD<'_, f64>| a.iter().map(|&v| v as f32).collect::<Vec<f32>>();
        let joints =
            RigJoint::from_arrays(names, &parents, &flat(rot), &flat(tr)).map_err(value)?;
        let target =
            RigTarget::from_joints(joints, joint_map, character.inner.skeleton()).map_err(value)?;
        let out = motion_core::rig_target::RigPose::for_target(&target);
        Ok(Rig { target, out })
    }

    /// A rig from the largest skin of a glTF/GLB file, mapped from `character`'s skeleton.
    #[staticmethod]
    #[pyo3(signature = (path, character, joint_map = None))]
    fn from_gltf(path: PathBuf, character: &Character, joint_map: Option<&str>) -> PyResult<Rig> {
        let target = motion_core::rig_target::RigTarget::from_gltf(
            &path,
            joint_map,
            character.inner.skeleton(),
        )
        .map_err(value)?;
        let out = motion_core::rig_target::RigPose::for_target(&target);
        Ok(Rig { target, out })
    }

    /// The joint names, in the rig's order.
    fn joint_names(&self) -> Vec<String> {
        self.target
            .joints()
            .iter()
            .map(|j| j.name.clone())
            .collect()
    }

    /// The hips joint's index.
    fn hips(&self) -> usize {
        self.target.hips()
    }

    /// `(rotations, hips_translation)` for `character`'s current pose: every joint's local
    /// rotation (`n x 4`, `x, y, z, w`) and the hips' local translation (3 floats, metres).
    #[allow(clippy::type_complexity)]
    fn pose<'py>(
        &mut self,
        py: Python<'py>,
        character: &Character,
    ) -> PyResult<(Bound<'py, PyArray2<f32>>, Bound<'py, PyArray1<f32>>)> {
        let pose = character.inner.current();
        if pose.local_rotations.len() != self.target.source_skeleton().len() {
            return Err(value(
                "the character's poses are not on the skeleton this rig was made for",
            ));
        }
        self.target.write(pose, &mut self.out);
        let n = self.out.local_rotations.len();
        let flat: Vec<f32> = self
            .out
            .local_rotations
            .iter()
            .flat_map(|q| q.to_array())
            .collect();
        let rotations = ndarray::Array2::from_shape_vec((n, 4), flat)
            .map_err(value)?
            .into_pyarray(py);
        let hips = self
            .out
            .hips_translation
            .to_array()
            .to_vec()
            .into_pyarray(py);
        Ok((rotations, hips))
    }
}

/// One character: `start(seed)`, then `advance(dt)` at the engine's rate for the root's world
/// position (metres) and every joint's local rotation (`x, y, z, w`; joint 0 the root's world
/// rotation), steered by `set_goal`.
#[pyclass(module = "motion._motion")]
pub struct Character {
    inner: CoreCharacter,
    source: MotionSource,
    /// The pelvis heading of the last pose (what a stop without a facing keeps).
    heading: f32,
}

#[pymethods]
impl Character {
    /// A character driven by `weights` (a learned model or a motion-matching database file, e.g.
    /// `weights/matching_cmu.safetensors`; `None`: the built-in game default), grounded unless
    /// `grounding=False`.
    #[new]
    #[pyo3(signature = (weights = None, grounding = true))]
    fn new(py: Python<'_>, weights: Option<PathBuf>, grounding: bool) -> PyResult<Character> {
        let source = match weights {
            Some(path) => py
                .detach(|| MotionSource::load(&path))
                .map_err(|e| value(format!("{e}")))?,
            None => match BuiltIn::Game.model() {
                Some(Ok(model)) => MotionSource::from(std::sync::Arc::new(model)),
                Some(Err(e)) => return Err(self::weights(e)),
                None => return Err(value("this build has no built-in weights")),
            },
        };
        let config = if grounding {
            GroundingConfig::default()
        } else {
            GroundingConfig::off()
        };
        let inner = CoreCharacter::with_grounding(source.clone(), config).map_err(value)?;
        Ok(Character {
            inner,
            source,
            heading: 0.0,
        })
    }

    /// Whether a motion-matching database drives it (it plays on the database's rig and has no
    /// actions).
    #[getter]
    fn is_database(&self) -> bool {
        self.inner.is_database()
    }

    /// The joint names of the poses, in order.
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        let skeleton = self.inner.skeleton();
        (0..skeleton.len())
            .map(|j| skeleton.joint(j).name.clone())
            .collect()
    }

    /// The source's frame rate (frames per second; `advance` takes any `dt`).
    #[getter]
    fn fps(&self) -> f64 {
        self.source.fps()
    }

    /// The seed's floor the poses stand on, once fitted (after `start` and the first `advance`):
    /// `{"level": (x, y, z, w), "pivot": (x, y, z), "tilt_degrees": t}`, or `None`. Poses come
    /// out in the floor frame; a position `p` of a pose is `inverse(level) * (p - (pivot.x, 0,
    /// pivot.z)) + pivot` in the world the seed was given in.
    #[getter]
    fn floor<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, pyo3::types::PyDict>>> {
        let Some(f) = self.inner.grounder().fitted_floor() else {
            return Ok(None);
        };
        let d = pyo3::types::PyDict::new(py);
        d.set_item("level", f.level.to_array())?;
        d.set_item("pivot", f.pivot.to_array())?;
        d.set_item("tilt_degrees", f.tilt_degrees())?;
        Ok(Some(d))
    }

    /// Seeds it from a file: a BVH on any rig the built-in maps fit (or exp-map text / `.npy`
    /// for a learned model), doing `action` (learned models with actions), drawing noise from
    /// `rng_seed`. A database continues the take in its coordinates.
    #[pyo3(signature = (seed, action = None, rng_seed = 0))]
    fn start(
        &mut self,
        py: Python<'_>,
        seed: PathBuf,
        action: Option<&str>,
        rng_seed: u64,
    ) -> PyResult<()> {
        match &self.source {
            MotionSource::Model(model) if !self.source.plays_on_rig() => {
                let fps = model.config().fps;
                let loaded = py
                    .detach(|| load_seed(&seed, ExpMapTarget::H36m, fps, 50.0, None))
                    .map_err(seed_error)?;
                self.inner
                    .start_from_clip(loaded.frames.view(), action, Noise::Seed(rng_seed))
                    .map_err(|e| value(format!("{}: {e}", seed.display())))?;
            }
            source => {
                let source = source.clone();
                let poses = py.detach(|| {
                    let bvh = read_bvh(&seed).map_err(format)?;
                    seed_poses_on_rig(
                        bvh,
                        &source.skeleton(),
                        source.rig_mm_per_unit(),
                        source.fps(),
                        None,
                    )
                    .map_err(|e| value(format!("{}: {e}", seed.display())))
                })?;
                let action = if source.database().is_some() {
                    None
                } else {
                    action
                };
                self.inner
                    .start_poses_with(&poses, action, Noise::Seed(rng_seed))
                    .map_err(value)?;
            }
        }
        Ok(())
    }

    /// Steers toward `velocity` (`(x, z)` on the floor, m/s) facing `facing` (yaw about +y,
    /// radians: 0 faces +z; default: where the velocity goes, or, standing, the way it faces),
    /// from the next frame on.
    #[pyo3(signature = (velocity, facing = None))]
    fn set_goal(&mut self, velocity: (f32, f32), facing: Option<f32>) -> PyResult<()> {
        let v = Vec2::new(velocity.0, velocity.1);
        if !(v.is_finite() && facing.is_none_or(f32::is_finite)) {
            return Err(value("a goal's velocity and facing must be finite"));
        }
        let mut goal = Goal::towards(v, facing.unwrap_or(self.heading));
        if let Some(facing) = facing {
            goal.facing = facing;
        }
        self.inner.set_goal(Some(goal));
        Ok(())
    }

    /// Lets the source go where it goes (no goal).
    fn clear_goal(&mut self) {
        self.inner.set_goal(None);
    }

    /// Switches the action without re-seeding (ignored by a database).
    #[pyo3(signature = (action, crossfade = 0))]
    fn set_action(&mut self, action: &str, crossfade: usize) -> PyResult<()> {
        self.inner.set_action(action, crossfade).map_err(value)
    }

    /// Moves the clock by `dt` seconds: `(root_position, rotations)`, the root's world position
    /// (3 floats, metres) and every joint's local rotation (`joints x 4`, `x, y, z, w`).
    #[allow(clippy::type_complexity)]
    fn advance<'py>(
        &mut self,
        py: Python<'py>,
        dt: f64,
    ) -> PyResult<(Bound<'py, PyArray1<f32>>, Bound<'py, PyArray2<f32>>)> {
        if !(dt.is_finite() && dt >= 0.0) {
            return Err(value(format!("dt {dt}: give a finite time step >= 0")));
        }
        let pose = self.inner.advance(dt).map_err(value)?.clone();
        self.heading = self.inner.heading_of(&pose);
        let root = pose.root_translation.to_array().to_vec().into_pyarray(py);
        let joints = pose.local_rotations.len();
        let flat: Vec<f32> = pose
            .local_rotations
            .iter()
            .flat_map(|q| q.to_array())
            .collect();
        let rotations = ndarray::Array2::from_shape_vec((joints, 4), flat)
            .map_err(value)?
            .into_pyarray(py);
        Ok((root, rotations))
    }
}
