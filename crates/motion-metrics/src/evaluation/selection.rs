//! What `eval` runs on: the dataset directory, and the actions (the ones asked for, that the model
//! may be evaluated on and that have test windows and S5 files) with the reason for each skip.
use std::path::{Path, PathBuf};

use motion_core::model::MotionModel;
use motion_core::protocol::{self, ACTIONS, ACTIONS_WITHOUT_WINDOWS, TEST_SUBJECT};

use super::EvalError;

/// The exp-map dataset directory (the one holding `S5/`) of `--data`, `$MOTION_DATA_DIR` or
/// `../shared/data`. `root` may be the data root (holding `h3.6m/dataset`) or the dataset itself.
pub fn resolve_dataset(root: Option<&Path>) -> Result<PathBuf, EvalError> {
    let root = match root {
        Some(root) => root.to_path_buf(),
        None => match std::env::var_os("MOTION_DATA_DIR") {
            Some(dir) => PathBuf::from(dir),
            None if Path::new("../shared/data").is_dir() => PathBuf::from("../shared/data"),
            None => {
                return Err(EvalError::Invalid(
                    "no data directory: pass --data DIR or set MOTION_DATA_DIR".into(),
                ))
            }
        },
    };
    if !root.is_dir() {
        return Err(EvalError::Invalid(format!(
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
        Err(EvalError::Invalid(format!(
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

/// Where a protocol's windows of an action come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WindowSource {
    /// The fixed table of [`protocol::TEST_WINDOWS`] (none for the actions whose S5 files were
    /// absent when it was made).
    Table,
    /// Sampled from both S5 takes of the action ([`protocol::sampler`]): any action whose two
    /// files are present.
    BothTakes,
    /// Every take of these subjects: any action with at least one of their files present.
    Subjects(&'static [&'static str]),
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
) -> Result<Selection, EvalError> {
    select_actions_from(requested, model, dataset, any_action, WindowSource::Table)
}

/// [`select_actions`] for a protocol whose windows come from `source`.
pub fn select_actions_from(
    requested: &[String],
    model: &MotionModel,
    dataset: &Path,
    any_action: bool,
    source: WindowSource,
) -> Result<Selection, EvalError> {
    let all = requested.iter().any(|a| a.trim() == "all");
    let names: Vec<&'static str> = if all {
        ACTIONS.to_vec()
    } else {
        let mut names = Vec::new();
        for raw in requested {
            let name = raw.trim().to_lowercase();
            let Some(&known) = ACTIONS.iter().find(|a| **a == name) else {
                return Err(EvalError::Invalid(format!(
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
            return Err(EvalError::Invalid(reason));
        }
        if source == WindowSource::Table && ACTIONS_WITHOUT_WINDOWS.contains(&action) {
            selection.skipped.push((
                action,
                "no test windows: its S5 files are absent from the data release".into(),
            ));
            continue;
        }
        if let WindowSource::Subjects(subjects) = source {
            let files: Vec<PathBuf> = subjects
                .iter()
                .flat_map(|subject| {
                    [1u8, 2].map(|sub| protocol::sequence_file(dataset, subject, action, sub))
                })
                .collect();
            if !files.iter().any(|f| f.is_file()) {
                selection.skipped.push((
                    action,
                    format!(
                        "no take of {} in {}",
                        subjects.join(", "),
                        dataset.display()
                    ),
                ));
                continue;
            }
        }
        let mut subactions: Vec<u8> = match source {
            WindowSource::Table => protocol::test_windows(action)
                .map(|w| w.subaction)
                .collect(),
            WindowSource::BothTakes => vec![1, 2],
            WindowSource::Subjects(_) => Vec::new(),
        };
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
        return Err(EvalError::Invalid(format!(
            "no action to evaluate ({})",
            reasons.join("; ")
        )));
    }
    Ok(selection)
}

#[cfg(test)]
mod tests {
    use super::*;
    use motion_core::model::{ArchConfig, Architecture, ModelConfig, VgruDFields};

    fn small_model(architecture: Architecture, actions: &[&str]) -> MotionModel {
        let mut config = ModelConfig::paper(architecture);
        config.hidden = 4;
        if architecture == Architecture::VgruD {
            config.arch = ArchConfig::VgruD(VgruDFields { plan_hidden: 2 });
        }
        config.actions = actions.iter().map(|a| a.to_string()).collect();
        MotionModel::random(&config, 7).unwrap()
    }

    /// A dataset directory whose S5 holds (empty) files for walking and eating only.
    fn dataset(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("eval-selection-{name}-{}", std::process::id()));
        let s5 = dir.join("S5");
        std::fs::create_dir_all(&s5).unwrap();
        for file in ["walking_1", "walking_2", "eating_1", "eating_2"] {
            std::fs::write(s5.join(format!("{file}.txt.gz")), b"").unwrap();
        }
        dir
    }

    fn strings(list: &[&str]) -> Vec<String> {
        list.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn a_single_action_model_is_held_to_its_action() {
        let dir = dataset("single");
        let model = small_model(Architecture::VgruD, &["walking"]);
        let err = select_actions(&strings(&["eating"]), &model, &dir, false).unwrap_err();
        let err = err.to_string();
        assert!(err.contains("trained on `walking` only") && err.contains("--any-action"));
        let all = select_actions(&strings(&["all"]), &model, &dir, false).unwrap();
        assert_eq!(all.planned.len(), 1);
        assert_eq!(all.planned[0].action, "walking");
        assert_eq!(all.skipped.len(), 14);
        // --any-action: eating is run, conditioned on the model's only label.
        let any = select_actions(&strings(&["eating"]), &model, &dir, true).unwrap();
        assert_eq!(any.planned[0].label.as_deref(), Some("walking"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn multi_action_and_unconditioned_models() {
        let dir = dataset("multi");
        let multi = small_model(Architecture::VgruD, &ACTIONS);
        let s = select_actions(
            &strings(&["walking", "eating", "smoking"]),
            &multi,
            &dir,
            false,
        )
        .unwrap();
        let planned: Vec<_> = s
            .planned
            .iter()
            .map(|p| (p.action, p.label.clone()))
            .collect();
        assert_eq!(
            planned,
            [
                ("walking", Some("walking".to_string())),
                ("eating", Some("eating".to_string()))
            ]
        );
        assert_eq!(s.skipped.len(), 1);
        assert!(
            s.skipped[0].1.contains("smoking_1.txt.gz"),
            "{:?}",
            s.skipped
        );
        // An unconditioned model without provenance: any action, no label.
        let grud = small_model(Architecture::GruD, &[]);
        let s = select_actions(&strings(&["eating"]), &grud, &dir, false).unwrap();
        assert_eq!(s.planned[0].label, None);
        let err = select_actions(&strings(&["Jogging"]), &grud, &dir, false).unwrap_err();
        assert!(err
            .to_string()
            .starts_with("unknown action `Jogging`; valid actions: all, directions"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
