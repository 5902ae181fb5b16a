//! Arbitrary text as a joint-map JSON (`--joint-map FILE`) for each built-in demo rig (CMU-style,
//! Mixamo, Unreal; y- and z-up, several units), then the retargeter it builds on two frames.
#![no_main]
use libfuzzer_sys::fuzz_target;
use motion_core::retarget::{demo_rig, JointMap, Retargeter};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    for (prefix, z_up, units) in [("", false, 0.1), ("mixamorig:", false, 1.0), ("", true, 0.0254)] {
        let rig = demo_rig(prefix, z_up, units);
        let Ok(map) = JointMap::from_json(&rig, text) else {
            continue;
        };
        let Ok(retargeter) = Retargeter::new(&rig, map) else {
            continue;
        };
        let frames = ndarray::Array2::<f64>::zeros((2, rig.channel_count()));
        let model = retargeter.to_model(frames.view(), 1.0 / 30.0);
        let _ = retargeter.to_rig(&model, frames.view());
    }
});
