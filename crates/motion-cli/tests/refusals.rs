//! Requests and files that are refused up front with one `error:` line and exit 2, before memory
//! or time is spent on them: sizes over `motion_core::limits` (resampling, predictions written
//! at a high rate, files read whole, GIF pixels), joint maps that break the rig's hierarchy, and
//! `score` options that do not apply to the data.
mod common;

use common::{bad_input, fixture_model, scratch, walk_frames, walk_seed, walk_with_frames};
use motion_core::formats::npy::write_npy;
use ndarray::{Array3, Array4};

#[test]
fn resampling_past_the_clip_limit_is_refused_naming_the_limit() {
    let dir = scratch("resample-limit");
    // 14,000 frames a second apart on a 99-channel rig: 350,000 frames at 25 Hz, 34.6 M values.
    let many: Vec<String> = walk_frames().into_iter().cycle().take(14_000).collect();
    let text = walk_with_frames(&many).replace("Frame Time: 0.04", "Frame Time: 1");
    std::fs::write(dir.join("slow.bvh"), text).unwrap();
    bad_input(
        &dir,
        &[&"convert", &"slow.bvh", &"o.bvh", &"--fps", &"25"],
        &["slow.bvh", "MAX_CLIP_VALUES", "lower frame rate"],
    );
    bad_input(
        &dir,
        &[
            &"predict",
            &"--model",
            &fixture_model(),
            &"--seed",
            &"slow.bvh",
            &"--action",
            &"walking",
            &"--out",
            &"p.bvh",
        ],
        &["slow.bvh", "MAX_CLIP_VALUES"],
    );
}

#[test]
fn predictions_written_past_the_clip_limit_are_refused_before_generating() {
    let dir = scratch("predict-limit");
    let m = fixture_model();
    let seed = walk_seed();
    let base: [&dyn AsRef<std::ffi::OsStr>; 8] = [
        &"predict",
        &"--model",
        &m,
        &"--seed",
        &seed,
        &"--action",
        &"walking",
        &"--out",
    ];
    let mut high_rate = base.to_vec();
    high_rate.extend([
        &"p.bvh" as &dyn AsRef<std::ffi::OsStr>,
        &"--fps",
        &"10000",
        &"--frames",
        &"20000",
    ]);
    bad_input(
        &dir,
        &high_rate,
        &["--fps 10000", "MAX_CLIP_VALUES", "--frames"],
    );
    let mut long = base.to_vec();
    long.extend([
        &"p.bvh" as &dyn AsRef<std::ffi::OsStr>,
        &"--frames",
        &"1350000",
    ]);
    bad_input(&dir, &long, &["--frames 1350000", "MAX_SAMPLE_VALUES"]);
}

#[test]
fn files_over_the_read_limit_are_refused_before_reading() {
    let dir = scratch("read-limit");
    // A sparse 300 MiB file: refused from its size, nothing is read.
    let big = std::fs::File::create(dir.join("big.npy")).unwrap();
    big.set_len(300 << 20).unwrap();
    drop(big);
    bad_input(
        &dir,
        &[&"convert", &"big.npy", &"o.bvh"],
        &["big.npy", "256 MiB", "MAX_INPUT_BYTES"],
    );
    std::fs::rename(dir.join("big.npy"), dir.join("big.bvh")).unwrap();
    bad_input(
        &dir,
        &[&"render", &"big.bvh", &"--out", &"o.gif"],
        &["big.bvh", "MAX_INPUT_BYTES"],
    );
}

#[test]
fn gifs_over_the_pixel_limit_are_refused_before_drawing() {
    let dir = scratch("gif-limit");
    let many: Vec<String> = walk_frames().into_iter().cycle().take(3_000).collect();
    std::fs::write(dir.join("w.bvh"), walk_with_frames(&many)).unwrap();
    bad_input(
        &dir,
        &[
            &"render",
            &"w.bvh",
            &"--out",
            &"o.gif",
            &"--width",
            &"4096",
            &"--height",
            &"4096",
        ],
        &["w.bvh", "MAX_GIF_PIXELS", "--width"],
    );
}

/// The CMU-style demo rig's walk and a joint map for it with `edit` applied to its pairs.
fn rig_and_map(dir: &std::path::Path, edit: impl Fn(&mut Vec<(String, String)>)) {
    use motion_core::formats::bvh::{read_bvh, write_bvh};
    use motion_core::retarget::{demo_rig, JointMap, Retargeter, CMU_NAMES, MAPPED_JOINTS};
    let rig = demo_rig("", false, 1.0 / 70.0);
    let retargeter = Retargeter::new(&rig, JointMap::detect(&rig).unwrap()).unwrap();
    let rest = ndarray::Array2::zeros((1, rig.channel_count()));
    let bvh = retargeter.to_rig(&read_bvh(walk_seed()).unwrap(), rest.view());
    write_bvh(dir.join("rig.bvh"), &bvh).unwrap();
    let mut pairs: Vec<(String, String)> = MAPPED_JOINTS
        .iter()
        .zip(CMU_NAMES)
        .map(|(m, u)| (m.to_string(), u.to_string()))
        .collect();
    edit(&mut pairs);
    let body: Vec<String> = pairs.iter().map(|(m, u)| format!("{m:?}: {u:?}")).collect();
    std::fs::write(dir.join("map.json"), format!("{{{}}}", body.join(", "))).unwrap();
}

fn set(pairs: &mut [(String, String)], model: &str, rig: &str) {
    pairs.iter_mut().find(|(m, _)| m == model).unwrap().1 = rig.into();
}

#[test]
fn joint_maps_that_break_the_hierarchy_are_refused_naming_the_entry() {
    let dir = scratch("maps");
    let m = fixture_model();
    type Edit = Box<dyn Fn(&mut Vec<(String, String)>)>;
    let cases: Vec<(Edit, &[&str])> = vec![
        (
            Box::new(|p| set(p, "LeftHand", "LeftForeArm")),
            &["map.json", "LeftHand", "LeftForeArm", "each needs its own"],
        ),
        (
            Box::new(|p| {
                set(p, "Hips", "Head");
                set(p, "Head", "Hips");
            }),
            &["map.json", "not below"],
        ),
        (
            Box::new(|p| {
                set(p, "LeftArm", "LeftUpLeg");
                set(p, "LeftUpLeg", "LeftArm");
            }),
            &["map.json", "not below"],
        ),
        (
            Box::new(|p| p.push(("Head".into(), "Neck".into()))),
            &["map.json", "\"Head\" twice"],
        ),
        (
            Box::new(|p| {
                for part in ["Shoulder", "Arm", "ForeArm", "Hand"] {
                    set(p, &format!("Left{part}"), &format!("Right{part}"));
                    set(p, &format!("Right{part}"), &format!("Left{part}"));
                }
            }),
            &["map.json", "swapped"],
        ),
    ];
    for (edit, expected) in cases {
        rig_and_map(&dir, edit);
        bad_input(
            &dir,
            &[
                &"predict",
                &"--model",
                &m,
                &"--seed",
                &"rig.bvh",
                &"--joint-map",
                &"map.json",
                &"--action",
                &"walking",
                &"--out",
                &"p.bvh",
            ],
            expected,
        );
    }
}

#[test]
fn score_options_that_do_not_apply_are_refused() {
    let dir = scratch("score-options");
    write_npy(dir.join("e.npy"), &Array3::<f64>::zeros((2, 30, 99))).unwrap();
    write_npy(dir.join("pos.npy"), &Array4::<f64>::zeros((2, 30, 32, 3))).unwrap();
    // NDMS in the raw space on exp-map frames.
    bad_input(
        &dir,
        &[
            &"score",
            &"--pred",
            &"e.npy",
            &"--db",
            &"e.npy",
            &"--metric",
            &"ndms",
            &"--input-space",
            &"raw",
        ],
        &["raw space needs positions", "e.npy"],
    );
    // --skeleton: missing, not a BVH, or given for exp-map data.
    for (skeleton, pred, expected) in [
        ("missing.bvh", "pos.npy", "missing.bvh"),
        ("e.npy", "pos.npy", "takes a .bvh"),
        (walk_seed().to_str().unwrap(), "e.npy", "not positions"),
    ] {
        bad_input(
            &dir,
            &[
                &"score",
                &"--pred",
                &pred,
                &"--db",
                &pred,
                &"--metric",
                &"ndms",
                &"--input-space",
                &"raw",
                &"--skeleton",
                &skeleton,
            ],
            &[expected],
        );
    }
}
