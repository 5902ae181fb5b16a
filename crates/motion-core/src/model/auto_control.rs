//! The control a model that reads one (`goal-gru`, [`super::goal_gru`]) gets when nobody steers
//! it: what its seed's root did over its last second (speed along and across the heading, turn;
//! a [`GoalControl`] without a goal), held from then on with the speed feedback of a goal's
//! control ([`GoalControl::holding`]: the model lags its control, so its own last second fed
//! back would slow it down to a stand). So a `goal-gru` model left alone keeps walking as its
//! seed walked, in every front end that drives a [`BatchGenerator`](super::BatchGenerator)
//! (`predict`, `eval`, Python, the C ABI); a row given a control of its own
//! ([`BatchGenerator::set_control`](super::BatchGenerator::set_control)) keeps that one.
//!
//! [`GoalControl`]: crate::steering::GoalControl
//! [`GoalControl::holding`]: crate::steering::GoalControl::holding
use std::sync::Arc;

use super::goal_gru::steerable_control_frames;
use super::predictor::MotionModel;
use crate::motion::{FrameScalar, RootEncoding};
use crate::pose::PoseDecoder;
use crate::steering::Steering;

/// One row's decoder and control.
#[derive(Debug)]
struct Row {
    decoder: PoseDecoder,
    steering: Steering,
    /// Given a control of its own: not driven from here.
    manual: bool,
    /// The seed's control, held.
    held: [f32; 3],
}

/// The automatic controls of a batch (see the module docs). No allocation per frame.
#[derive(Debug)]
pub(crate) struct AutoControl {
    rows: Vec<Row>,
}

impl AutoControl {
    /// Controls for `batch` rows of `model`, or `None` when it reads no control this crate can
    /// make (3 values, [`steerable_control_frames`]) or its skeleton has no legs to face by.
    pub(crate) fn for_model(model: &MotionModel, batch: usize) -> Option<AutoControl> {
        let config = model.config();
        let control_frames = steerable_control_frames(config)?;
        let skeleton = Arc::clone(model.skeleton());
        let step = config.root_step();
        let frame_time = (1.0 / config.fps) as f32;
        let rows = (0..batch)
            .map(|_| {
                let mut steering = Steering::new(&skeleton, frame_time).ok()?;
                steering.use_control(control_frames);
                Some(Row {
                    decoder: PoseDecoder::new(Arc::clone(&skeleton), RootEncoding::Deltas, step),
                    steering,
                    manual: false,
                    held: [0.0; 3],
                })
            })
            .collect::<Option<Vec<_>>>()?;
        Some(AutoControl { rows })
    }

    /// Row `row` has a control of its own from now on.
    pub(crate) fn set_manual(&mut self, row: usize) {
        if let Some(r) = self.rows.get_mut(row) {
            r.manual = true;
        }
    }

    /// Starts row `row` over: forgets its motion; `None` when it is manual.
    pub(crate) fn begin(&mut self, row: usize) -> Option<()> {
        let r = self.rows.get_mut(row).filter(|r| !r.manual)?;
        r.decoder.reset();
        r.steering.clear_seed();
        Some(())
    }

    /// A seed frame of row `row` (after [`begin`](Self::begin)).
    pub(crate) fn observe_seed<T: FrameScalar>(&mut self, row: usize, frame: &[T]) {
        if let Some(r) = self.rows.get_mut(row).filter(|r| !r.manual) {
            let pose = r.decoder.push(frame);
            r.steering.observe_seed(pose);
        }
    }

    /// A frame row `row` made (handed out): recorded; returns the control of its next step,
    /// `None` when it is manual.
    pub(crate) fn frame(&mut self, row: usize, frame: &[f32]) -> Option<[f32; 3]> {
        let r = self.rows.get_mut(row).filter(|r| !r.manual)?;
        let pose = r.decoder.push(frame);
        r.steering.steer(pose);
        r.steering.holding(r.held)
    }

    /// Row `row`'s first control, after its seed (`None` when manual): the seed's last second,
    /// held from now on.
    pub(crate) fn seed_control(&mut self, row: usize) -> Option<[f32; 3]> {
        let r = self.rows.get_mut(row).filter(|r| !r.manual)?;
        r.held = r.steering.control_vector()?;
        Some(r.held)
    }
}
