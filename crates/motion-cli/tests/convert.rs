//! `motion-cli convert`, driven through the built binary.
//!
//! The acceptance test on `MOTION_DATA_DIR/h3.6m/dataset/S5/walking_1.txt.gz` (default
//! `<repo>/../shared/data`) is skipped with a visible message when the data is absent; the other
//! tests use motion generated here or the generated fixtures of `tests/fixtures/bvh/`.
mod common;

use common::{data_dir, repo, scratch};
use std::f64::consts::PI;
use std::path::Path;
use std::process::Command;

use motion_core::formats::bvh::read_bvh;
use motion_core::formats::h36m_text::{downsample_protocol, read_expmap_text, write_expmap_text};
use motion_core::formats::npy::read_npy_positions;
use motion_core::kinematics::{channel_positions, expmap_positions};
use motion_core::motion::RootEncoding;
use motion_core::rotation::expmap2rotmat;
use motion_core::skeleton::Skeleton;
use ndarray::{Array2, Array3};

/// Runs `motion-cli convert ARGS`; returns (exit code, stderr).
fn convert(args: &[&dyn AsRef<std::ffi::OsStr>]) -> (i32, String) {
    let output = Command::new(env!("CARGO_BIN_EXE_motion-cli"))
        .arg("convert")
        .args(args.iter().map(|a| a.as_ref()))
        .output()
        .expect("runs motion-cli");
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    (output.status.code().unwrap_or(-1), stderr)
}

fn convert_ok(args: &[&dyn AsRef<std::ffi::OsStr>]) {
    let (code, stderr) = convert(args);
    assert_eq!(code, 0, "motion-cli convert failed: {stderr}");
}

fn max_abs_diff2(a: &Array2<f64>, b: &Array2<f64>) -> f64 {
    assert_eq!(a.dim(), b.dim());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

fn max_abs_diff3(a: &Array3<f64>, b: &Array3<f64>) -> f64 {
    assert_eq!(a.dim(), b.dim());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// Max difference of two exp-map sequences as rotations (row-vector matrices), joints only.
fn max_rotation_diff(a: &Array2<f64>, b: &Array2<f64>) -> f64 {
    let mut worst = 0.0f64;
    for (ra, rb) in a.rows().into_iter().zip(b.rows()) {
        for k in (6..ra.len()).step_by(3) {
            let ma = expmap2rotmat([ra[k], ra[k + 1], ra[k + 2]]);
            let mb = expmap2rotmat([rb[k], rb[k + 1], rb[k + 2]]);
            for (x, y) in ma.iter().flatten().zip(mb.iter().flatten()) {
                worst = worst.max((x - y).abs());
            }
        }
    }
    worst
}

/// Synthetic H3.6M-like frames (99 dims, root deltas), so the binary is tested without data.
fn synthetic_h36m(frames: usize) -> Array2<f64> {
    Array2::from_shape_fn((frames, 99), |(t, d)| {
        let time = t as f64 / 50.0;
        let df = d as f64;
        match d {
            0 => 0.4 * (2.0 * PI * time).sin(),
            1 => 0.1,
            2 => 12.0,
            3 | 5 => 0.001,
            4 => 0.015,
            _ => 0.7 * (2.0 * PI * (0.25 + 0.02 * df) * time + df).sin(),
        }
    })
}

/// Checks the BVH of `source` (written by `convert`) against exp-map FK, and BVH -> txt -> BVH.
/// Returns (FK max difference mm, BVH round trip max difference, exp-map round trip max difference).
fn check_h36m_conversions(dir: &Path, source_path: &Path, fps_25: bool) -> (f64, f64, f64) {
    let source = read_expmap_text(source_path).unwrap();
    let (source, step) = if fps_25 {
        (downsample_protocol(source.view()), 2)
    } else {
        (source, 1)
    };
    let bvh_path = dir.join("motion.bvh");
    let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![&source_path, &bvh_path];
    if fps_25 {
        args.extend([&"--fps" as &dyn AsRef<std::ffi::OsStr>, &"25"]);
    }
    convert_ok(&args);
    let bvh = read_bvh(&bvh_path).unwrap();
    assert_eq!(bvh.frames.nrows(), source.nrows());
    assert_eq!(bvh.frame_time, if fps_25 { 0.04 } else { 0.02 });

    let reference =
        expmap_positions(&Skeleton::h36m(), source.view(), RootEncoding::Deltas, step).unwrap();
    let fk = channel_positions(&bvh.skeleton, bvh.frames.view()).unwrap();
    let fk_error = max_abs_diff3(&reference, &fk);

    // BVH -> txt -> BVH.
    let txt_path = dir.join("back.txt");
    let bvh2_path = dir.join("back.bvh");
    convert_ok(&[&bvh_path, &txt_path]);
    // Exp-map text stores no frame rate: say it.
    let rate = if fps_25 { "25" } else { "50" };
    convert_ok(&[&txt_path, &bvh2_path, &"--input-fps", &rate]);
    let bvh2 = read_bvh(&bvh2_path).unwrap();
    assert_eq!(bvh2.skeleton, bvh.skeleton);
    assert_eq!(bvh2.frame_time, bvh.frame_time);
    let bvh_error = max_abs_diff2(&bvh.frames, &bvh2.frames);

    // txt -> BVH -> txt: the same exp-maps (as rotations: angles > π come back below π).
    let back = read_expmap_text(&txt_path).unwrap();
    let root_error = max_abs_diff2(
        &source.slice(ndarray::s![.., 0..6]).to_owned(),
        &back.slice(ndarray::s![.., 0..6]).to_owned(),
    );
    let expmap_error = root_error.max(max_rotation_diff(&source, &back));
    (fk_error, bvh_error, expmap_error)
}

#[test]
fn h36m_walking_to_bvh_matches_expmap_fk_and_round_trips() {
    let path = data_dir().join("h3.6m/dataset/S5/walking_1.txt.gz");
    if !path.exists() {
        eprintln!(
            "SKIPPED: {} not found (set MOTION_DATA_DIR)",
            path.display()
        );
        return;
    }
    for fps_25 in [false, true] {
        let dir = scratch(if fps_25 { "walking-25" } else { "walking-50" });
        let (fk, bvh, expmap) = check_h36m_conversions(&dir, &path, fps_25);
        let rate = if fps_25 { 25 } else { 50 };
        eprintln!(
            "S5 walking_1 at {rate} Hz: BVH FK vs exp-map FK max {fk:e} mm; \
             BVH -> txt -> BVH max {bvh:e}; txt -> BVH -> txt max {expmap:e}"
        );
        assert!(fk < 1e-3, "FK differs by {fk} mm");
        assert!(bvh < 1e-6, "BVH -> txt -> BVH differs by {bvh}");
        assert!(expmap < 1e-6, "txt -> BVH -> txt differs by {expmap}");
    }
}

#[test]
fn synthetic_h36m_to_bvh_matches_expmap_fk_and_round_trips() {
    for fps_25 in [false, true] {
        let dir = scratch(if fps_25 {
            "synthetic-25"
        } else {
            "synthetic-50"
        });
        let source = dir.join("synthetic.txt.gz");
        write_expmap_text(&source, synthetic_h36m(200).view()).unwrap();
        let (fk, bvh, expmap) = check_h36m_conversions(&dir, &source, fps_25);
        assert!(fk < 1e-3, "FK differs by {fk} mm");
        assert!(bvh < 1e-6, "BVH -> txt -> BVH differs by {bvh}");
        assert!(expmap < 1e-6, "txt -> BVH -> txt differs by {expmap}");
    }
}

#[test]
fn positions_from_text_npy_and_bvh_agree() {
    let dir = scratch("positions");
    let frames = synthetic_h36m(60);
    let txt = dir.join("m.txt");
    write_expmap_text(&txt, frames.view()).unwrap();
    let reference =
        expmap_positions(&Skeleton::h36m(), frames.view(), RootEncoding::Deltas, 1).unwrap();

    let from_txt = dir.join("from_txt.npy");
    convert_ok(&[&txt, &from_txt, &"--positions"]);
    assert_eq!(read_npy_positions(&from_txt).unwrap(), reference);

    // Exp-map .npy in, positions out.
    let npy = dir.join("m.npy");
    convert_ok(&[&txt, &npy]);
    let from_npy = dir.join("from_npy.npy");
    convert_ok(&[&npy, &from_npy, &"--positions"]);
    assert_eq!(read_npy_positions(&from_npy).unwrap(), reference);

    let bvh = dir.join("m.bvh");
    convert_ok(&[&txt, &bvh]);
    let from_bvh = dir.join("from_bvh.npy");
    convert_ok(&[&bvh, &from_bvh, &"--positions"]);
    let error = max_abs_diff3(&read_npy_positions(&from_bvh).unwrap(), &reference);
    assert!(error < 1e-3, "{error} mm");

    // 25 Hz positions: the root integrated with two source frames per step.
    let from_txt_25 = dir.join("from_txt_25.npy");
    convert_ok(&[&txt, &from_txt_25, &"--positions", &"--fps", &"25"]);
    let reference_25 = expmap_positions(
        &Skeleton::h36m(),
        downsample_protocol(frames.view()).view(),
        RootEncoding::Deltas,
        2,
    )
    .unwrap();
    assert_eq!(read_npy_positions(&from_txt_25).unwrap(), reference_25);
}

#[test]
fn cmu_style_bvh_fixture_converts_to_bvh_and_positions() {
    let dir = scratch("cmu-style");
    let fixture = repo().join("tests/fixtures/bvh/cmu_style_crlf_tabs.bvh");
    let original = read_bvh(&fixture).unwrap();
    let out = dir.join("copy.bvh");
    convert_ok(&[&fixture, &out]);
    let copy = read_bvh(&out).unwrap();
    assert_eq!(copy, original);
    let positions = dir.join("positions.npy");
    convert_ok(&[&fixture, &positions, &"--positions"]);
    let fk = channel_positions(&original.skeleton, original.frames.view()).unwrap();
    assert_eq!(read_npy_positions(&positions).unwrap(), fk);
    // 120 fps (Frame Time 0.00833333) to 30 fps keeps every 4th frame.
    let slow = dir.join("slow.bvh");
    convert_ok(&[&fixture, &slow, &"--fps", &"30"]);
    let slow = read_bvh(&slow).unwrap();
    assert_eq!(slow.frames.nrows(), original.frames.nrows().div_ceil(4));
    assert_eq!(slow.frames.row(1), original.frames.row(4));
    assert!((slow.fps() - 30.0).abs() < 1e-3);
}

/// Bad input: exit status 2, one line on stderr naming the problem, no output file left behind.
fn assert_rejected(dir: &Path, args: &[&dyn AsRef<std::ffi::OsStr>], needle: &str) {
    let before: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    let (code, stderr) = convert(args);
    assert_eq!(code, 2, "stderr: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "stderr: {stderr}");
    assert!(stderr.starts_with("error: "), "stderr: {stderr}");
    assert!(stderr.contains(needle), "expected {needle:?} in: {stderr}");
    let after: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(before, after, "files changed after a rejected conversion");
}

#[test]
fn bad_input_exits_2_with_one_line_and_no_output() {
    let dir = scratch("bad-input");
    let txt = dir.join("ok.txt");
    write_expmap_text(&txt, synthetic_h36m(10).view()).unwrap();
    let out_bvh = dir.join("out.bvh");

    assert_rejected(&dir, &[&dir.join("missing.txt"), &out_bvh], "missing.txt");
    assert_rejected(&dir, &[&txt, &dir.join("out.csv")], "unknown motion format");
    assert_rejected(
        &dir,
        &[&txt, &dir.join("out.txt"), &"--positions"],
        "--positions writes a .npy",
    );
    assert_rejected(
        &dir,
        &[&txt, &out_bvh, &"--fps", &"0.5"],
        "--fps: 0.5 fps is outside 1 ..= 10000 frames per second",
    );

    let malformed = dir.join("malformed.bvh");
    std::fs::write(
        &malformed,
        "HIERARCHY\nROOT Hips\n{\n\tOFFSET 0 0 0\n\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n}\nMOTION\nFrames: 2\nFrame Time: 0.02\n0 0 0 0 0 0\n",
    )
    .unwrap();
    assert_rejected(
        &dir,
        &[&malformed, &dir.join("out.txt")],
        "malformed.bvh:8: 'Frames: 2' but the file has 1 frame lines",
    );

    let not_h36m = dir.join("not_h36m.bvh");
    std::fs::write(
        &not_h36m,
        "HIERARCHY\nROOT Hips\n{\n\tOFFSET 0 0 0\n\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n}\nMOTION\nFrames: 1\nFrame Time: 0.02\n0 0 0 0 0 0\n",
    )
    .unwrap();
    assert_rejected(
        &dir,
        &[&not_h36m, &dir.join("out.txt")],
        "no built-in exp-map skeleton fits",
    );

    let narrow = dir.join("narrow.txt");
    std::fs::write(&narrow, "1,2,3\n4,5,6\n").unwrap();
    assert_rejected(
        &dir,
        &[&narrow, &out_bvh],
        "3 columns per frame fit no built-in skeleton",
    );
    assert_rejected(
        &dir,
        &[&narrow, &dir.join("p.npy"), &"--positions"],
        "no built-in skeleton",
    );
    // ... but copying it between text and .npy works.
    convert_ok(&[&narrow, &dir.join("narrow.npy")]);

    let ragged = dir.join("ragged.txt");
    std::fs::write(&ragged, "1,2,3\n4,5\n").unwrap();
    assert_rejected(&dir, &[&ragged, &dir.join("r.npy")], "ragged.txt:2");
}

#[test]
fn help_teaches_with_examples() {
    let output = Command::new(env!("CARGO_BIN_EXE_motion-cli"))
        .args(["convert", "--help"])
        .output()
        .unwrap();
    assert!(output.status.success());
    let help = String::from_utf8_lossy(&output.stdout);
    for needle in [
        "Examples:",
        "--fps 25",
        "--positions",
        ".txt.gz",
        "exits with status 2",
    ] {
        assert!(help.contains(needle), "{needle:?} missing from:\n{help}");
    }
}

#[test]
fn any_rate_interpolates_and_frames_at_shared_times_are_the_source_frames() {
    let dir = scratch("any-rate");
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/walk_seed.bvh");
    let out = dir.join("walk60.bvh");
    convert_ok(&[&source, &out, &"--fps", &"60"]);
    let (a, b) = (read_bvh(&source).unwrap(), read_bvh(&out).unwrap());
    assert!((b.fps() - 60.0).abs() < 1e-9);
    // 75 frames at 25 Hz span 2.96 s: 178 frames at 60 Hz.
    assert_eq!(b.frames.nrows(), 178);
    let pa = channel_positions(&a.skeleton, a.frames.view()).unwrap();
    let pb = channel_positions(&b.skeleton, b.frames.view()).unwrap();
    // Every 0.2 s both rates have a frame: 25 Hz frame 5k is 60 Hz frame 12k.
    for k in 0..15 {
        let d = (&pa.index_axis(ndarray::Axis(0), 5 * k)
            - &pb.index_axis(ndarray::Axis(0), 12 * k))
            .mapv(f64::abs)
            .fold(0.0f64, |m, &v| m.max(v));
        assert!(d < 1e-6, "0.2 s x {k}: {d} mm");
    }
}
