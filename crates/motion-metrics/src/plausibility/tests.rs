use super::reference::percentile;
use super::*;
use motion_core::kinematics::expmap_positions;
use motion_core::RootEncoding;
use ndarray::{concatenate, s, Array2, Axis};

/// Deterministic motion: root deltas like a slow walk with small turns, joints swinging.
fn wavy(frames: usize, phase: f64) -> Array2<f64> {
    Array2::from_shape_fn((frames, 99), |(t, k)| {
        let x = (t as f64 * 0.23 + k as f64 * 0.71 + phase).sin();
        match k {
            0..=2 => 9.0 * x + if k == 2 { 12.0 } else { 0.0 },
            3..=5 => 0.015 * x,
            _ => 0.5 * x,
        }
    })
}

/// The definitions of the module docs, written out directly in f64 on full FK arrays.
fn naive(seed: &Array2<f64>, motion: &Array2<f64>) -> SequenceMeasures {
    let skeleton = Skeleton::h36m();
    let joined = concatenate(Axis(0), &[seed.view(), motion.view()]).unwrap();
    let world = expmap_positions(&skeleton, joined.view(), RootEncoding::Deltas, 2).unwrap();
    let mut still_root = joined.clone();
    still_root.slice_mut(s![.., ..6]).fill(0.0);
    let local = expmap_positions(&skeleton, still_root.view(), RootEncoding::Deltas, 2).unwrap();
    let seed_frames = seed.nrows();
    let feet = [3, 4, 5, 8, 9, 10];
    let points: Vec<glam::Vec3> = (0..seed_frames)
        .flat_map(|t| {
            feet.map(|j| {
                (glam::DVec3::new(world[[t, j, 0]], world[[t, j, 1]], world[[t, j, 2]]) * 1e-3)
                    .as_vec3()
            })
        })
        .collect();
    let floor = motion_core::grounding::Floor::fit_frames(&points, feet.len()).unwrap();
    let at = |t: usize, j: usize| {
        let p = glam::DVec3::new(world[[t, j, 0]], world[[t, j, 1]], world[[t, j, 2]]);
        floor.to_floor_frame_f64(p * 1e-3) * 1e3
    };
    let lean = |t: usize| {
        let v = at(t, 13) - at(t, 0);
        (v.x * v.x + v.z * v.z).sqrt().atan2(v.y).to_degrees()
    };
    let last = seed_frames - 1;
    let mut out = SequenceMeasures {
        speed_mm_s: vec![],
        hip_height_change_mm: vec![],
        lean_change_deg: vec![],
        airborne: vec![],
        lean_deg: vec![],
        hip_height_mm: vec![],
        lowest_foot_mm: vec![],
        skating: vec![],
    };
    for t in seed_frames..joined.nrows() {
        let mut sum = 0.0;
        for j in 0..32 {
            let d: f64 = (0..3)
                .map(|a| (local[[t, j, a]] - local[[t - 1, j, a]]).powi(2))
                .sum();
            sum += d.sqrt();
        }
        out.speed_mm_s.push(sum / 32.0 * 25.0);
        out.hip_height_change_mm
            .push((at(t, 0).y - at(last, 0).y).abs());
        out.lean_change_deg.push((lean(t) - lean(last)).abs());
        out.hip_height_mm.push(at(t, 0).y);
        out.lean_deg.push(lean(t));
        let right = [3, 4, 5]
            .map(|j| at(t, j).y)
            .into_iter()
            .fold(f64::INFINITY, f64::min);
        let left = [8, 9, 10]
            .map(|j| at(t, j).y)
            .into_iter()
            .fold(f64::INFINITY, f64::min);
        out.airborne.push(right > 100.0 && left > 100.0);
        out.lowest_foot_mm.push(right.min(left));
        out.skating.push(feet.iter().any(|&j| {
            let (p, q) = (at(t, j), at(t - 1, j));
            p.y < 50.0 && ((p.x - q.x).powi(2) + (p.z - q.z).powi(2)).sqrt() * 25.0 > 500.0
        }));
    }
    out
}

fn close(a: &[f64], b: &[f64], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}");
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= 1e-9 * x.abs().max(1.0),
            "{what}[{i}]: {x} vs {y}"
        );
    }
}

#[test]
fn matches_the_naive_definition() {
    for (seed_frames, frames, phase) in [(50, 120, 0.0), (1, 30, 1.3), (7, 301, 2.1)] {
        let seed = wavy(seed_frames, phase);
        let mut motion = wavy(frames, phase + 0.4);
        // Lift the body now and then so that some frames are airborne.
        for t in 0..frames {
            if (t / 10) % 2 == 1 {
                motion[[t, 1]] += 40.0;
            }
        }
        let got = Measurer::new().measure(seed.view(), motion.view()).unwrap();
        let want = naive(&seed, &motion);
        close(&got.speed_mm_s, &want.speed_mm_s, "speed");
        close(
            &got.hip_height_change_mm,
            &want.hip_height_change_mm,
            "hip height",
        );
        close(&got.lean_change_deg, &want.lean_change_deg, "lean");
        assert_eq!(got.airborne, want.airborne);
        close(&got.lean_deg, &want.lean_deg, "lean_deg");
        close(&got.hip_height_mm, &want.hip_height_mm, "hip height");
        close(&got.lowest_foot_mm, &want.lowest_foot_mm, "lowest foot");
        assert_eq!(got.skating, want.skating);
        assert!(got.speed_mm_s.iter().all(|&v| v > 0.0));
    }
    // Some frames of the lifted motion are airborne and some not.
    let lifted = Array2::from_shape_fn(
        (80, 99),
        |(t, k)| if k == 1 { 30.0 } else { 0.0 * t as f64 },
    );
    let m = Measurer::new()
        .measure(Array2::zeros((5, 99)).view(), lifted.view())
        .unwrap();
    assert!(!m.airborne[0] && m.airborne[1]);
}

#[test]
fn a_still_pose_does_not_move_drift_or_float() {
    let still = Array2::<f64>::zeros((350, 99));
    let m = Measurer::new()
        .measure(still.slice(s![..50, ..]), still.slice(s![50.., ..]))
        .unwrap();
    assert!(m.speed_mm_s.iter().all(|&v| v == 0.0));
    assert!(m.hip_height_change_mm.iter().all(|&v| v == 0.0));
    assert!(m.lean_change_deg.iter().all(|&v| v == 0.0));
    assert!(m.airborne.iter().all(|&a| !a));
    let reference = ActionReference::from_parts(
        "walking",
        200.0,
        Array2::from_elem((3, 300), 10.0),
        Array2::from_elem((3, 300), 2.0),
    );
    let report = PlausibilityReport::new(std::slice::from_ref(&m), 300, &reference);
    for w in &report.speed_ratio.windows {
        assert_eq!(w.ratio, Some(0.0));
    }
    for w in &report.foot_contact.windows {
        assert_eq!(w.airborne_fraction, Some(0.0));
    }
    for w in &report.drift.windows {
        assert_eq!(w.hip_height_mm, Some(0.0));
        assert_eq!(w.hip_height_within_p95, Some(1.0));
        assert_eq!(w.hip_height_p95_mm, 10.0);
        assert_eq!(w.lean_p95_deg, 2.0);
    }
}

#[test]
fn a_known_lean_gives_its_angle() {
    // Upright seed; the first motion frame turns the root by 2 x 10° about z (each 25 Hz root
    // delta is applied twice), the rest keep it.
    let seed = Array2::<f64>::zeros((10, 99));
    let mut motion = Array2::<f64>::zeros((60, 99));
    motion[[0, 5]] = 10f64.to_radians();
    let m = Measurer::new().measure(seed.view(), motion.view()).unwrap();
    for &lean in &m.lean_change_deg {
        // expmap2rotmat's ε (float32 epsilon) scales the axis by θ / (θ + ε): 1e-6 relative.
        assert!((lean - 20.0).abs() < 1e-4, "{lean}");
    }
    // The rotation is about the hips: their height does not change.
    assert!(m.hip_height_change_mm.iter().all(|&h| h.abs() < 1e-9));
    // Spine bent forward by 30° about x from the first motion frame: the torso vector is
    // (0, 0.1, 0) + (0, 490.46, 0) · R_x(30°).
    let mut bent = Array2::<f64>::zeros((5, 99));
    for t in 0..5 {
        bent[[t, 36]] = 30f64.to_radians();
    }
    let m = Measurer::new().measure(seed.view(), bent.view()).unwrap();
    let long = 233.383263 + 257.077681;
    let r = motion_core::rotation::expmap2rotmat([30f64.to_radians(), 0.0, 0.0]);
    let v = vec_mul_mat3([0.0, long, 0.0], &r);
    let want = (v[0].hypot(v[2])).atan2(0.1 + v[1]).to_degrees();
    assert!(
        (m.lean_change_deg[0] - want).abs() < 1e-9,
        "{}",
        m.lean_change_deg[0]
    );
    assert!((want - 30.0).abs() < 0.01);
}

#[test]
fn rising_feet_are_airborne_after_the_clearance() {
    // The root rises 30 mm per 50 Hz source frame: 60 mm per 25 Hz motion frame.
    let seed = Array2::<f64>::zeros((10, 99));
    let mut motion = Array2::<f64>::zeros((100, 99));
    motion.column_mut(1).fill(30.0);
    let m = Measurer::new().measure(seed.view(), motion.view()).unwrap();
    for (i, h) in m.hip_height_change_mm.iter().enumerate() {
        assert!((h - 60.0 * (i + 1) as f64).abs() < 1e-9);
    }
    // Frame 0 is 60 mm up, frame 1 120 mm: airborne from frame 1 on.
    assert_eq!(m.airborne.iter().filter(|&&a| !a).count(), 1);
    let w = m.window(&horizon_windows(100)[0]).unwrap();
    assert!((w.airborne_fraction - 49.0 / 50.0).abs() < 1e-15);
    assert!((w.hip_height_mm - 3000.0).abs() < 1e-9);
    // A root translation does not move the body in its own frame.
    assert!(m.speed_mm_s.iter().all(|&v| v == 0.0));
}

#[test]
fn windows_follow_the_horizon() {
    let w = horizon_windows(300);
    assert_eq!(w.len(), 4);
    assert_eq!(
        w.iter()
            .map(|w| (w.start_frame, w.end_frame))
            .collect::<Vec<_>>(),
        [(0, 50), (50, 100), (100, 200), (200, 300)]
    );
    assert_eq!((w[3].start_s, w[3].end_s), (8.0, 12.0));
    let w = horizon_windows(150);
    assert_eq!(w.len(), 3);
    assert_eq!((w[2].start_s, w[2].end_s, w[2].end_frame), (4.0, 6.0, 150));
    assert_eq!(horizon_windows(50).len(), 1);
    assert_eq!(horizon_windows(51).len(), 2);
    // Long horizons: 12-20 s (cut at 16 s here), then 10 s windows to 60 s.
    let w = horizon_windows(400);
    assert_eq!(w.len(), 5);
    assert_eq!(
        (w[4].start_frame, w[4].end_frame, w[4].end_s),
        (300, 400, 16.0)
    );
    let w = horizon_windows(1500);
    assert_eq!(w.len(), 9);
    assert_eq!((w[8].start_frame, w[8].end_frame), (1250, 1500));
    assert_eq!(horizon_windows(5000).len(), 9);
    assert!(horizon_windows(0).is_empty());
}

#[test]
fn percentile_interpolates_like_numpy() {
    // numpy.percentile([4, 1, 3, 2], 95) = 3.85
    assert!((percentile(&mut [4.0, 1.0, 3.0, 2.0], 95.0) - 3.85).abs() < 1e-12);
    assert_eq!(percentile(&mut [7.0], 95.0), 7.0);
    assert!(percentile(&mut [], 95.0).is_nan());
}

#[test]
fn short_sequences_only_count_in_the_windows_they_cover() {
    let seed = wavy(50, 0.0);
    let long = wavy(300, 0.5);
    let short = wavy(120, 0.9);
    let pairs = [(seed.view(), long.view()), (seed.view(), short.view())];
    let measures = measure_sequences(&pairs).unwrap();
    let want = naive(&seed, &long);
    close(&measures[0].speed_mm_s, &want.speed_mm_s, "speed");
    close(&measures[0].lean_change_deg, &want.lean_change_deg, "lean");
    // p95 of per-window maxima: real windows with changes 0..=99 mm at every frame.
    let hip = Array2::from_shape_fn((100, 300), |(r, _)| r as f64);
    let reference = ActionReference::from_parts("walking", 100.0, hip.clone(), hip);
    let report = PlausibilityReport::new(&measures, 300, &reference);
    let counts: Vec<usize> = report
        .speed_ratio
        .windows
        .iter()
        .map(|w| w.sequences)
        .collect();
    assert_eq!(counts, [2, 2, 1, 1]);
    assert!((report.drift.windows[0].hip_height_p95_mm - 94.05).abs() < 1e-9);
    let first = &report.speed_ratio.windows[0];
    let want = (measures[0]
        .window(&horizon_windows(300)[0])
        .unwrap()
        .mean_speed_mm_s
        + measures[1]
            .window(&horizon_windows(300)[0])
            .unwrap()
            .mean_speed_mm_s)
        / 2.0;
    assert!((first.mean_speed_mm_s.unwrap() - want).abs() < 1e-12);
    assert!((first.ratio.unwrap() - want / 100.0).abs() < 1e-12);
    // A window nobody covers is null, not 0.
    let report = PlausibilityReport::new(&measures[1..], 300, &reference);
    assert_eq!(report.foot_contact.windows[3].airborne_fraction, None);
    assert_eq!(report.drift.windows[3].sequences, 0);
    let json = serde_json::to_value(&report).unwrap();
    assert_eq!(
        json["drift"]["windows"][3]["hip_height_mm"],
        serde_json::Value::Null
    );
    assert_eq!(json["speed_ratio"]["windows"][0]["start_s"], 0.0);
    assert_eq!(json["foot_contact"]["clearance_mm"], 100.0);
}

#[test]
fn bad_input_is_a_typed_error() {
    let mut m = Measurer::new();
    let ok = Array2::<f64>::zeros((5, 99));
    let narrow = Array2::<f64>::zeros((5, 98));
    assert!(matches!(
        m.measure(ok.view(), narrow.view()),
        Err(MetricError::ShapeMismatch { .. })
    ));
    assert!(matches!(
        m.measure(ok.slice(s![..0, ..]), ok.view()),
        Err(MetricError::Empty { .. })
    ));
    let mut bad = ok.clone();
    bad[[3, 40]] = f64::NAN;
    assert_eq!(
        m.measure(ok.view(), bad.view()),
        Err(MetricError::NonFinite {
            what: "motion".into(),
            index: vec![3, 40]
        })
    );
}

#[test]
fn a_grounded_clip_measures_on_the_floor_it_was_grounded_on() {
    // A seed recorded 12° off level (its first root rotation), walking with swinging legs: the
    // grounding levels it and the measure refits the floor on the levelled seed; the two floors
    // agree, so every grounded frame's lowest foot point is on the measured floor.
    use motion_core::formats::expmap_bvh::ExpMapTarget;
    use motion_core::grounding::{ground_expmap_clip, ClipSpec, GroundingConfig};
    let mut whole = wavy(300, 0.4);
    whole[[0, 3]] = 0.17;
    whole[[0, 5]] = 0.12;
    let spec = ClipSpec::new(
        ExpMapTarget::H36m,
        25.0,
        0..50,
        Some("walking"),
        GroundingConfig::default(),
    );
    let clip = ground_expmap_clip(whole.view(), &spec).unwrap();
    let m = Measurer::new()
        .measure(
            clip.frames.slice(s![..50, ..]),
            clip.frames.slice(s![50.., ..]),
        )
        .unwrap();
    let worst = m.lowest_foot_mm.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    assert!(
        worst < 2.0,
        "a grounded frame's lowest foot point {worst} mm off the floor"
    );
    // Raw, the same motion leaves the floor.
    let raw = Measurer::new()
        .measure(whole.slice(s![..50, ..]), whole.slice(s![50.., ..]))
        .unwrap();
    let raw_worst = raw
        .lowest_foot_mm
        .iter()
        .fold(0.0f64, |a, v| a.max(v.abs()));
    assert!(raw_worst > 50.0, "{raw_worst}");
}
