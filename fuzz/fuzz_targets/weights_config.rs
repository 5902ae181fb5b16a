//! Structure-aware: a valid weights file (one of the parity fixtures, chosen by the first byte)
//! whose `config` metadata is replaced by the rest of the input, so that mutations reach the
//! config's fields (byte mutation of a whole file breaks its length-prefixed header first). Then
//! load and a few generator steps.
#![no_main]
use std::collections::HashMap;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use motion_core::model::weights::WeightStore;
use motion_core::model::MotionModel;
use safetensors::tensor::{Dtype, SafeTensors, TensorView};

#[path = "common.rs"]
mod common;

const FIXTURES: [&[u8]; 4] = [
    include_bytes!("../../tests/fixtures/parity/vgru_d.safetensors"),
    include_bytes!("../../tests/fixtures/parity/gru_d.safetensors"),
    include_bytes!("../../tests/fixtures/parity/dae_lstm.safetensors"),
    include_bytes!("../../tests/fixtures/parity/vgru_d_f16.safetensors"),
];

struct Fixture {
    tensors: Vec<(String, Dtype, Vec<usize>, Vec<u8>)>,
    metadata: HashMap<String, String>,
}

fn fixtures() -> &'static [Fixture] {
    static PARSED: OnceLock<Vec<Fixture>> = OnceLock::new();
    PARSED.get_or_init(|| {
        FIXTURES
            .iter()
            .map(|bytes| {
                let (_, header) = SafeTensors::read_metadata(bytes).expect("fixture header");
                let st = SafeTensors::deserialize(bytes).expect("fixture");
                Fixture {
                    tensors: st
                        .tensors()
                        .into_iter()
                        .map(|(name, t)| (name, t.dtype(), t.shape().to_vec(), t.data().to_vec()))
                        .collect(),
                    metadata: header.metadata().clone().unwrap_or_default(),
                }
            })
            .collect()
    })
}

fuzz_target!(|data: &[u8]| {
    let Some((&pick, config)) = data.split_first() else {
        return;
    };
    let fixture = &fixtures()[pick as usize % FIXTURES.len()];
    let mut metadata = fixture.metadata.clone();
    metadata.insert("config".into(), String::from_utf8_lossy(config).into_owned());
    let views: Vec<(String, TensorView<'_>)> = fixture
        .tensors
        .iter()
        .map(|(name, dtype, shape, bytes)| {
            (name.clone(), TensorView::new(*dtype, shape.clone(), bytes).expect("fixture tensor"))
        })
        .collect();
    let bytes = safetensors::serialize(views, Some(metadata)).expect("re-serialize");
    let Ok(store) = WeightStore::from_bytes(&bytes, "fuzz.safetensors") else {
        return;
    };
    if let Ok(model) = MotionModel::from_store(&store) {
        common::exercise(model);
    }
});
