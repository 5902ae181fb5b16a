//! With the `builtin-weights` feature, embeds the two default models into motion-core when their
//! files exist at build time: the game default (`weights/intention_actions.safetensors`: what
//! `Character`, `predict`, the C ABI, Bevy, the web page and Python load) as `cfg(game_weights)`
//! and `MOTION_GAME_WEIGHTS`, and the forecasting default (`weights/vgru_d_multi.safetensors`:
//! what `eval` scores) as `cfg(default_weights)` and `MOTION_DEFAULT_WEIGHTS` (each the file's
//! absolute path, for `include_bytes!`); [`model::builtin`](src/model/builtin.rs) hands them out.
//! Without the feature or a file, that model is not embedded.
//!
//! `MOTION_GAME_WEIGHTS_FILE=PATH` and `MOTION_DEFAULT_WEIGHTS_FILE=PATH` at build time embed
//! another file instead (to try a candidate, or to test the embedding without touching
//! `weights/`).
//!
//! The action classifier (`weights/action_classifier.safetensors`, Ghosh et al. 2017's evaluation
//! instrument) is embedded the same way: `cfg(default_classifier)` and `MOTION_DEFAULT_CLASSIFIER`.
use std::path::{Path, PathBuf};

/// The shipped game default, relative to the workspace root.
const GAME_WEIGHTS: &str = "weights/intention_actions.safetensors";
/// The shipped forecasting default, relative to the workspace root.
const DEFAULT_WEIGHTS: &str = "weights/vgru_d_multi.safetensors";
/// The shipped action classifier, relative to the workspace root.
const DEFAULT_CLASSIFIER: &str = "weights/action_classifier.safetensors";
/// Build-time override of the embedded game default.
const GAME_OVERRIDE_VAR: &str = "MOTION_GAME_WEIGHTS_FILE";
/// Build-time override of the embedded forecasting default.
const OVERRIDE_VAR: &str = "MOTION_DEFAULT_WEIGHTS_FILE";

fn main() {
    println!("cargo::rustc-check-cfg=cfg(game_weights)");
    println!("cargo::rustc-check-cfg=cfg(default_weights)");
    println!("cargo::rustc-check-cfg=cfg(default_classifier)");
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-env-changed={OVERRIDE_VAR}");
    println!("cargo::rerun-if-env-changed={GAME_OVERRIDE_VAR}");
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
    let game = chosen(&root, GAME_OVERRIDE_VAR, GAME_WEIGHTS);
    embed(&game, "game_weights", "MOTION_GAME_WEIGHTS");
    let file = chosen(&root, OVERRIDE_VAR, DEFAULT_WEIGHTS);
    embed(&file, "default_weights", "MOTION_DEFAULT_WEIGHTS");
    embed(
        &root.join(DEFAULT_CLASSIFIER),
        "default_classifier",
        "MOTION_DEFAULT_CLASSIFIER",
    );
}

/// The file `var` names at build time, else `shipped` under the workspace root.
fn chosen(root: &Path, var: &str, shipped: &str) -> PathBuf {
    match std::env::var_os(var) {
        Some(path) if !path.is_empty() => {
            let path = PathBuf::from(path);
            assert!(path.is_file(), "{var}={} is not a file", path.display());
            path
        }
        _ => root.join(shipped),
    }
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
