//! Helpers shared by the `motion-cli` integration tests: paths, scratch directories and running
//! the binary.
#![allow(dead_code)] // each test file uses a subset

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The repository root.
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `MOTION_DATA_DIR`, or `../shared/data` beside the repository.
pub fn data_dir() -> PathBuf {
    std::env::var_os("MOTION_DATA_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join("../shared/data"))
}

/// The small random-weight VGRU-d of the parity fixtures.
pub fn fixture_model() -> PathBuf {
    repo().join("tests/fixtures/parity/vgru_d.safetensors")
}

/// The example walking seed (BVH, H3.6M skeleton).
pub fn walk_seed() -> PathBuf {
    repo().join("examples/walk_seed.bvh")
}

/// A fresh, empty scratch directory for one test (under Cargo's target tmpdir), named after the
/// test file and `name` so that no two test files share one.
pub fn scratch(name: &str) -> PathBuf {
    let dir =
        Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("{}-{name}", env!("CARGO_CRATE_NAME")));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs `motion-cli ARGS`.
pub fn motion_cli<I, S>(args: I) -> Output
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    Command::new(env!("CARGO_BIN_EXE_motion-cli"))
        .args(args)
        .output()
        .expect("the motion-cli binary runs")
}

/// The sorted file names in `dir`.
pub fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Runs `motion-cli ARGS` in `dir` and checks the bad-input contract: exit 2, one `error:` line
/// containing every string of `expected`, no new file in `dir`.
pub fn bad_input(dir: &Path, args: &[&dyn AsRef<std::ffi::OsStr>], expected: &[&str]) {
    let before = listing(dir);
    let output = Command::new(env!("CARGO_BIN_EXE_motion-cli"))
        .current_dir(dir)
        .args(args.iter().map(|a| a.as_ref()))
        .output()
        .expect("runs motion-cli");
    let stderr = String::from_utf8_lossy(&output.stderr);
    let shown: Vec<String> = args
        .iter()
        .map(|a| a.as_ref().to_string_lossy().into_owned())
        .collect();
    assert_eq!(output.status.code(), Some(2), "{shown:?}: {stderr}");
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(
        lines.len(),
        1,
        "{shown:?}: one line expected, got: {stderr}"
    );
    assert!(lines[0].starts_with("error: "), "{stderr}");
    assert!(
        !stderr.contains("panicked") && !stderr.contains("RUST_BACKTRACE"),
        "{stderr}"
    );
    for text in expected {
        assert!(
            lines[0].contains(text),
            "{shown:?}: `{text}` missing from: {stderr}"
        );
    }
    assert_eq!(listing(dir), before, "{shown:?} left files behind");
}

/// A copy of the walk seed's text with its frames replaced by `frames` lines (and count).
pub fn walk_with_frames(frames: &[String]) -> String {
    let text = std::fs::read_to_string(walk_seed()).unwrap();
    let (head, _) = text.split_once("MOTION").unwrap();
    format!(
        "{head}MOTION\nFrames: {}\nFrame Time: 0.04\n{}\n",
        frames.len(),
        frames.join("\n")
    )
}

/// The walk seed's frame lines.
pub fn walk_frames() -> Vec<String> {
    let text = std::fs::read_to_string(walk_seed()).unwrap();
    let (_, motion) = text.split_once("Frame Time:").unwrap();
    motion
        .lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(String::from)
        .collect()
}
