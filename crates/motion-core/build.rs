//! With the `builtin-weights` feature, embeds the default weights
//! (`weights/vgru_d_multi.safetensors`) into motion-core when the file exists at build time: sets
//! `cfg(default_weights)` and `MOTION_DEFAULT_WEIGHTS` (the file's absolute path, for
//! `include_bytes!`); [`model::builtin`](src/model/builtin.rs) hands them out to every front end
//! (CLI, C ABI, web). Without the feature or the file, nothing is embedded.
//!
//! `MOTION_DEFAULT_WEIGHTS_FILE=PATH` at build time embeds another file instead (to try a
//! candidate, or to test the embedding without touching `weights/`).
//!
//! The action classifier (`weights/action_classifier.safetensors`, Ghosh et al. 2017's evaluation
//! instrument) is embedded the same way: `cfg(default_classifier)` and `MOTION_DEFAULT_CLASSIFIER`.
use std::path::{Path, PathBuf};

/// The shipped default model, relative to the workspace root.
const DEFAULT_WEIGHTS: &str = "weights/vgru_d_multi.safetensors";
/// The shipped action classifier, relative to the workspace root.
const DEFAULT_CLASSIFIER: &str = "weights/action_classifier.safetensors";
/// Build-time override of the embedded file.
const OVERRIDE_VAR: &str = "MOTION_DEFAULT_WEIGHTS_FILE";

fn main() {
    println!("cargo::rustc-check-cfg=cfg(default_weights)");
    println!("cargo::rustc-check-cfg=cfg(default_classifier)");
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-env-changed={OVERRIDE_VAR}");
    if std::env::var_os("CARGO_FEATURE_BUILTIN_WEIGHTS").is_none() {
        return;
    }
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
    embed(&file, "default_weights", "MOTION_DEFAULT_WEIGHTS");
    embed(
        &root.join(DEFAULT_CLASSIFIER),
        "default_classifier",
        "MOTION_DEFAULT_CLASSIFIER",
    );
}

/// Sets `cfg(cfg_name)` and the env var `env_name` (the absolute path) when `file` exists.
fn embed(file: &Path, cfg_name: &str, env_name: &str) {
    if file.is_file() {
        let absolute = file.canonicalize().unwrap_or(file.to_path_buf());
        println!("cargo::rerun-if-changed={}", absolute.display());
        println!("cargo::rustc-cfg={cfg_name}");
        println!("cargo::rustc-env={env_name}={}", absolute.display());
    }
}
