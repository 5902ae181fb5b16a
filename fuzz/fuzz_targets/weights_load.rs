//! Arbitrary bytes as a motion-weights `.safetensors` file (the file a game loads from a mod
//! folder): header, metadata, config, tensor names, dtypes and shapes, then a few generator steps
//! (and the action classifier's loader on the same bytes).
#![no_main]
use libfuzzer_sys::fuzz_target;
use motion_core::model::weights::WeightStore;
use motion_core::model::{ActionClassifier, MotionModel};

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    let Ok(store) = WeightStore::from_bytes(data, "fuzz.safetensors") else {
        return;
    };
    if let Ok(model) = MotionModel::from_store(&store) {
        common::exercise(model);
    }
    let _ = ActionClassifier::from_store(&store);
});
