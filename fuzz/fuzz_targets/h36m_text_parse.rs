//! Fuzz target: the exp-map text parser, and for 99/117-column input the exp-map -> BVH -> exp-map
//! conversion through BVH text. Any panic or hang is a bug.
#![no_main]

use std::path::Path;
use std::sync::Arc;

use libfuzzer_sys::fuzz_target;
use motion_core::formats::bvh::{parse_bvh, to_bvh_string};
use motion_core::formats::expmap_bvh::{bvh_to_expmap, expmap_to_bvh, ExpMapTarget};
use motion_core::formats::h36m_text::parse_expmap_text;
use motion_core::motion::{Motion, MotionLayout, RootEncoding};
use motion_core::skeleton::Skeleton;

fuzz_target!(|data: &[u8]| {
    let Ok(frames) = parse_expmap_text(data, Path::new("fuzz.txt")) else {
        return;
    };
    let (skeleton, root, target) = match frames.ncols() {
        99 => (Skeleton::h36m(), RootEncoding::Deltas, ExpMapTarget::H36m),
        117 => (Skeleton::cmu(), RootEncoding::Absolute, ExpMapTarget::Cmu),
        _ => return,
    };
    let motion = Motion::new(
        Arc::new(skeleton),
        MotionLayout::ExpMap { root },
        frames,
        50.0,
    )
    .expect("width checked");
    let _ = motion.positions();
    let Ok(bvh) = expmap_to_bvh(&motion) else {
        return;
    };
    // Huge exp-map values can make rotations NaN, which the writer refuses.
    let Ok(text) = to_bvh_string(&bvh) else {
        return;
    };
    let read = parse_bvh(&text, "converted.bvh").expect("a written BVH parses");
    assert_eq!(read, bvh);
    assert_eq!(ExpMapTarget::detect(&read).ok(), Some(target));
    let _ = bvh_to_expmap(&read, target);
});
