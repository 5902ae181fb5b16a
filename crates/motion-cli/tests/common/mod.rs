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

/// A fresh, empty scratch directory for one test (under Cargo's target tmpdir).
pub fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
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
