//! The standard H3.6M evaluation protocol (`h36m.md`): the 15 actions, the fixed test windows on
//! subject 5 (8 per action, 25 Hz frame indices), loading a window's seed and ground truth from the
//! data directory, the protocol's Euler conversion of exp-map sequences and the zero-velocity
//! baselines (the angle protocols' and the root-held one for world positions).
//!
//! The window table is `h36m_test_windows.csv`, embedded as code. It was produced with the
//! protocol's fixed random generator (seed 1234567890, `randint(16, T - 150)` alternating
//! subactions 1 and 2); it is missing for the actions whose S5 files could not be obtained.
use std::path::{Path, PathBuf};

use ndarray::{s, Array2, Array3, ArrayView2, ArrayView3, Axis};

use crate::error::FormatError;
use crate::formats::h36m_text::{downsample_protocol, read_expmap_text};
use crate::root::{integrate_root_kept, RootPose};
use crate::rotation::expmap_frame_to_euler_protocol;

pub use crate::skeleton::H36M_ACTIONS as ACTIONS;

pub mod sampler;
pub mod validation;
pub use validation::WindowSet;

/// Frames the model observes before it predicts (2 s at 25 Hz).
pub const SEED_FRAMES: usize = 50;
/// Frames predicted in the long-term protocol (4 s at 25 Hz).
pub const LONG_TERM_HORIZON: usize = 100;
/// The test subject.
pub const TEST_SUBJECT: &str = "S5";
/// Every subject of the data release, training subjects and [`TEST_SUBJECT`] (h36m.md).
pub const SUBJECTS: [&str; 7] = ["S1", "S5", "S6", "S7", "S8", "S9", "S11"];
/// The protocol's frame rate divided into the data's: each 25 Hz frame's root delta spans this
/// many 50 Hz source frames when the root is integrated ([`crate::root`]).
pub const ROOT_STEP_25HZ: usize = 2;
/// The actions without test windows: their S5 files are absent from the data release here.
pub const ACTIONS_WITHOUT_WINDOWS: [&str; 4] =
    ["directions", "discussion", "sittingdown", "waiting"];

/// One fixed test window, in 25 Hz frame indices of `S5/{action}_{subaction}`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TestWindow {
    /// The action.
    pub action: &'static str,
    /// The window's number within its action (0..8).
    pub sample: usize,
    /// The take: 1 or 2.
    pub subaction: u8,
    /// First seed frame; the seed is `[seed_start, predict_start)`.
    pub seed_start: usize,
    /// First predicted frame.
    pub predict_start: usize,
    /// Frames of the file at 25 Hz (a check that the data is the release the table was made from).
    pub even_frames_in_file: usize,
}

const fn w(
    action: &'static str,
    sample: usize,
    subaction: u8,
    seed_start: usize,
    predict_start: usize,
    even_frames_in_file: usize,
) -> TestWindow {
    TestWindow {
        action,
        sample,
        subaction,
        seed_start,
        predict_start,
        even_frames_in_file,
    }
}

/// Every test window: 8 per action with data, in the table's order.
pub const TEST_WINDOWS: [TestWindow; 88] = [
    w("eating", 0, 1, 1426, 1476, 1638),
    w("eating", 1, 2, 374, 424, 1166),
    w("eating", 2, 1, 1087, 1137, 1638),
    w("eating", 3, 2, 156, 206, 1166),
    w("eating", 4, 1, 1329, 1379, 1638),
    w("eating", 5, 2, 955, 1005, 1166),
    w("eating", 6, 1, 1145, 1195, 1638),
    w("eating", 7, 2, 332, 382, 1166),
    w("greeting", 0, 1, 402, 452, 737),
    w("greeting", 1, 2, 1398, 1448, 1600),
    w("greeting", 2, 1, 63, 113, 737),
    w("greeting", 3, 2, 1180, 1230, 1600),
    w("greeting", 4, 1, 305, 355, 737),
    w("greeting", 5, 2, 955, 1005, 1600),
    w("greeting", 6, 1, 121, 171, 737),
    w("greeting", 7, 2, 332, 382, 1600),
    w("phoning", 0, 1, 1426, 1476, 1639),
    w("phoning", 1, 2, 374, 424, 1043),
    w("phoning", 2, 1, 1087, 1137, 1639),
    w("phoning", 3, 2, 156, 206, 1043),
    w("phoning", 4, 1, 1329, 1379, 1639),
    w("phoning", 5, 2, 121, 171, 1043),
    w("phoning", 6, 1, 332, 382, 1639),
    w("phoning", 7, 2, 414, 464, 1043),
    w("posing", 0, 1, 402, 452, 1123),
    w("posing", 1, 2, 374, 424, 943),
    w("posing", 2, 1, 63, 113, 1123),
    w("posing", 3, 2, 156, 206, 943),
    w("posing", 4, 1, 835, 885, 1123),
    w("posing", 5, 2, 305, 355, 943),
    w("posing", 6, 1, 955, 1005, 1123),
    w("posing", 7, 2, 121, 171, 943),
    w("purchases", 0, 1, 1087, 1137, 1240),
    w("purchases", 1, 2, 1180, 1230, 1562),
    w("purchases", 2, 1, 955, 1005, 1240),
    w("purchases", 3, 2, 1145, 1195, 1562),
    w("purchases", 4, 1, 332, 382, 1240),
    w("purchases", 5, 2, 660, 710, 1562),
    w("purchases", 6, 1, 304, 354, 1240),
    w("purchases", 7, 2, 201, 251, 1562),
    w("sitting", 0, 1, 1426, 1476, 1969),
    w("sitting", 1, 2, 1398, 1448, 1939),
    w("sitting", 2, 1, 1087, 1137, 1969),
    w("sitting", 3, 2, 1180, 1230, 1939),
    w("sitting", 4, 1, 1329, 1379, 1969),
    w("sitting", 5, 2, 955, 1005, 1939),
    w("sitting", 6, 1, 1145, 1195, 1969),
    w("sitting", 7, 2, 332, 382, 1939),
    w("smoking", 0, 1, 1426, 1476, 1601),
    w("smoking", 1, 2, 1398, 1448, 1711),
    w("smoking", 2, 1, 1087, 1137, 1601),
    w("smoking", 3, 2, 1180, 1230, 1711),
    w("smoking", 4, 1, 1329, 1379, 1601),
    w("smoking", 5, 2, 955, 1005, 1711),
    w("smoking", 6, 1, 1145, 1195, 1601),
    w("smoking", 7, 2, 332, 382, 1711),
    w("takingphoto", 0, 1, 1426, 1476, 1663),
    w("takingphoto", 1, 2, 1087, 1137, 1391),
    w("takingphoto", 2, 1, 1180, 1230, 1663),
    w("takingphoto", 3, 2, 955, 1005, 1391),
    w("takingphoto", 4, 1, 1145, 1195, 1663),
    w("takingphoto", 5, 2, 332, 382, 1391),
    w("takingphoto", 6, 1, 1438, 1488, 1663),
    w("takingphoto", 7, 2, 660, 710, 1391),
    w("walking", 0, 1, 1087, 1137, 1500),
    w("walking", 1, 2, 955, 1005, 1261),
    w("walking", 2, 1, 1145, 1195, 1500),
    w("walking", 3, 2, 332, 382, 1261),
    w("walking", 4, 1, 660, 710, 1500),
    w("walking", 5, 2, 304, 354, 1261),
    w("walking", 6, 1, 201, 251, 1500),
    w("walking", 7, 2, 54, 104, 1261),
    w("walkingdog", 0, 1, 402, 452, 969),
    w("walkingdog", 1, 2, 374, 424, 1068),
    w("walkingdog", 2, 1, 63, 113, 969),
    w("walkingdog", 3, 2, 156, 206, 1068),
    w("walkingdog", 4, 1, 305, 355, 969),
    w("walkingdog", 5, 2, 121, 171, 1068),
    w("walkingdog", 6, 1, 332, 382, 969),
    w("walkingdog", 7, 2, 414, 464, 1068),
    w("walkingtogether", 0, 1, 1087, 1137, 1508),
    w("walkingtogether", 1, 2, 1180, 1230, 1492),
    w("walkingtogether", 2, 1, 1329, 1379, 1508),
    w("walkingtogether", 3, 2, 955, 1005, 1492),
    w("walkingtogether", 4, 1, 1145, 1195, 1508),
    w("walkingtogether", 5, 2, 332, 382, 1492),
    w("walkingtogether", 6, 1, 660, 710, 1508),
    w("walkingtogether", 7, 2, 304, 354, 1492),
];

/// The 8 test windows of `action` (none for an unknown action or one without data).
pub fn test_windows(action: &str) -> impl Iterator<Item = &'static TestWindow> + '_ {
    TEST_WINDOWS.iter().filter(move |w| w.action == action)
}

/// The actions that have test windows, in [`ACTIONS`] order.
pub fn actions_with_windows() -> impl Iterator<Item = &'static str> {
    ACTIONS
        .iter()
        .copied()
        .filter(|a| !ACTIONS_WITHOUT_WINDOWS.contains(a))
}

/// The exp-map dataset directory under a data root: `<root>/h3.6m/dataset`.
pub fn dataset_dir(data_root: &Path) -> PathBuf {
    data_root.join("h3.6m").join("dataset")
}

/// The file of `subject`/`action`/`subaction` in `dataset`: `.txt.gz` if present, else `.txt`
/// (the `.txt.gz` name when neither exists, so that the error names what was looked for).
pub fn sequence_file(dataset: &Path, subject: &str, action: &str, subaction: u8) -> PathBuf {
    let stem = dataset.join(subject).join(format!("{action}_{subaction}"));
    let gz = stem.with_extension("txt.gz");
    let txt = stem.with_extension("txt");
    if !gz.exists() && txt.exists() {
        txt
    } else {
        gz
    }
}

/// A test window's data: the seed and the ground truth that follows it (25 Hz exp-map frames).
#[derive(Debug, Clone, PartialEq)]
pub struct WindowData {
    /// The window.
    pub window: TestWindow,
    /// The [`SEED_FRAMES`] observed frames.
    pub seed: Array2<f64>,
    /// The absolute root pose of the 25 Hz frame before the seed, integrated exactly from the
    /// take's first frame ([`integrate_root_kept`]; `None` for a seed starting the take): the
    /// seed's deltas continue it. Measures in world space (floor, lean, hip height) integrate from it,
    /// so a seated seed keeps its real orientation.
    pub root_before: Option<RootPose>,
    /// The `horizon` frames from `predict_start`.
    pub ground_truth: Array2<f64>,
}

/// The window `window` of a file's 25 Hz frames (`path` names the file in errors).
///
/// Errors ([`FormatError::Invalid`]): the file's frame count differs from the table's, or the
/// window with `horizon` predicted frames reaches past the end.
pub fn cut_window(
    frames_25hz: ArrayView2<'_, f64>,
    root_poses: &[RootPose],
    window: &TestWindow,
    horizon: usize,
    path: &Path,
) -> Result<WindowData, FormatError> {
    let invalid = |problem: String| FormatError::Invalid {
        path: path.to_path_buf(),
        problem,
    };
    let frames = frames_25hz.nrows();
    if frames != window.even_frames_in_file {
        return Err(invalid(format!(
            "has {frames} frames at 25 Hz but the protocol's test-window table expects {} (another release of the data?)",
            window.even_frames_in_file
        )));
    }
    let end = window.predict_start + horizon;
    if end > frames {
        return Err(invalid(format!(
            "{} window {} needs frames up to {end} at 25 Hz, the file has {frames}",
            window.action, window.sample
        )));
    }
    Ok(WindowData {
        window: *window,
        seed: frames_25hz
            .slice(s![window.seed_start..window.predict_start, ..])
            .to_owned(),
        root_before: window
            .seed_start
            .checked_sub(1)
            .and_then(|k| root_poses.get(k).copied()),
        ground_truth: frames_25hz
            .slice(s![window.predict_start..end, ..])
            .to_owned(),
    })
}

/// Loads the 8 test windows of `action` from `dataset` (see [`dataset_dir`]) with `horizon`
/// predicted frames, reading each S5 file once and downsampling it to 25 Hz.
///
/// Errors: a missing or unreadable file ([`FormatError::Io`] naming it), a malformed file, or a
/// file that does not match the table ([`FormatError::Invalid`]). An action without windows gives
/// an empty list.
pub fn load_action_windows(
    dataset: &Path,
    action: &str,
    horizon: usize,
) -> Result<Vec<WindowData>, FormatError> {
    load_windows(dataset, action, horizon, false)
}

/// [`load_action_windows`] for horizons past what every file holds (long-horizon evaluation):
/// each window's `ground_truth` is its file's frames from `predict_start`, at most `horizon`
/// (shorter where the file ends first). Errors as [`load_action_windows`] otherwise.
pub fn load_action_windows_covered(
    dataset: &Path,
    action: &str,
    horizon: usize,
) -> Result<Vec<WindowData>, FormatError> {
    load_windows(dataset, action, horizon, true)
}

/// [`load_action_windows_covered`] on another [`WindowSet`]: the test windows, or `per_action`
/// validation windows ([`validation::validation_windows`]; fewer where the takes do not hold
/// that many, none for an action that is not in [`ACTIONS`]).
pub fn load_action_windows_in(
    dataset: &Path,
    action: &str,
    horizon: usize,
    set: WindowSet,
    per_action: usize,
) -> Result<Vec<WindowData>, FormatError> {
    match set {
        WindowSet::Test => load_windows(dataset, action, horizon, true),
        WindowSet::Validation => {
            let Some(&action) = ACTIONS.iter().find(|&&a| a == action) else {
                return Ok(Vec::new());
            };
            let mut loaded = Vec::new();
            for sub in [1u8, 2] {
                let path = sequence_file(dataset, TEST_SUBJECT, action, sub);
                if path.is_file() {
                    let frames = read_take(&path)?;
                    loaded.push((sub, path, frames));
                }
            }
            let takes: Vec<(u8, usize)> = loaded
                .iter()
                .map(|(s, _, f)| (*s, f.frames.nrows()))
                .collect();
            let windows = validation::validation_windows(action, &takes, per_action);
            cut_windows(&windows, loaded, dataset, action, horizon, true)
        }
    }
}

fn load_windows(
    dataset: &Path,
    action: &str,
    horizon: usize,
    cut_at_file_end: bool,
) -> Result<Vec<WindowData>, FormatError> {
    let windows: Vec<TestWindow> = test_windows(action).copied().collect();
    cut_windows(
        &windows,
        Vec::new(),
        dataset,
        action,
        horizon,
        cut_at_file_end,
    )
}

/// Cuts `windows` out of their takes (those in `loaded` are used as read, the others read once).
fn cut_windows(
    windows: &[TestWindow],
    mut loaded: Vec<(u8, PathBuf, Take)>,
    dataset: &Path,
    action: &str,
    horizon: usize,
    cut_at_file_end: bool,
) -> Result<Vec<WindowData>, FormatError> {
    let mut out = Vec::new();
    for window in windows {
        if !loaded.iter().any(|(sub, _, _)| *sub == window.subaction) {
            let path = sequence_file(dataset, TEST_SUBJECT, action, window.subaction);
            let frames = read_take(&path)?;
            loaded.push((window.subaction, path, frames));
        }
        let (_, path, take) = loaded
            .iter()
            .find(|(sub, _, _)| *sub == window.subaction)
            .expect("loaded above");
        let frames = &take.frames;
        let available = frames.nrows().saturating_sub(window.predict_start);
        let horizon = if cut_at_file_end {
            horizon.min(available)
        } else {
            horizon
        };
        out.push(cut_window(
            frames.view(),
            &take.root_poses,
            window,
            horizon,
            path,
        )?);
    }
    Ok(out)
}

/// One H3.6M take at the protocol's 25 Hz, with the exact absolute root pose of each of its
/// frames ([`integrate_root_kept`]).
#[derive(Debug, Clone)]
pub struct Take {
    /// The 25 Hz frames ([`downsample_protocol`]).
    pub frames: Array2<f64>,
    /// The absolute root pose of each 25 Hz frame, integrated at the source's 50 Hz.
    pub root_poses: Vec<RootPose>,
}

/// Reads one H3.6M take ([`Take`]); a file whose frames are not 99 wide is refused (naming it)
/// before anything indexes its columns.
pub fn read_take(path: &Path) -> Result<Take, FormatError> {
    let frames = read_source_frames(path)?;
    Ok(Take {
        root_poses: integrate_root_kept(frames.view(), ROOT_STEP_25HZ),
        frames: downsample_protocol(frames.view()),
    })
}

/// One H3.6M file's 50 Hz frames, refused (naming it) unless 99 wide.
fn read_source_frames(path: &Path) -> Result<Array2<f64>, FormatError> {
    let frames = read_expmap_text(path)?;
    if frames.ncols() != crate::skeleton::H36M_FRAME_DIMS {
        return Err(FormatError::Invalid {
            path: path.to_path_buf(),
            problem: format!(
                "{} columns per frame; H3.6M exp-map frames have {}",
                frames.ncols(),
                crate::skeleton::H36M_FRAME_DIMS
            ),
        });
    }
    Ok(frames)
}

/// Both takes of `action` by `subject` at the protocol's 25 Hz (the even frames), those whose file
/// exists (the NDMS word database of an action; Tanke et al. 2021 fills it from the test subject).
pub fn load_subject_sequences(
    dataset: &Path,
    subject: &str,
    action: &str,
) -> Result<Vec<Array2<f64>>, FormatError> {
    let mut out = Vec::new();
    for sub in [1, 2] {
        let path = sequence_file(dataset, subject, action, sub);
        if path.is_file() {
            out.push(downsample_protocol(read_source_frames(&path)?.view()));
        }
    }
    Ok(out)
}

/// The protocol's Euler sequence of exp-map frames (`T x (3 + 3k)`): every triple from dim 3 on
/// through `rotmat2euler(expmap2rotmat(·))`, dims 0..5 set to 0.
///
/// # Panics
/// If the width is not `3 + 3k` with `k >= 1`.
pub fn expmap_to_euler_protocol(frames: ArrayView2<'_, f64>) -> Array2<f64> {
    let mut out = Array2::zeros(frames.raw_dim());
    let mut input = vec![0.0; frames.ncols()];
    for (row, mut dst) in frames.rows().into_iter().zip(out.rows_mut()) {
        input.iter_mut().zip(row.iter()).for_each(|(d, s)| *d = *s);
        let dst = dst.as_slice_mut().expect("a fresh array is contiguous");
        expmap_frame_to_euler_protocol(&input, dst);
    }
    out
}

/// [`expmap_to_euler_protocol`] of every sequence of `N x T x (3 + 3k)`.
pub fn expmap_batch_to_euler_protocol(batch: ArrayView3<'_, f64>) -> Array3<f64> {
    let mut out = Array3::zeros(batch.raw_dim());
    for (sequence, mut dst) in batch.outer_iter().zip(out.outer_iter_mut()) {
        dst.assign(&expmap_to_euler_protocol(sequence));
    }
    out
}

/// Stacks equally shaped 2-D arrays into `N x T x D`.
///
/// # Panics
/// If the shapes differ or the list is empty.
pub fn stack_sequences(sequences: &[ArrayView2<'_, f64>]) -> Array3<f64> {
    ndarray::stack(Axis(0), sequences).expect("equally shaped, non-empty sequences")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_has_8_windows_for_each_action_with_data() {
        for action in ACTIONS {
            let count = test_windows(action).count();
            let expected = if ACTIONS_WITHOUT_WINDOWS.contains(&action) {
                0
            } else {
                8
            };
            assert_eq!(count, expected, "{action}");
        }
        for w in &TEST_WINDOWS {
            assert_eq!(w.predict_start - w.seed_start, SEED_FRAMES);
            assert!(
                w.predict_start + LONG_TERM_HORIZON <= w.even_frames_in_file,
                "{w:?}"
            );
            assert!(w.subaction == 1 || w.subaction == 2);
        }
        assert_eq!(actions_with_windows().count(), 11);
    }

    #[test]
    fn cut_window_cuts_and_names_the_file() {
        let window = TEST_WINDOWS[0];
        let frames = Array2::from_shape_fn((window.even_frames_in_file, 6), |(t, j)| {
            (t * 10 + j) as f64
        });
        let poses: Vec<RootPose> = (0..window.even_frames_in_file)
            .map(|t| RootPose {
                translation: [t as f64, 0.0, 0.0],
                ..RootPose::IDENTITY
            })
            .collect();
        let data = cut_window(frames.view(), &poses, &window, 10, Path::new("x.txt")).unwrap();
        assert_eq!(data.seed.nrows(), SEED_FRAMES);
        // The seed continues the take after the pose of the frame before it.
        assert_eq!(data.root_before, Some(poses[window.seed_start - 1]));
        assert_eq!(data.seed[[0, 0]], (window.seed_start * 10) as f64);
        assert_eq!(
            data.ground_truth[[0, 1]],
            (window.predict_start * 10 + 1) as f64
        );
        // A file of another length is rejected, naming the file.
        let short = frames.slice(s![..100, ..]);
        let err = cut_window(short, &poses, &window, 10, Path::new("x.txt")).unwrap_err();
        assert!(err.to_string().starts_with("x.txt:"), "{err}");
    }

    #[test]
    fn euler_conversion_zeroes_the_root_dims() {
        let frames = Array2::from_shape_fn((3, 9), |(t, j)| 0.1 * (t + j) as f64);
        let euler = expmap_to_euler_protocol(frames.view());
        assert!(euler.slice(s![.., ..6]).iter().all(|&v| v == 0.0));
        let mut expected = [0.0; 9];
        expmap_frame_to_euler_protocol(frames.row(1).as_slice().unwrap(), &mut expected);
        assert_eq!(euler.row(1).as_slice().unwrap(), &expected);
    }

    #[test]
    fn a_missing_file_is_an_io_error_naming_it() {
        let err =
            load_action_windows(Path::new("/nonexistent/dataset"), "walking", 10).unwrap_err();
        assert!(matches!(err, FormatError::Io { .. }));
        assert!(err.to_string().contains("S5/walking_1.txt.gz"), "{err}");
    }

    #[test]
    fn takes_of_another_width_are_refused_naming_the_file() {
        for columns in [98, 100] {
            let dataset = std::env::temp_dir().join(format!(
                "motion-protocol-width-{columns}-{}",
                std::process::id()
            ));
            std::fs::create_dir_all(dataset.join("S5")).unwrap();
            let row = vec!["0.1"; columns].join(",");
            let text = vec![row; 40].join("\n");
            for sub in [1, 2] {
                std::fs::write(dataset.join(format!("S5/walking_{sub}.txt")), &text).unwrap();
            }
            let e = load_subject_sequences(&dataset, "S5", "walking").unwrap_err();
            assert!(
                e.to_string().contains("walking_1.txt")
                    && e.to_string().contains(&format!("{columns} columns")),
                "{e}"
            );
            let e = load_action_windows_covered(&dataset, "walking", 100).unwrap_err();
            assert!(e.to_string().contains("columns per frame"), "{e}");
            std::fs::remove_dir_all(&dataset).unwrap();
        }
    }
}
