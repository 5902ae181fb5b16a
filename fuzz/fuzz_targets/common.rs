//! What the weights targets do with a model that loaded: start a generator on a short seed of
//! zeros and take a few closed-loop steps (buffers sized from the config, every kernel once).
#![allow(dead_code)]
use std::sync::Arc;

use motion_core::model::{Generator, MotionModel, Noise};

pub fn exercise(model: MotionModel) {
    let config = model.config().clone();
    let seed = ndarray::Array2::<f32>::zeros((config.seed_frames.clamp(1, 8), config.frame_dims));
    let mut generator = Generator::new(Arc::new(model));
    let action = config.actions.first().map(String::as_str);
    if generator.start(seed.view(), action, Noise::Seed(1)).is_ok() {
        for _ in 0..3 {
            if generator.step().is_err() {
                break;
            }
        }
        if let Some(last) = config.actions.last() {
            let _ = generator.set_action(last, 2);
            let _ = generator.step();
        }
    }
}
