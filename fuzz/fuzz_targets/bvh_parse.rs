//! Fuzz target: the BVH parser, and what follows a successful parse (writer round trip, channel
//! FK, BVH -> exp-map). Any panic, hang or unbounded allocation is a bug.
#![no_main]

use libfuzzer_sys::fuzz_target;
use motion_core::formats::bvh::{parse_bvh, to_bvh_string};
use motion_core::formats::expmap_bvh::{bvh_to_expmap, ExpMapTarget};
use motion_core::kinematics::channel_positions;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(bvh) = parse_bvh(text, "fuzz.bvh") else {
        return;
    };
    // Whatever parses writes and reads back identically.
    let written = to_bvh_string(&bvh).expect("a parsed BVH is writable");
    let back = parse_bvh(&written, "written.bvh").expect("a written BVH parses");
    assert_eq!(back, bvh, "write/read round trip changed the BVH");
    // FK of finite channels must not panic (it may overflow to inf/NaN).
    let fk = channel_positions(&bvh.skeleton, bvh.frames.view()).expect("widths match");
    assert_eq!(fk.dim().1, bvh.skeleton.len());
    if let Ok(target) = ExpMapTarget::detect(&bvh) {
        let _ = bvh_to_expmap(&bvh, target);
    }
});
