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
