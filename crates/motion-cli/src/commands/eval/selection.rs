//! What `eval` runs on: the dataset directory, and the actions (the ones asked for, that the model
//! may be evaluated on and that have test windows and S5 files) with the reason for each skip.
use std::path::{Path, PathBuf};

use motion_core::model::MotionModel;
use motion_core::protocol::{self, ACTIONS, ACTIONS_WITHOUT_WINDOWS, TEST_SUBJECT};

use super::super::UsageError;

/// The exp-map dataset directory (the one holding `S5/`) of `--data`, `$MOTION_DATA_DIR` or
/// `../shared/data`. `root` may be the data root (holding `h3.6m/dataset`) or the dataset itself.
pub fn resolve_dataset(root: Option<&Path>) -> Result<PathBuf, UsageError> {
    let root = match root {
        Some(root) => root.to_path_buf(),
        None => match std::env::var_os("MOTION_DATA_DIR") {
            Some(dir) => PathBuf::from(dir),
            None if Path::new("../shared/data").is_dir() => PathBuf::from("../shared/data"),
            None => {
                return Err(UsageError(
                    "no data directory: pass --data DIR or set MOTION_DATA_DIR".into(),
                ))
            }
        },
    };
    if !root.is_dir() {
        return Err(UsageError(format!(
            "{}: data directory does not exist",
            root.display()
        )));
    }
    let nested = protocol::dataset_dir(&root);
    if nested.join(TEST_SUBJECT).is_dir() {
        Ok(nested)
    } else if root.join(TEST_SUBJECT).is_dir() {
        Ok(root)
    } else {
        Err(UsageError(format!(
            "{}: no H3.6M exp-map data (expected {} or {})",
            root.display(),
            nested.join(TEST_SUBJECT).display(),
            root.join(TEST_SUBJECT).display()
        )))
    }
}

/// The action labels the model was trained on: its conditioning labels, else the
/// `actions_trained` of its provenance (unconditioned models), else unknown (empty).
pub fn trained_actions(model: &MotionModel) -> Vec<String> {
    let config = model.config();
    if !config.actions.is_empty() {
        return config.actions.clone();
    }
    match model.provenance().get("actions_trained") {
        Some(serde_json::Value::Array(list)) => list
            .iter()
            .filter_map(|v| v.as_str().map(str::to_string))
            .collect(),
        Some(serde_json::Value::String(one)) => vec![one.clone()],
        _ => Vec::new(),
    }
}

/// An action to evaluate and the label the model is conditioned on for it.
#[derive(Debug, Clone)]
pub struct Planned {
    /// The action whose test windows are run.
    pub action: &'static str,
    /// The conditioning label (`None` for unconditioned models).
    pub label: Option<String>,
}

/// The outcome of the selection.
#[derive(Debug, Clone, Default)]
pub struct Selection {
    /// The actions to run, in [`ACTIONS`] order of the request.
    pub planned: Vec<Planned>,
    /// Actions asked for (or implied by `all`) that are not run, and why.
    pub skipped: Vec<(&'static str, String)>,
}

/// Resolves `--actions` (a comma list or `all`) against the model and the dataset.
///
/// Errors: an unknown action name (the message lists the valid ones), an action the model cannot
/// be evaluated on that was named explicitly, or nothing left to run.
pub fn select_actions(
    requested: &[String],
    model: &MotionModel,
    dataset: &Path,
    any_action: bool,
) -> Result<Selection, UsageError> {
    let all = requested.iter().any(|a| a.trim() == "all");
    let names: Vec<&'static str> = if all {
        ACTIONS.to_vec()
    } else {
        let mut names = Vec::new();
        for raw in requested {
            let name = raw.trim().to_lowercase();
            let Some(&known) = ACTIONS.iter().find(|a| **a == name) else {
                return Err(UsageError(format!(
                    "unknown action `{raw}`; valid actions: all, {}",
                    ACTIONS.join(", ")
                )));
            };
            if !names.contains(&known) {
                names.push(known);
            }
        }
        names
    };
    let conditioned = &model.config().actions;
    let trained = trained_actions(model);
    let mut selection = Selection::default();
    for action in names {
        // The model first: evaluating it where it cannot (or should not) go is a usage error
        // when the action was named, and a quiet skip under `all`.
        let refusal = if !conditioned.is_empty()
            && conditioned.len() > 1
            && !conditioned.iter().any(|a| a == action)
        {
            Some(format!(
                "the model is conditioned on {}; it has no label `{action}`",
                conditioned.join(", ")
            ))
        } else if trained.len() == 1 && trained[0] != action && !any_action {
            Some(format!(
                "the model was trained on `{}` only (pass --any-action to evaluate it on `{action}` anyway)",
                trained[0]
            ))
        } else {
            None
        };
        if let Some(reason) = refusal {
            if all {
                selection.skipped.push((action, reason));
                continue;
            }
            return Err(UsageError(reason));
        }
        if ACTIONS_WITHOUT_WINDOWS.contains(&action) {
            selection.skipped.push((
                action,
                "no test windows: its S5 files are absent from the data release".into(),
            ));
            continue;
        }
        let mut subactions: Vec<u8> = protocol::test_windows(action)
            .map(|w| w.subaction)
            .collect();
        subactions.sort_unstable();
        subactions.dedup();
        let missing: Vec<String> = subactions
            .iter()
            .map(|&sub| protocol::sequence_file(dataset, TEST_SUBJECT, action, sub))
            .filter(|path| !path.is_file())
            .map(|path| path.display().to_string())
            .collect();
        if !missing.is_empty() {
            selection
                .skipped
                .push((action, format!("missing {}", missing.join(", "))));
            continue;
        }
        let label = match conditioned.len() {
            0 => None,
            1 => Some(conditioned[0].clone()),
            _ => Some(action.to_string()),
        };
        selection.planned.push(Planned { action, label });
    }
    if selection.planned.is_empty() {
        let reasons: Vec<String> = selection
            .skipped
            .iter()
            .map(|(a, r)| format!("{a}: {r}"))
            .collect();
        return Err(UsageError(format!(
            "no action to evaluate ({})",
            reasons.join("; ")
        )));
    }
    Ok(selection)
}
