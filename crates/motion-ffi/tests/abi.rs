//! The C ABI called as C would: status codes, `motion_last_error`, NULL handling, poses.
use std::ffi::{CStr, CString};
use std::ptr::{null, null_mut};

use motion_ffi::*;

fn last_error() -> String {
    unsafe { CStr::from_ptr(motion_last_error()) }
        .to_string_lossy()
        .into_owned()
}

fn c(s: &str) -> CString {
    CString::new(s).unwrap()
}

#[test]
fn statuses_messages_and_poses() {
    unsafe {
        let fixture = c(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/fixtures/parity/vgru_d.safetensors"
        ));
        let model = motion_model_load(fixture.as_ptr());
        assert!(!model.is_null(), "{}", last_error());
        assert_eq!(motion_model_joint_count(model), 32);
        assert_eq!(
            CStr::from_ptr(motion_model_joint_name(model, 0)).to_str(),
            Ok("Hips")
        );
        assert!(motion_model_joint_name(model, 32).is_null());
        assert_eq!(motion_model_action_index(model, c("walking").as_ptr()), 12);
        assert_eq!(
            motion_model_action_index(model, c("moonwalk").as_ptr()),
            MotionStatus::BadInput as i32
        );
        assert!(
            last_error().contains("walking"),
            "lists the valid actions: {}",
            last_error()
        );
        assert_eq!(
            motion_model_action_index(null(), c("walking").as_ptr()),
            MotionStatus::InvalidArgument as i32
        );

        let generator = motion_generator_new(model, 3);
        let (mut p, mut r, mut q) = ([0f32; 3], [0f32; 4], vec![0f32; 4 * 32]);
        let (pp, rp, qp) = (p.as_mut_ptr(), r.as_mut_ptr(), q.as_mut_ptr());
        let step = |g| motion_generator_step_pose(g, pp, rp, qp, 32);
        assert_eq!(step(generator), MotionStatus::State as i32);
        assert!(last_error().contains("before a start"), "{}", last_error());
        let frames = vec![0.1f32; 10 * 99];
        // Grounding on by default; switched off (and back) for the next start, NULL refused.
        assert_eq!(motion_generator_set_grounding(generator, 0), 0);
        assert_eq!(motion_generator_set_grounding(generator, 1), 0);
        assert_eq!(
            motion_generator_set_grounding(null_mut(), 0),
            MotionStatus::InvalidArgument as i32
        );
        assert_eq!(
            motion_generator_start_frames(
                generator,
                frames.as_ptr(),
                10,
                98,
                c("walking").as_ptr()
            ),
            MotionStatus::InvalidArgument as i32
        );
        assert_eq!(
            motion_generator_start_frames(generator, frames.as_ptr(), 5, 99, c("walking").as_ptr()),
            MotionStatus::BadInput as i32
        );
        assert_eq!(
            motion_generator_start_frames(
                generator,
                frames.as_ptr(),
                10,
                99,
                c("walking").as_ptr()
            ),
            0,
            "{}",
            last_error()
        );
        for _ in 0..30 {
            assert_eq!(step(generator), 0, "{}", last_error());
        }
        let norm = |q: &[f32]| q.iter().map(|v| v * v).sum::<f32>().sqrt();
        assert!((norm(&r) - 1.0).abs() < 1e-5);
        assert!(q.chunks(4).all(|x| (norm(x) - 1.0).abs() < 1e-5));
        assert_eq!(
            r,
            [q[0], q[1], q[2], q[3]],
            "entry 0 is the root's rotation"
        );
        assert_eq!(
            motion_generator_set_action(generator, c("eating").as_ptr()),
            0
        );
        assert_eq!(
            motion_generator_advance_pose(
                generator,
                1.0 / 60.0,
                p.as_mut_ptr(),
                r.as_mut_ptr(),
                q.as_mut_ptr(),
                31
            ),
            MotionStatus::InvalidArgument as i32
        );
        assert_eq!(
            motion_generator_advance_pose(
                generator,
                1.0 / 60.0,
                null_mut(),
                r.as_mut_ptr(),
                q.as_mut_ptr(),
                32
            ),
            MotionStatus::InvalidArgument as i32
        );
        motion_generator_free(generator);
        motion_generator_free(null_mut());
        motion_model_free(model);
        motion_model_free(null_mut());
    }
}

/// Exp-map files given to `motion_generator_start_bvh` (which reads any seed file) are read at
/// the front ends' one rate, `motion_core::seed::DEFAULT_EXPMAP_FILE_FPS` (50 Hz), as the CLI and
/// Python read them: 19 rows at 50 Hz are 10 frames at the fixture's 25 Hz (its seed length),
/// 18 rows are 9 (too few).
#[test]
fn expmap_seed_files_are_read_at_the_front_ends_rate() {
    let dir = std::env::temp_dir().join(format!("motion-ffi-rate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let row = vec!["0.01"; 99].join(",");
    unsafe {
        let fixture = c(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/fixtures/parity/vgru_d.safetensors"
        ));
        let model = motion_model_load(fixture.as_ptr());
        let generator = motion_generator_new(model, 1);
        for (rows, expected) in [(19, 0), (18, MotionStatus::BadInput as i32)] {
            let path = dir.join(format!("seed_{rows}.txt"));
            std::fs::write(&path, vec![row.as_str(); rows].join("\n")).unwrap();
            let status = motion_generator_start_bvh(
                generator,
                c(path.to_str().unwrap()).as_ptr(),
                c("walking").as_ptr(),
            );
            assert_eq!(status, expected, "{rows} rows: {}", last_error());
            if status != 0 {
                assert!(last_error().contains("9 seed frames"), "{}", last_error());
            }
        }
        motion_generator_free(generator);
        motion_model_free(model);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A goal steers the character (its root goes the goal's way); a non-finite goal is refused;
/// clearing it is accepted.
#[test]
fn goals_steer_and_bad_goals_are_refused() {
    unsafe {
        let fixture = c(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/fixtures/parity/vgru_d.safetensors"
        ));
        let model = motion_model_load(fixture.as_ptr());
        let generator = motion_generator_new(model, 1);
        let frames = vec![0.05f32; 10 * 99];
        assert_eq!(
            motion_generator_start_frames(
                generator,
                frames.as_ptr(),
                10,
                99,
                c("walking").as_ptr()
            ),
            0,
            "{}",
            last_error()
        );
        assert_eq!(
            motion_generator_set_goal(generator, f32::NAN, 0.0, 0.0),
            MotionStatus::InvalidArgument as i32
        );
        assert!(last_error().contains("finite"), "{}", last_error());
        assert_eq!(motion_generator_set_goal(generator, 1.0, 0.0, 1.5), 0);
        let (mut p, mut r, mut q) = ([0f32; 3], [0f32; 4], vec![0f32; 4 * 32]);
        motion_generator_advance_pose(
            generator,
            0.0,
            p.as_mut_ptr(),
            r.as_mut_ptr(),
            q.as_mut_ptr(),
            32,
        );
        let start = p;
        for _ in 0..120 {
            assert_eq!(
                motion_generator_advance_pose(
                    generator,
                    1.0 / 60.0,
                    p.as_mut_ptr(),
                    r.as_mut_ptr(),
                    q.as_mut_ptr(),
                    32
                ),
                0,
                "{}",
                last_error()
            );
        }
        // The random-weight fixture's stride is whatever it is; its direction is the goal's (+x).
        let moved = (p[0] - start[0], p[2] - start[2]);
        assert!(
            moved.0 >= 0.0 && moved.1.abs() <= moved.0.abs() + 0.05,
            "{moved:?}"
        );
        assert_eq!(motion_generator_clear_goal(generator), 0);
        assert_eq!(
            motion_generator_set_goal(null_mut(), 0.0, 0.0, 0.0),
            MotionStatus::InvalidArgument as i32
        );
        motion_generator_free(generator);
        motion_model_free(model);
    }
}

/// The shipped motion-matching database is steered as a model is: loaded by
/// `motion_model_load`, started from a BVH seed on another rig (the H3.6M example walk,
/// retargeted onto the database's CMU rig), and sent along +x by `motion_generator_set_goal`
/// at 60 Hz ticks: it goes there on the floor.
#[test]
fn the_shipped_database_is_steered_by_goals() {
    unsafe {
        let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
        let db = c(&format!("{root}/weights/matching_cmu.safetensors"));
        let model = motion_model_load(db.as_ptr());
        assert!(!model.is_null(), "{}", last_error());
        let joints = motion_model_joint_count(model);
        assert!(joints > 20, "{joints} joints");
        // A database has no actions.
        assert!(motion_model_action_index(model, c("walking").as_ptr()) < 0);
        let generator = motion_generator_new(model, 1);
        assert!(!generator.is_null(), "{}", last_error());
        let seed = c(&format!("{root}/examples/walk_seed.bvh"));
        assert_eq!(
            motion_generator_start_bvh(generator, seed.as_ptr(), null()),
            0,
            "{}",
            last_error()
        );
        // Exp-map frames are for learned models.
        let frames = vec![0.0f32; 10 * 99];
        assert_eq!(
            motion_generator_start_frames(generator, frames.as_ptr(), 10, 99, null()),
            MotionStatus::BadInput as i32
        );
        assert!(last_error().contains("database"), "{}", last_error());
        assert_eq!(
            motion_generator_set_goal(generator, 1.2, 0.0, std::f32::consts::FRAC_PI_2),
            0
        );
        let (mut p, mut r, mut q) = ([0f32; 3], [0f32; 4], vec![0f32; 4 * joints]);
        assert_eq!(
            motion_generator_advance_pose(
                generator,
                0.0,
                p.as_mut_ptr(),
                r.as_mut_ptr(),
                q.as_mut_ptr(),
                joints
            ),
            0,
            "{}",
            last_error()
        );
        let start = p;
        let (mut low, mut high) = (f32::INFINITY, f32::NEG_INFINITY);
        for _ in 0..360 {
            assert_eq!(
                motion_generator_advance_pose(
                    generator,
                    1.0 / 60.0,
                    p.as_mut_ptr(),
                    r.as_mut_ptr(),
                    q.as_mut_ptr(),
                    joints
                ),
                0,
                "{}",
                last_error()
            );
            low = low.min(p[1]);
            high = high.max(p[1]);
        }
        // 6 s toward +x at 1.2 m/s: most of 7.2 m that way, little across, hips at a
        // standing person's height all along.
        let moved = (p[0] - start[0], p[2] - start[2]);
        assert!(moved.0 > 4.0 && moved.1.abs() < 1.5, "{moved:?}");
        assert!(
            low > start[1] - 0.25 && high < start[1] + 0.25,
            "{low} {high}"
        );
        motion_generator_free(generator);
        motion_model_free(model);
    }
}
