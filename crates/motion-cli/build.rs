//! Embeds the default weights (`weights/vgru_d_multi.safetensors`) into `motion-cli` when the
//! file exists at build time: sets `cfg(default_weights)` and `MOTION_DEFAULT_WEIGHTS` (the
//! file's absolute path, for `include_bytes!`). Without the file the binary needs `--model`.
//!
//! `MOTION_DEFAULT_WEIGHTS_FILE=PATH` at build time embeds another file instead (to try a
//! candidate, or to test the embedding without touching `weights/`).
use std::path::{Path, PathBuf};

/// The shipped default model, relative to the workspace root.
const DEFAULT_WEIGHTS: &str = "weights/vgru_d_multi.safetensors";
/// Build-time override of the embedded file.
const OVERRIDE_VAR: &str = "MOTION_DEFAULT_WEIGHTS_FILE";

fn main() {
    println!("cargo::rustc-check-cfg=cfg(default_weights)");
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-env-changed={OVERRIDE_VAR}");
    let manifest = std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR");
    let root = Path::new(&manifest).join("../..");
    let weights_dir = root.join("weights");
    // Watching the directory (not only the file) catches the file appearing later; watching a
    // file that does not exist would rerun this script on every build.
    if weights_dir.is_dir() {
        println!("cargo::rerun-if-changed={}", weights_dir.display());
    }
    let file = match std::env::var_os(OVERRIDE_VAR) {
        Some(path) if !path.is_empty() => {
            let path = PathBuf::from(path);
            assert!(
                path.is_file(),
                "{OVERRIDE_VAR}={} is not a file",
                path.display()
            );
            path
        }
        _ => root.join(DEFAULT_WEIGHTS),
    };
    if file.is_file() {
        let absolute = file.canonicalize().unwrap_or(file);
        println!("cargo::rerun-if-changed={}", absolute.display());
        println!("cargo::rustc-cfg=default_weights");
        println!(
            "cargo::rustc-env=MOTION_DEFAULT_WEIGHTS={}",
            absolute.display()
        );
    }
}
