//! Posture realism: the Fréchet distance against closed forms and a Newton–Schulz square root,
//! the joints found on several rigs, the heading frame and elevations, and (with the H3.6M data
//! at `MOTION_DATA_DIR`, default `<repo>/../shared/data`; skipped with a visible message when
//! absent) real-vs-real values of walking and a synthetic "airplane arms" walk.
mod posture {
    use std::path::{Path, PathBuf};

    use motion_core::kinematics::channel_positions;
    use motion_core::protocol::dataset_dir;
    use motion_core::{Channel, Joint, Skeleton};
    use motion_metrics::posture::{
        elevation_emd_deg, frechet_distance, h36m_joints, h36m_positions, h36m_take_positions,
        symmetric_eigen, PostureJoints, PostureReference, PostureReport, PostureStats,
        ELEVATION_BINS, REFERENCE_SUBJECTS,
    };
    use motion_metrics::MetricError;
    use ndarray::{s, Array1, Array2, Array3};
    use rand::rngs::StdRng;
    use rand::{RngExt, SeedableRng};

    // ---------------------------------------------------------------- Fréchet distance

    fn random_spd(rng: &mut StdRng, n: usize) -> Array2<f64> {
        let a = Array2::from_shape_fn((n, n), |_| rng.random_range(-1.0..1.0));
        a.dot(&a.t()) + Array2::<f64>::eye(n) * 0.3
    }

    /// `sqrt(A)` of a matrix with positive real eigenvalues by the coupled Newton–Schulz
    /// iteration on `A / ||A||_F`.
    fn newton_schulz_sqrt(a: &Array2<f64>) -> Array2<f64> {
        let n = a.nrows();
        let c = a.iter().map(|x| x * x).sum::<f64>().sqrt();
        let eye = Array2::<f64>::eye(n);
        let mut y = a / c;
        let mut z = eye.clone();
        for _ in 0..200 {
            let t = (&eye * 3.0 - z.dot(&y)) * 0.5;
            let next = y.dot(&t);
            z = t.dot(&z);
            let change = (&next - &y).iter().map(|x| x.abs()).fold(0.0, f64::max);
            y = next;
            if change < 1e-16 {
                break;
            }
        }
        y * c.sqrt()
    }

    fn naive_frechet(
        mu1: &Array1<f64>,
        s1: &Array2<f64>,
        mu2: &Array1<f64>,
        s2: &Array2<f64>,
    ) -> f64 {
        let d = mu1 - mu2;
        let root = newton_schulz_sqrt(&s1.dot(s2));
        d.dot(&d) + s1.diag().sum() + s2.diag().sum() - 2.0 * root.diag().sum()
    }

    #[test]
    fn frechet_of_1d_gaussians_is_the_closed_form() {
        let f = |m1: f64, v1: f64, m2: f64, v2: f64| {
            frechet_distance(
                Array1::from(vec![m1]).view(),
                Array2::from_elem((1, 1), v1).view(),
                Array1::from(vec![m2]).view(),
                Array2::from_elem((1, 1), v2).view(),
            )
            .unwrap()
        };
        let expected = 1.4f64.powi(2) + (2f64.sqrt() - 0.5f64.sqrt()).powi(2);
        assert!((f(0.3, 2.0, -1.1, 0.5) - expected).abs() < 1e-12);
        assert!((f(0.3, 2.0, -1.1, 0.5) - f(-1.1, 0.5, 0.3, 2.0)).abs() < 1e-12);
        assert_eq!(f(1.0, 0.0, 1.0, 0.0), 0.0);
        assert!((f(0.0, 0.0, 0.0, 4.0) - 4.0).abs() < 1e-12);
    }

    #[test]
    fn frechet_of_diagonal_gaussians_is_the_closed_form() {
        let a = [0.5, 1.0, 2.0, 1e-6, 3.0];
        let b = [2.0, 1.0, 0.1, 4.0, 0.0];
        let mu1 = Array1::from(vec![0.0, 1.0, -2.0, 0.5, 3.0]);
        let mu2 = Array1::from(vec![1.0, 1.0, 0.0, 0.5, -1.0]);
        let got = frechet_distance(
            mu1.view(),
            Array2::from_diag(&Array1::from(a.to_vec())).view(),
            mu2.view(),
            Array2::from_diag(&Array1::from(b.to_vec())).view(),
        )
        .unwrap();
        let expected: f64 = (&mu1 - &mu2).mapv(|x| x * x).sum()
            + a.iter()
                .zip(&b)
                .map(|(x, y)| (x.sqrt() - y.sqrt()).powi(2))
                .sum::<f64>();
        assert!((got - expected).abs() < 1e-12, "{got} vs {expected}");
    }

    #[test]
    fn frechet_of_random_6d_gaussians_matches_newton_schulz() {
        let mut rng = StdRng::seed_from_u64(58);
        for _ in 0..20 {
            let (s1, s2) = (random_spd(&mut rng, 6), random_spd(&mut rng, 6));
            let mu1 = Array1::from_shape_fn(6, |_| rng.random_range(-1.0..1.0));
            let mu2 = Array1::from_shape_fn(6, |_| rng.random_range(-1.0..1.0));
            let got = frechet_distance(mu1.view(), s1.view(), mu2.view(), s2.view()).unwrap();
            let swapped = frechet_distance(mu2.view(), s2.view(), mu1.view(), s1.view()).unwrap();
            let expected = naive_frechet(&mu1, &s1, &mu2, &s2);
            assert!(
                (got - expected).abs() <= 1e-9 * expected.max(1.0),
                "{got} vs {expected}"
            );
            assert!((got - swapped).abs() <= 1e-9 * expected.max(1.0));
            let same = frechet_distance(mu1.view(), s1.view(), mu1.view(), s1.view()).unwrap();
            assert!(same < 1e-12, "{same}");
        }
    }

    #[test]
    fn frechet_rejects_bad_shapes_and_values() {
        let mu = Array1::<f64>::zeros(3);
        let s = Array2::<f64>::eye(3);
        let wide = Array2::<f64>::zeros((3, 4));
        assert!(matches!(
            frechet_distance(mu.view(), wide.view(), mu.view(), s.view()),
            Err(MetricError::ShapeMismatch { .. })
        ));
        let short = Array1::<f64>::zeros(2);
        assert!(frechet_distance(short.view(), s.view(), mu.view(), s.view()).is_err());
        let mut nan = s.clone();
        nan[[1, 2]] = f64::NAN;
        assert!(matches!(
            frechet_distance(mu.view(), s.view(), mu.view(), nan.view()),
            Err(MetricError::NonFinite { .. })
        ));
        let empty = Array2::<f64>::zeros((0, 0));
        let none = Array1::<f64>::zeros(0);
        assert!(matches!(
            frechet_distance(none.view(), empty.view(), none.view(), empty.view()),
            Err(MetricError::Empty { .. })
        ));
    }

    #[test]
    fn symmetric_eigen_reconstructs_the_matrix() {
        let mut rng = StdRng::seed_from_u64(3);
        let a = Array2::from_shape_fn((9, 9), |_| rng.random_range(-1.0..1.0));
        let a = &a + &a.t();
        let (values, vectors) = symmetric_eigen(a.view()).unwrap();
        assert!(values.windows(2).into_iter().all(|w| w[0] <= w[1]));
        let back = vectors.dot(&Array2::from_diag(&values)).dot(&vectors.t());
        let eye = vectors.t().dot(&vectors);
        for ((x, y), e) in back
            .iter()
            .zip(a.iter())
            .zip(eye.iter().zip(Array2::<f64>::eye(9).iter()))
        {
            assert!((x - y).abs() < 1e-12 && (e.0 - e.1).abs() < 1e-12);
        }
    }

    // ---------------------------------------------------------------- elevation histograms

    #[test]
    fn elevation_emd_moves_mass_by_bin_centres() {
        let mut a = [0.0; ELEVATION_BINS];
        let mut b = [0.0; ELEVATION_BINS];
        a[0] = 1.0;
        b[9] = 1.0;
        assert!((elevation_emd_deg(&a, &b) - 90.0).abs() < 1e-12);
        assert!((elevation_emd_deg(&b, &a) - 90.0).abs() < 1e-12);
        b = [0.0; ELEVATION_BINS];
        b[0] = 0.5;
        b[17] = 0.5;
        assert!((elevation_emd_deg(&a, &b) - 85.0).abs() < 1e-12);
        assert_eq!(elevation_emd_deg(&a, &a), 0.0);
    }

    // ---------------------------------------------------------------- joints on rigs

    fn names(s: &Skeleton, j: &PostureJoints) -> Vec<String> {
        j.position_joints()
            .iter()
            .map(|&k| s.joint(k).name.clone())
            .collect()
    }

    #[test]
    fn h36m_posture_joints_are_the_named_parts() {
        let s = Skeleton::h36m();
        let j = h36m_joints();
        assert_eq!(j, PostureJoints::find(&s).unwrap());
        assert_eq!(s.joint(j.pelvis).name, "Hips");
        assert_eq!(
            names(&s, &j),
            [
                "RightUpLeg",
                "LeftUpLeg",
                "RightLeg",
                "LeftLeg",
                "RightFoot",
                "LeftFoot",
                "Neck",
                "HeadSite",
                "LeftArm",
                "RightArm",
                "LeftForeArm",
                "RightForeArm",
                "LeftHand",
                "RightHand"
            ]
        );
        assert!((j.leg_length - 897.1).abs() < 0.5);
        assert_eq!(j.forward_sign, 1.0);
        assert_eq!(j.feature_dims(), 66);
        assert_eq!(j.feature_names(&s).len(), 66);
    }

    #[test]
    fn cmu_exp_map_posture_joints_are_found_by_lengths() {
        // Unnamed joints (joint_00 ..): the elbow comes from the bone lengths.
        let s = Skeleton::cmu();
        let j = PostureJoints::find(&s).unwrap();
        assert_eq!((j.pelvis, j.torso_top, j.head), (0, 15, Some(19)));
        let mut arms: Vec<[usize; 3]> = j.arms.iter().map(|a| [a.start, a.middle, a.end]).collect();
        arms.sort();
        assert_eq!(arms, [[21, 22, 23], [30, 31, 32]]);
        assert_eq!(j.feature_dims(), 66);
    }

    /// A Mixamo-like rig in a T-pose facing `facing` (+1: +z, −1: −z), cm, optionally with a root
    /// joint on the floor above the hips and with names stripped (`j00`, `j01`, ...).
    fn t_pose_rig(facing: f64, floor_root: bool, named: bool) -> Skeleton {
        let f = facing;
        let mut spec: Vec<(String, Option<usize>, [f64; 3])> = Vec::new();
        let mut add = |name: String, parent: Option<usize>, offset: [f64; 3]| {
            spec.push((name, parent, offset));
            spec.len() - 1
        };
        let hips = if floor_root {
            let root = add("Root".into(), None, [0.0; 3]);
            add("Hips".into(), Some(root), [0.0, 95.0, 0.0])
        } else {
            add("Hips".into(), None, [0.0; 3])
        };
        for (side, x) in [("Left", 1.0), ("Right", -1.0)] {
            let up = add(format!("{side}UpLeg"), Some(hips), [9.0 * x * f, -5.0, 0.0]);
            let leg = add(format!("{side}Leg"), Some(up), [0.0, -44.0, 0.0]);
            let foot = add(format!("{side}Foot"), Some(leg), [0.0, -42.0, 0.0]);
            let toe = add(format!("{side}ToeBase"), Some(foot), [0.0, -4.0, 12.0 * f]);
            add(format!("{side}Toe_End"), Some(toe), [0.0, 0.0, 6.0 * f]);
        }
        let spine = add("Spine".into(), Some(hips), [0.0, 10.0, 0.0]);
        let spine1 = add("Spine1".into(), Some(spine), [0.0, 12.0, 0.0]);
        let spine2 = add("Spine2".into(), Some(spine1), [0.0, 14.0, 0.0]);
        let neck = add("Neck".into(), Some(spine2), [0.0, 16.0, 0.0]);
        let head = add("Head".into(), Some(neck), [0.0, 10.0, 0.0]);
        add("HeadTop_End".into(), Some(head), [0.0, 18.0, 0.0]);
        for (side, x) in [("Left", 1.0), ("Right", -1.0)] {
            let x = x * f;
            let mut parent = spine2;
            for (name, offset) in [
                ("Shoulder", [6.0 * x, 10.0, 0.0]),
                ("Arm", [12.0 * x, 0.0, 0.0]),
                ("ForeArm", [27.0 * x, 0.0, 0.0]),
                ("Hand", [26.0 * x, 0.0, 0.0]),
                ("HandMiddle1", [9.0 * x, 0.0, 0.0]),
                ("HandMiddle_End", [4.0 * x, 0.0, 0.0]),
            ] {
                parent = add(format!("{side}{name}"), Some(parent), offset);
            }
        }
        let joints = spec
            .into_iter()
            .enumerate()
            .map(|(i, (name, parent, offset))| {
                let name = if named { name } else { format!("j{i:02}") };
                let channels = if parent.is_none() {
                    vec![
                        Channel::Xposition,
                        Channel::Yposition,
                        Channel::Zposition,
                        Channel::Zrotation,
                        Channel::Xrotation,
                        Channel::Yrotation,
                    ]
                } else {
                    vec![Channel::Zrotation, Channel::Xrotation, Channel::Yrotation]
                };
                Joint::new(name, parent, offset, channels)
            })
            .collect();
        Skeleton::new(joints).unwrap()
    }

    #[test]
    fn posture_joints_of_other_rigs_named_or_not() {
        let expected = [
            "RightUpLeg",
            "LeftUpLeg",
            "RightLeg",
            "LeftLeg",
            "RightFoot",
            "LeftFoot",
            "Neck",
            "HeadTop_End",
            "RightArm",
            "LeftArm",
            "RightForeArm",
            "LeftForeArm",
            "RightHand",
            "LeftHand",
        ];
        for floor_root in [false, true] {
            let named = t_pose_rig(1.0, floor_root, true);
            let j = PostureJoints::find(&named).unwrap();
            assert_eq!(names(&named, &j), expected);
            assert_eq!(named.joint(j.pelvis).name, "Hips");
            assert_eq!(j.forward_sign, 1.0);
            // The same rig without names: the torso top is where the arms branch (Spine2), the
            // elbows come from the bone lengths.
            let plain = t_pose_rig(1.0, floor_root, false);
            let k = PostureJoints::find(&plain).unwrap();
            assert_eq!(
                (k.legs, k.arms, k.head, k.pelvis),
                (j.legs, j.arms, j.head, j.pelvis)
            );
            assert_eq!(Some(k.torso_top), named.joint_index("Spine2"));
        }
        let back = PostureJoints::find(&t_pose_rig(-1.0, false, true)).unwrap();
        assert_eq!(back.forward_sign, -1.0);
    }

    #[test]
    fn posture_joints_refuse_a_rig_without_arms() {
        let j = |name: &str, parent: Option<usize>, offset: [f64; 3]| {
            Joint::new(name, parent, offset, vec![Channel::Xrotation])
        };
        let s = Skeleton::new(vec![
            j("hips", None, [0.0; 3]),
            j("l_thigh", Some(0), [10.0, -5.0, 0.0]),
            j("l_shin", Some(1), [0.0, -40.0, 0.0]),
            j("l_foot", Some(2), [0.0, -40.0, 0.0]),
            j("r_thigh", Some(0), [-10.0, -5.0, 0.0]),
            j("r_shin", Some(4), [0.0, -40.0, 0.0]),
            j("r_foot", Some(5), [0.0, -40.0, 0.0]),
            j("neck", Some(0), [0.0, 50.0, 0.0]),
            j("head", Some(7), [0.0, 20.0, 0.0]),
        ])
        .unwrap();
        let e = PostureJoints::find(&s).unwrap_err();
        assert!(e.to_string().contains("no two arms"), "{e}");
    }

    // ---------------------------------------------------------------- features and elevations

    /// 25 Hz H3.6M frames with every joint angle swinging (amplitude `amp` rad), the root turning.
    fn swinging(frames: usize, amp: f64, phase: f64) -> Array2<f64> {
        Array2::from_shape_fn((frames, 99), |(t, d)| match d {
            0..=2 => 10.0,
            3..=5 => 0.02,
            _ => amp * (0.23 * t as f64 + phase + 1.7 * d as f64).sin(),
        })
    }

    #[test]
    fn posture_features_ignore_yaw_and_translation() {
        let s = Skeleton::h36m();
        let j = h36m_joints();
        let positions = h36m_positions(swinging(40, 0.5, 0.0).view(), None).unwrap();
        let (mut a, mut b) = (vec![0.0; 66], vec![0.0; 66]);
        for frame in positions.outer_iter() {
            let p: Vec<[f64; 3]> = frame.outer_iter().map(|r| [r[0], r[1], r[2]]).collect();
            let (c, sn) = (1.3f64.cos(), 1.3f64.sin());
            let moved: Vec<[f64; 3]> = p
                .iter()
                .map(|q| {
                    [
                        c * q[0] + sn * q[2] + 500.0,
                        q[1] - 20.0,
                        -sn * q[0] + c * q[2] - 70.0,
                    ]
                })
                .collect();
            let e1 = j.frame_features(&p, &mut a);
            let e2 = j.frame_features(&moved, &mut b);
            for (x, y) in a.iter().zip(&b) {
                assert!((x - y).abs() < 1e-12);
            }
            assert!((e1.upper_arm_deg[0] - e2.upper_arm_deg[0]).abs() < 1e-9);
        }
        // The rest pose: the pelvis faces +z, hips on ±x, arms straight up, legs straight down.
        let rest = h36m_positions(Array2::zeros((1, 99)).view(), None).unwrap();
        let p: Vec<[f64; 3]> = rest
            .index_axis(ndarray::Axis(0), 0)
            .outer_iter()
            .map(|r| [r[0], r[1], r[2]])
            .collect();
        let e = j.frame_features(&p, &mut a);
        let hip = s.joint(j.legs[0].start).offset[0] / j.leg_length;
        assert!((a[0] - hip).abs() < 1e-12 && a[1].abs() < 1e-12 && a[2].abs() < 1e-12);
        assert_eq!(e.upper_arm_deg, [180.0, 180.0]);
        assert_eq!(e.thigh_deg, [0.0, 0.0]);
        // The thigh direction (feature slots after 14 positions and 4 arm directions) points down.
        assert!((a[3 * 18 + 1] + 1.0).abs() < 1e-12);
    }

    #[test]
    fn posture_reference_against_itself_is_zero_and_merges_exactly() {
        let j = h36m_joints();
        let real = h36m_positions(swinging(300, 0.3, 0.0).view(), None).unwrap();
        let reference = PostureReference::from_takes(&j, &[real.view()]).unwrap();
        let r = reference.measure(&[real.view()]).unwrap();
        assert!(r.frechet < 1e-9, "{}", r.frechet);
        assert_eq!(
            (r.arm_elevation_emd_deg, r.thigh_elevation_emd_deg),
            (0.0, 0.0)
        );
        assert!(r.arms_above_real_p99 < 0.01 + 1.0 / 300.0);
        assert_eq!((r.frames, r.real_frames), (300, 300));
        // Two halves merged = the whole (pooled windows).
        let halves = reference
            .measure(&[real.slice(s![..120, .., ..]), real.slice(s![120.., .., ..])])
            .unwrap();
        assert!((halves.frechet - r.frechet).abs() < 1e-9);
        let mut whole = PostureStats::new(&j);
        whole.push_frames(real.view()).unwrap();
        let mut parts = PostureStats::new(&j);
        let mut second = PostureStats::new(&j);
        parts.push_frames(real.slice(s![..77, .., ..])).unwrap();
        second.push_frames(real.slice(s![77.., .., ..])).unwrap();
        parts.merge(&second).unwrap();
        for (x, y) in whole.covariance().iter().zip(parts.covariance().iter()) {
            assert!((x - y).abs() < 1e-12);
        }
        for (x, y) in whole.mean().iter().zip(parts.mean()) {
            assert!((x - y).abs() < 1e-12);
        }
        // A different motion scores worse on each measure.
        let other = h36m_positions(swinging(300, 0.9, 2.0).view(), None).unwrap();
        let o = reference.measure(&[other.view()]).unwrap();
        assert!(o.frechet > 0.1 && o.arm_elevation_emd_deg > 5.0, "{o:?}");
    }

    #[test]
    fn posture_measure_rejects_bad_input() {
        let j = h36m_joints();
        let real = h36m_positions(swinging(30, 0.3, 0.0).view(), None).unwrap();
        let reference = PostureReference::from_takes(&j, &[real.view()]).unwrap();
        let few = Array3::<f64>::zeros((5, 20, 3));
        assert!(matches!(
            reference.measure(&[few.view()]),
            Err(MetricError::InvalidConfig(_))
        ));
        let mut nan = real.clone();
        nan[[3, 7, 1]] = f64::NAN;
        assert!(matches!(
            reference.measure(&[nan.view()]),
            Err(MetricError::NonFinite { .. })
        ));
        assert!(matches!(
            reference.measure(&[]),
            Err(MetricError::Empty { .. })
        ));
        assert!(PostureReference::from_takes(&j, &[]).is_err());
    }

    // ---------------------------------------------------------------- data

    fn data_root() -> PathBuf {
        std::env::var_os("MOTION_DATA_DIR")
            .map(PathBuf::from)
            .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"))
    }

    fn dataset() -> Option<PathBuf> {
        let dataset = dataset_dir(&data_root());
        if dataset.join("S5/walking_1.txt.gz").is_file() {
            Some(dataset)
        } else {
            eprintln!(
                "SKIPPED: posture realism on H3.6M needs the data at {} (set MOTION_DATA_DIR)",
                dataset.display()
            );
            None
        }
    }

    /// The arms of `positions` rotated about their shoulders, frame by frame, so that each upper
    /// arm points straight out to its side at shoulder height (the forearm keeps its bend).
    fn airplane_arms(
        skeleton: &Skeleton,
        j: &PostureJoints,
        positions: &Array3<f64>,
    ) -> Array3<f64> {
        let mut out = positions.clone();
        let v = |p: &Array3<f64>, t: usize, k: usize| [p[[t, k, 0]], p[[t, k, 1]], p[[t, k, 2]]];
        for t in 0..positions.dim().0 {
            for arm in &j.arms {
                let s = v(positions, t, arm.start);
                let u = sub(v(positions, t, arm.middle), s);
                let side = sub(s, v(positions, t, j.torso_top));
                let h = side[0].hypot(side[2]);
                let target = [side[0] / h, 0.0, side[2] / h];
                let r = rotation_between(unit(u), target);
                for k in 0..skeleton.len() {
                    if k != arm.start && is_under(skeleton, k, arm.start) {
                        let q = mat_vec(&r, sub(v(positions, t, k), s));
                        for c in 0..3 {
                            out[[t, k, c]] = s[c] + q[c];
                        }
                    }
                }
            }
        }
        out
    }

    fn is_under(s: &Skeleton, mut k: usize, a: usize) -> bool {
        loop {
            if k == a {
                return true;
            }
            match s.parent(k) {
                Some(p) => k = p,
                None => return false,
            }
        }
    }

    fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }

    fn unit(a: [f64; 3]) -> [f64; 3] {
        let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        a.map(|x| x / l)
    }

    /// The rotation taking unit `a` to unit `b` (Rodrigues).
    fn rotation_between(a: [f64; 3], b: [f64; 3]) -> [[f64; 3]; 3] {
        let k = [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ];
        let c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let f = 1.0 / (1.0 + c);
        let kx = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]];
        let mut r = [[0.0; 3]; 3];
        for i in 0..3 {
            for m in 0..3 {
                let kk: f64 = (0..3).map(|l| kx[i][l] * kx[l][m]).sum();
                r[i][m] = f64::from(u8::from(i == m)) + kx[i][m] + kk * f;
            }
        }
        r
    }

    fn mat_vec(r: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|i| r[i][0] * v[0] + r[i][1] * v[1] + r[i][2] * v[2])
    }

    fn line(what: &str, r: &PostureReport) -> String {
        format!(
            "{what:<34} frames {:5}  frechet {:8.4}  arm EMD {:6.2}°  thigh EMD {:6.2}°  arms > real p99 ({:.1}°) {:.3}",
            r.frames,
            r.frechet,
            r.arm_elevation_emd_deg,
            r.thigh_elevation_emd_deg,
            r.real_arm_elevation_p99_deg,
            r.arms_above_real_p99
        )
    }

    #[test]
    fn posture_walking_real_vs_real_and_airplane_arms() {
        let Some(dataset) = dataset() else { return };
        let skeleton = Skeleton::h36m();
        let j = h36m_joints();
        let mut subjects: Vec<&str> = vec!["S5"];
        subjects.extend(REFERENCE_SUBJECTS);
        // Positions and statistics per subject (both takes).
        let takes: Vec<Vec<(PathBuf, Array3<f64>)>> = subjects
            .iter()
            .map(|s| h36m_take_positions(&dataset, "walking", &[s]).unwrap())
            .collect();
        let stats: Vec<PostureStats> = takes
            .iter()
            .map(|t| {
                let mut st = PostureStats::new(&j);
                for (_, p) in t {
                    st.push_frames(p.view()).unwrap();
                }
                st
            })
            .collect();
        let reference_of = |left_out: usize| {
            let mut all = PostureStats::new(&j);
            for (k, st) in stats.iter().enumerate() {
                if k != left_out {
                    all.merge(st).unwrap();
                }
            }
            PostureReference::from_stats(all).unwrap()
        };
        // The reference of the six training subjects; S5 measured against it.
        let reference = reference_of(0);
        let s5 = &takes[0];
        let s5_views: Vec<_> = s5.iter().map(|(_, p)| p.view()).collect();
        let real = reference.measure(&s5_views).unwrap();
        eprintln!(
            "walking: reference S1/S6/S7/S8/S9/S11, {} frames",
            reference.frames()
        );
        eprintln!("{}", line("real vs real: S5, both takes", &real));
        for (path, p) in s5 {
            let name = path.file_name().unwrap().to_string_lossy().to_string();
            eprintln!(
                "{}",
                line(
                    &format!("real vs real: S5 {name}"),
                    &reference.measure(&[p.view()]).unwrap()
                )
            );
        }
        // The band: each subject measured against the other six.
        for (k, s) in subjects.iter().enumerate() {
            let r = reference_of(k).measure_stats(&stats[k]).unwrap();
            eprintln!(
                "{}",
                line(&format!("leave-one-out: {s} vs the other six"), &r)
            );
        }
        // Airplane arms on S5's real walks.
        let planes: Vec<Array3<f64>> = s5
            .iter()
            .map(|(_, p)| airplane_arms(&skeleton, &j, p))
            .collect();
        let plane_views: Vec<_> = planes.iter().map(|p| p.view()).collect();
        let plane = reference.measure(&plane_views).unwrap();
        eprintln!("{}", line("airplane arms on S5's walks", &plane));
        eprintln!(
            "real arm histogram      {:?}",
            reference
                .stats()
                .arm_elevation_histogram()
                .map(|x| (x * 1000.0).round() / 1000.0)
        );
        eprintln!(
            "S5 arm histogram        {:?}",
            real.arm_elevation_histogram
                .map(|x| (x * 1000.0).round() / 1000.0)
        );
        eprintln!(
            "airplane arm histogram  {:?}",
            plane
                .arm_elevation_histogram
                .map(|x| (x * 1000.0).round() / 1000.0)
        );
        println!("{}", serde_json::to_string(&real).unwrap());

        // Real-vs-real is small; the airplane walk is clearly worse on all three measures (the
        // legs are untouched: the thigh distance is the real one).
        assert!(real.arms_above_real_p99 < 0.1, "{real:?}");
        assert!(plane.arms_above_real_p99 > 0.9, "{plane:?}");
        assert!(
            plane.arm_elevation_emd_deg > real.arm_elevation_emd_deg + 40.0,
            "{plane:?}"
        );
        assert!(
            plane.frechet > 2.0 * real.frechet + 0.1,
            "{plane:?} vs {real:?}"
        );
        assert!((plane.thigh_elevation_emd_deg - real.thigh_elevation_emd_deg).abs() < 1e-12);
    }

    #[test]
    fn posture_joints_of_the_cmu_locomotion_bvh_rigs() {
        let root = data_root().join("cmu_locomotion");
        let files = ["16_08.bvh", "131_01.bvh"];
        if !files.iter().all(|f| root.join(f).is_file()) {
            eprintln!(
                "SKIPPED: the BVH rigs need {} (set MOTION_DATA_DIR)",
                root.display()
            );
            return;
        }
        let expected = [
            ["thorax", "lhumerus", "lradius", "lhand"],
            ["Neck", "LeftShoulder", "LeftElbow", "LeftWrist"],
        ];
        for (file, want) in files.iter().zip(expected) {
            let bvh = motion_core::formats::bvh::read_bvh(root.join(file)).unwrap();
            let s = &bvh.skeleton;
            let j = PostureJoints::find(s).unwrap();
            let arm = j
                .arms
                .iter()
                .find(|a| s.joint(a.middle).name.to_ascii_lowercase().starts_with('l'))
                .unwrap();
            let got =
                [j.torso_top, arm.start, arm.middle, arm.end].map(|k| s.joint(k).name.clone());
            assert_eq!(got, want, "{file}");
            let positions = channel_positions(s, bvh.frames.view()).unwrap();
            let half = positions.dim().0 / 2;
            let reference =
                PostureReference::from_takes(&j, &[positions.slice(s![..half, .., ..])]).unwrap();
            let r = reference
                .measure(&[positions.slice(s![half.., .., ..])])
                .unwrap();
            eprintln!("{}", line(&format!("{file}: second half vs first"), &r));
            assert!(r.frechet.is_finite() && r.arm_elevation_emd_deg < 30.0);
        }
    }
}
