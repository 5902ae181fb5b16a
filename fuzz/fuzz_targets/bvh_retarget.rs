//! Arbitrary bytes as a BVH seed, through the one seed loader: units check and rescaling, a
//! foreign rig detected and retargeted onto the H3.6M skeleton, resampling to the model's rate,
//! exp-map conversion.
#![no_main]
use std::path::Path;

use libfuzzer_sys::fuzz_target;
use motion_core::formats::bvh::parse_bvh;
use motion_core::formats::expmap_bvh::ExpMapTarget;
use motion_core::seed::seed_from_bvh;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = Path::new("fuzz.bvh");
    let Ok(bvh) = parse_bvh(text, path) else {
        return;
    };
    if bvh.frames.nrows() > 256 {
        return;
    }
    let _ = seed_from_bvh(bvh, path, ExpMapTarget::H36m, 25.0, None);
});
