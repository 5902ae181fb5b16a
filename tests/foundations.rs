//! Facade-level tests of the motion-core foundations (rotations, skeleton, root integration, FK,
//! derivative features, H3.6M text and `.npy`), on synthetic motion and, when present, on the
//! real H3.6M data under `MOTION_DATA_DIR` (default `<repo>/../shared/data`).
mod common;

use std::path::PathBuf;
use std::sync::Arc;

use motion::core::derivatives::{derivative_features, DerivativeBuffer};
use motion::core::formats::h36m_text::{downsample_protocol, read_expmap_text, write_expmap_text};
use motion::core::formats::npy::{read_npy_frames, read_npy_positions, write_npy};
use motion::core::kinematics::{channel_positions, expmap_positions, ExpMapFk};
use motion::core::motion::{Motion, MotionLayout, RootEncoding};
use motion::core::root::{integrate_root, root_deltas, RootIntegrator, RootPose};
use motion::core::rotation::{
    dmat3_to_euler, expmap2rotmat, expmap_frame_to_euler_protocol, mat3_to_dmat3, EulerOrder,
};
use motion::core::skeleton::{Skeleton, H36M_ACTIONS, H36M_DIMS_USED};
use motion::core::FormatError;
use ndarray::{Array2, Array3};

/// `S5/{name}.txt.gz` of the H3.6M data, or `None` after a visible SKIPPED message.
fn s5(name: &str, test: &str) -> Option<Array2<f64>> {
    let path = common::data_root().join(format!("h3.6m/dataset/S5/{name}.txt.gz"));
    if !path.exists() {
        eprintln!(
            "SKIPPED: {test}: {} not found (set MOTION_DATA_DIR)",
            path.display()
        );
        return None;
    }
    Some(read_expmap_text(&path).expect("real H3.6M file reads"))
}

/// A scratch directory removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new(tag: &str) -> Scratch {
        let dir =
            std::env::temp_dir().join(format!("motion-foundations-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn synthetic(frames: usize) -> Array2<f64> {
    Array2::from_shape_fn((frames, 99), |(t, k)| {
        let x = (t as f64 * 0.13 + k as f64 * 0.71).sin();
        match k {
            0..=2 => 14.0 * x + if k == 2 { 9.0 } else { 0.0 },
            3..=5 => 0.02 * x,
            _ => 0.7 * x,
        }
    })
}

fn max_abs_diff<'a>(
    a: impl IntoIterator<Item = &'a f64>,
    b: impl IntoIterator<Item = &'a f64>,
) -> f64 {
    a.into_iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

fn horizontal_path_length(poses: &[RootPose]) -> f64 {
    poses
        .windows(2)
        .map(|w| {
            let (a, b) = (w[0].translation, w[1].translation);
            ((a[0] - b[0]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
        })
        .sum()
}

fn worst_bone_error(skeleton: &Skeleton, positions: &Array3<f64>) -> f64 {
    let mut worst: f64 = 0.0;
    for t in 0..positions.dim().0 {
        for j in 1..skeleton.len() {
            let p = skeleton.parent(j).unwrap();
            let d: f64 = (0..3)
                .map(|k| (positions[[t, j, k]] - positions[[t, p, k]]).powi(2))
                .sum::<f64>()
                .sqrt();
            worst = worst.max((d - skeleton.bone_length(j)).abs());
        }
    }
    worst
}

#[test]
fn walking_root_trajectory_covers_about_2_by_3_metres_at_0_7_m_per_s() {
    let Some(x) = s5("walking_1", "walking_root_trajectory") else {
        return;
    };
    assert_eq!(x.ncols(), 99);
    let poses = integrate_root(x.view(), 1);
    let extent = |k: usize| {
        let (lo, hi) = poses.iter().fold((f64::MAX, f64::MIN), |(lo, hi), p| {
            (lo.min(p.translation[k]), hi.max(p.translation[k]))
        });
        hi - lo
    };
    let (mut a, mut b) = (extent(0), extent(2));
    if a > b {
        std::mem::swap(&mut a, &mut b);
    }
    let seconds = x.nrows() as f64 / 50.0;
    let speed = horizontal_path_length(&poses) / seconds / 1000.0;
    eprintln!("walking_1: {a:.0} x {b:.0} mm, {speed:.3} m/s");
    assert!((1500.0..2800.0).contains(&a), "short side {a} mm");
    assert!((2500.0..3800.0).contains(&b), "long side {b} mm");
    assert!((0.6..0.8).contains(&speed), "speed {speed} m/s");
}

#[test]
fn root_deltas_of_real_data_round_trip_at_50_and_25_hz() {
    let Some(x) = s5("walking_1", "root_deltas_round_trip") else {
        return;
    };
    let back = root_deltas(&integrate_root(x.view(), 1), 1);
    for t in 0..x.nrows() {
        for k in 0..6 {
            assert!(
                (back[[t, k]] - x[[t, k]]).abs() < 1e-9,
                "50 Hz frame {t} dim {k}"
            );
        }
    }
    let d = downsample_protocol(x.view());
    let back = root_deltas(&integrate_root(d.view(), 2), 2);
    for t in 0..d.nrows() {
        for k in 0..6 {
            assert!(
                (back[[t, k]] - d[[t, k]]).abs() < 1e-9,
                "25 Hz frame {t} dim {k}"
            );
        }
    }
}

#[test]
fn root_integration_at_25_hz_is_consistent_with_50_hz() {
    let Some(x) = s5("walking_1", "root_integration_25_vs_50_hz") else {
        return;
    };
    let p50 = integrate_root(x.view(), 1);
    let d = downsample_protocol(x.view());
    let p25 = integrate_root(d.view(), 2);
    // 25 Hz frame k approximates 50 Hz frame 2k (each kept delta is applied for two steps).
    let sampled: Vec<RootPose> = (0..p25.len()).map(|k| p50[2 * k]).collect();
    let drift = |n: usize| {
        (0..n.min(p25.len()))
            .map(|k| {
                let (a, b) = (sampled[k].translation, p25[k].translation);
                ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
            })
            .fold(0.0, f64::max)
    };
    let (len50, len25) = (
        horizontal_path_length(&sampled),
        horizontal_path_length(&p25),
    );
    eprintln!(
        "25 vs 50 Hz root: drift {:.1} mm over 4 s, {:.1} mm over the clip; path {len25:.0} vs {len50:.0} mm",
        drift(100),
        drift(usize::MAX)
    );
    assert!(
        (len25 / len50 - 1.0).abs() < 0.03,
        "path lengths {len25} vs {len50}"
    );
    assert!(
        drift(100) < 80.0,
        "drift over the first 4 s: {} mm",
        drift(100)
    );
    assert!(drift(usize::MAX) < 0.03 * len50, "drift over the clip");
}

#[test]
fn fk_of_real_data_preserves_bone_lengths_and_matches_channel_fk() {
    let Some(x) = s5("walking_1", "fk_of_real_data") else {
        return;
    };
    let skeleton = Skeleton::h36m();
    let clip = x.slice(ndarray::s![..600, ..]);
    let positions = expmap_positions(&skeleton, clip, RootEncoding::Deltas, 1).unwrap();
    let bone = worst_bone_error(&skeleton, &positions);
    eprintln!("walking_1 FK: worst bone length error {bone:.2e} mm");
    assert!(bone < 1e-3, "bone length error {bone} mm");

    // The same motion as BVH channels (root position + ZXY degrees, column-vector local
    // rotation = transpose of the H3.6M row-vector one) gives the same positions.
    let poses = integrate_root(clip, 1);
    let mut channels = Array2::zeros((clip.nrows(), skeleton.channel_count()));
    for t in 0..clip.nrows() {
        for k in 0..3 {
            channels[[t, k]] = poses[t].translation[k];
        }
        for j in 0..skeleton.len() {
            let row = if j == 0 {
                poses[t].rotation
            } else {
                let k = 3 + 3 * j;
                expmap2rotmat([clip[[t, k]], clip[[t, k + 1]], clip[[t, k + 2]]])
            };
            let euler = dmat3_to_euler(EulerOrder::ZXY, &mat3_to_dmat3(&row).transpose());
            let start = skeleton.channel_start(j) + if j == 0 { 3 } else { 0 };
            for k in 0..3 {
                channels[[t, start + k]] = euler[k].to_degrees();
            }
        }
    }
    let via_channels = channel_positions(&skeleton, channels.view()).unwrap();
    let worst = max_abs_diff(positions.iter(), via_channels.iter());
    eprintln!("walking_1: exp-map FK vs channel FK {worst:.2e} mm");
    assert!(worst < 1e-3, "FK disagreement {worst} mm");
}

#[test]
fn real_text_round_trips_bit_exactly_through_txt_and_gz() {
    let Some(x) = s5("walking_1", "real_text_round_trip") else {
        return;
    };
    let dir = Scratch::new("text");
    let clip = x.slice(ndarray::s![..200, ..]);
    for name in ["clip.txt", "clip.txt.gz"] {
        let path = dir.0.join(name);
        write_expmap_text(&path, clip).unwrap();
        assert_eq!(read_expmap_text(&path).unwrap(), clip);
    }
}

#[test]
fn missing_h36m_files_are_clear_errors() {
    // S5 directions_1 is one of the files the data release does not have (h36m.md).
    let path = common::data_root().join("h3.6m/dataset/S5/directions_1.txt.gz");
    let err = read_expmap_text(&path).unwrap_err();
    assert!(matches!(err, FormatError::Io { .. }));
    assert!(err.to_string().contains("directions_1.txt.gz"), "{err}");
}

#[test]
fn protocol_euler_conversion_of_real_frames() {
    let Some(x) = s5("walking_1", "protocol_euler_conversion") else {
        return;
    };
    let d = downsample_protocol(x.view());
    assert_eq!(d.nrows(), x.nrows().div_ceil(2));
    let mut out = vec![0.0; 99];
    for row in d.rows().into_iter().take(300) {
        expmap_frame_to_euler_protocol(row.as_slice().unwrap(), &mut out);
        assert!(out[..6].iter().all(|&v| v == 0.0));
        assert!(out
            .iter()
            .all(|v| v.is_finite() && v.abs() <= std::f64::consts::PI));
    }
    // The 54 used dims are exactly those that move in this clip (the others are constant).
    let moving: Vec<usize> = (0..99)
        .filter(|&k| {
            let col = x.column(k);
            let (lo, hi) = col
                .iter()
                .fold((f64::MAX, f64::MIN), |(l, h), &v| (l.min(v), h.max(v)));
            hi - lo > 1e-4
        })
        .collect();
    assert!(
        moving.iter().all(|k| H36M_DIMS_USED.contains(k)),
        "{moving:?}"
    );
}

#[test]
fn derivative_features_batch_equals_incremental_on_real_data_f32() {
    let Some(x) = s5("walking_1", "derivative_features_real") else {
        return;
    };
    let used: Array2<f32> =
        Array2::from_shape_fn((300, 54), |(t, k)| x[[t, H36M_DIMS_USED[k]]] as f32);
    let batch = derivative_features(used.view(), 3);
    let mut buffer = DerivativeBuffer::<f32>::new(54, 3);
    let mut out = vec![0.0f32; 216];
    for t in 0..300 {
        buffer.push(used.row(t).as_slice().unwrap(), &mut out);
        assert!(batch
            .row(t)
            .iter()
            .zip(&out)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
    }
}

#[test]
fn streaming_fk_equals_batch_fk_and_motion_positions() {
    let x = synthetic(80);
    let skeleton = Arc::new(Skeleton::h36m());
    let motion = Motion::new(
        skeleton.clone(),
        MotionLayout::ExpMap {
            root: RootEncoding::Deltas,
        },
        x.clone(),
        25.0,
    )
    .unwrap();
    let batch = motion.positions();
    let mut fk = ExpMapFk::new(&skeleton);
    let mut root = RootIntegrator::new(motion.root_step());
    let mut out = vec![[0.0; 3]; skeleton.len()];
    for t in 0..x.nrows() {
        let frame = x.row(t).to_vec();
        let pose = root.push(&frame);
        fk.frame(&skeleton, &frame, &pose, &mut out);
        for (j, p) in out.iter().enumerate() {
            assert_eq!(p, &[batch[[t, j, 0]], batch[[t, j, 1]], batch[[t, j, 2]]]);
        }
    }
    assert!(worst_bone_error(&skeleton, &batch) < 1e-3);
    let window = motion.window(10, 50).unwrap();
    assert_eq!(window.row(0), x.row(10));
}

#[test]
fn npy_round_trips_frames_and_positions() {
    let dir = Scratch::new("npy");
    let x = synthetic(30);
    let positions = expmap_positions(&Skeleton::h36m(), x.view(), RootEncoding::Deltas, 1).unwrap();
    write_npy(dir.0.join("frames.npy"), &x).unwrap();
    write_npy(dir.0.join("positions.npy"), &positions).unwrap();
    assert_eq!(read_npy_frames(dir.0.join("frames.npy")).unwrap(), x);
    assert_eq!(
        read_npy_positions(dir.0.join("positions.npy")).unwrap(),
        positions
    );
    let err = read_npy_frames(dir.0.join("positions.npy")).unwrap_err();
    assert!(err.to_string().contains("positions.npy"), "{err}");
}

#[test]
fn cmu_clips_stand_on_the_floor_with_an_absolute_root() {
    let path = common::data_root().join("cmu/train/walking/walking_1.txt.gz");
    if !path.exists() {
        eprintln!(
            "SKIPPED: cmu_clips_stand_on_the_floor: {} not found (set MOTION_DATA_DIR)",
            path.display()
        );
        return;
    }
    let x = read_expmap_text(&path).unwrap();
    assert_eq!(x.ncols(), 117);
    let skeleton = Skeleton::cmu();
    let positions = expmap_positions(&skeleton, x.view(), RootEncoding::Absolute, 1).unwrap();
    assert!(worst_bone_error(&skeleton, &positions) < 1e-5);
    for t in 0..x.nrows() {
        let lowest = (0..skeleton.len())
            .map(|j| positions[[t, j, 1]])
            .fold(f64::MAX, f64::min);
        assert!(
            (-2.0..2.5).contains(&lowest),
            "frame {t}: lowest joint at y = {lowest}"
        );
    }
}

#[test]
fn actions_are_the_fifteen_of_the_protocol() {
    assert_eq!(H36M_ACTIONS.len(), 15);
    assert_eq!(H36M_ACTIONS[12], "walking");
    let mut sorted = H36M_ACTIONS;
    sorted.sort_unstable();
    assert_eq!(sorted, H36M_ACTIONS, "h36m.md lists them alphabetically");
}

#[test]
fn validation_windows_are_training_datas() {
    // `training/data.py`: validation_windows(None, ACTIONS, 8, stride=50), (subaction, start) of
    // three actions, in pick order.
    let expected: [(&str, [(u8, usize); 8]); 3] = [
        (
            "greeting",
            [
                (1, 552),
                (2, 532),
                (2, 116),
                (2, 682),
                (2, 66),
                (2, 482),
                (2, 582),
                (2, 732),
            ],
        ),
        (
            "posing",
            [
                (1, 602),
                (2, 674),
                (1, 552),
                (2, 574),
                (1, 652),
                (2, 724),
                (1, 213),
                (2, 524),
            ],
        ),
        (
            "walking",
            [
                (1, 810),
                (2, 682),
                (1, 401),
                (2, 582),
                (1, 910),
                (2, 782),
                (1, 351),
                (2, 532),
            ],
        ),
    ];
    let dataset = common::data_root().join("h3.6m/dataset");
    if !dataset.join("S5").exists() {
        eprintln!(
            "SKIPPED: validation_windows_are_training_datas: no S5 data (set MOTION_DATA_DIR)"
        );
        return;
    }
    for (action, starts) in expected {
        let windows = motion::core::protocol::load_action_windows_in(
            &dataset,
            action,
            100,
            motion::core::protocol::WindowSet::Validation,
            8,
        )
        .unwrap();
        let got: Vec<(u8, usize)> = windows
            .iter()
            .map(|w| (w.window.subaction, w.window.seed_start))
            .collect();
        assert_eq!(got, starts, "{action}");
        for w in &windows {
            assert_eq!(w.seed.nrows(), 50);
            assert_eq!(w.ground_truth.nrows(), 100);
        }
    }
}
