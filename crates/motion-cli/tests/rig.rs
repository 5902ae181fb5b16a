//! `predict --rig FILE.glb|FILE.bvh`: the motion written as BVH on a character's own skeleton
//! (the committed mannequin, `assets/mannequin.glb`), and the refusals around it. No `../shared`
//! data is needed.
mod common;

use common::{bad_input, motion_cli, repo, scratch, walk_seed};

use motion_core::formats::bvh::read_bvh;

#[test]
fn predict_writes_the_motion_on_the_mannequins_skeleton() {
    let dir = scratch("rig");
    let glb = repo().join("assets/mannequin.glb");
    let out = dir.join("m.bvh");
    let run = motion_cli([
        "predict".as_ref(),
        "--seed".as_ref(),
        walk_seed().as_os_str(),
        "--action".as_ref(),
        "walking".as_ref(),
        "--frames".as_ref(),
        "50".as_ref(),
        "--rig".as_ref(),
        glb.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let bvh = read_bvh(&out).unwrap();
    let names: Vec<&str> = bvh
        .skeleton
        .joints()
        .iter()
        .map(|j| j.name.as_str())
        .collect();
    assert_eq!(names.len(), 66);
    for name in [
        "root",
        "pelvis",
        "thigh_l",
        "calf_r",
        "upperarm_l",
        "head",
        "index_02_l",
    ] {
        assert!(names.contains(&name), "{name} missing from {names:?}");
    }
    assert_eq!(bvh.frames.nrows(), 100);
    // Metres: the pelvis sits under a metre above the root, the motion moves.
    let pelvis = &bvh.skeleton.joint(1);
    assert!(
        pelvis.offset[2].abs() + pelvis.offset[1].abs() < 1.2,
        "{:?}",
        pelvis.offset
    );
    let first = bvh.frames.row(0).to_owned();
    let last = bvh.frames.row(99).to_owned();
    assert!((&first - &last).iter().any(|d| d.abs() > 1.0));
    // A BVH rig works as a target too.
    let out2 = dir.join("w.bvh");
    let run = motion_cli([
        "predict".as_ref(),
        "--seed".as_ref(),
        walk_seed().as_os_str(),
        "--frames".as_ref(),
        "10".as_ref(),
        "--rig".as_ref(),
        walk_seed().as_os_str(),
        "--out".as_ref(),
        out2.as_os_str(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
}

#[test]
fn bad_rigs_are_refused() {
    let dir = scratch("rig_refusals");
    let seed = walk_seed();
    let glb = repo().join("assets/mannequin.glb");
    let text = dir.join("not.glb");
    std::fs::write(&text, "not a glTF file").unwrap();
    bad_input(
        &dir,
        &[
            &"predict",
            &"--seed",
            &seed,
            &"--rig",
            &text,
            &"--out",
            &dir.join("a.bvh"),
        ],
        &["not.glb", "not glTF"],
    );
    bad_input(
        &dir,
        &[
            &"predict",
            &"--seed",
            &seed,
            &"--rig",
            &glb,
            &"--out",
            &dir.join("a.npy"),
        ],
        &["--rig", ".bvh"],
    );
    let obj = dir.join("char.obj");
    std::fs::write(&obj, "v 0 0 0").unwrap();
    bad_input(
        &dir,
        &[
            &"predict",
            &"--seed",
            &seed,
            &"--rig",
            &obj,
            &"--out",
            &dir.join("a.bvh"),
        ],
        &["char.obj", ".glb"],
    );
}
