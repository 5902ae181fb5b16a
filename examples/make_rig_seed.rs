//! Writes `examples/cmu_rig_walk.bvh`: the procedural walk of `examples/walk_seed.bvh` retargeted
//! onto a CMU-style rig ([`motion_core::retarget::demo_rig`]: the CMU mocap BVH conversions' bone
//! names and hierarchy without fingers, a T-pose, ZYX channels, about 25 units tall) at 120 fps —
//! a seed on a foreign skeleton, made by this project's own code, for
//! `motion-cli predict --seed examples/cmu_rig_walk.bvh --out pred.bvh`.
//!
//! ```text
//! cargo run --example make_rig_seed            # writes examples/cmu_rig_walk.bvh
//! cargo run --example make_rig_seed -- out.bvh # or anywhere else
//! cargo run --example make_rig_seed -- out.bvh --mixamo  # a Mixamo-style rig (demo_mixamo_rig), 30 fps
//! ```
use std::path::PathBuf;

use motion_core::formats::bvh::{read_bvh, write_bvh};
use motion_core::resample::resample_bvh;
use motion_core::retarget::{demo_mixamo_rig, demo_rig, JointMap, Retargeter};
use ndarray::Array2;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples");
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mixamo = args.iter().any(|a| a == "--mixamo");
    let out = args
        .iter()
        .find(|a| !a.starts_with("--"))
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("cmu_rig_walk.bvh"));
    let walk = read_bvh(root.join("walk_seed.bvh"))?;
    let (rig, fps) = if mixamo {
        (demo_mixamo_rig(), 30.0)
    } else {
        (demo_rig("", false, 1.0 / 70.0), 120.0)
    };
    let retargeter = Retargeter::new(&rig, JointMap::detect(&rig)?)?;
    // No rig-only joint moves: references of zeros (the rig's rest for its extra bones).
    let rest = Array2::zeros((1, rig.channel_count()));
    let on_rig = retargeter.to_rig(&walk, rest.view());
    write_bvh(&out, &resample_bvh(&on_rig, fps)?)?;
    println!("wrote {}", out.display());
    Ok(())
}
