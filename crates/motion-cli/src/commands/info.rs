//! `motion-cli info WEIGHTS [--json]`: describe a motion-weights file (schema: weights/README.md)
//! — architecture, sizes (an intention model's noise, forecaster, intentions, clusters,
//! look-ahead and convolution too), parameter count, fps, actions, dims, residual, GRU convention
//! and training provenance; for an `action-classifier` file its windows, sizes and classes. Loading
//! checks every tensor, so this also validates the file. A motion-matching database
//! (`motion-cli matching build`) prints its rig, rate, frames, takes, feature weights, licence
//! and provenance.
use std::fmt::Write as _;
use std::path::PathBuf;

use motion_core::matching::features::{GROUP_NAMES, TRAJECTORY_TIMES_S};
use motion_core::matching::file::{FORMAT_NAME, FORMAT_VERSION};
use motion_core::matching::{is_database, MatchingDatabase};
use motion_core::takes::unit_name;

use motion_core::model::config::architecture_name;
use motion_core::model::{
    ActionClassifier, Architecture, MotionModel, WeightStore, CLASSIFIER_ARCHITECTURE,
};
use motion_core::nn::GruConvention;

/// Arguments of `motion-cli info`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A motion-weights or motion-matching database safetensors file.
    pub weights: PathBuf,
    #[command(flatten)]
    pub reporting: super::output::Output,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let store = WeightStore::open(&args.weights)?;
    if is_database(&store) {
        let db = MatchingDatabase::from_store(&store)?;
        let file_bytes = std::fs::metadata(&args.weights).map_or(0, |m| m.len());
        let text = if args.reporting.json {
            database_json(&args, &db, file_bytes)?
        } else {
            database_text(&args, &db, file_bytes)
        };
        print!("{text}");
        return Ok(());
    }
    if architecture_name(&store).ok().as_deref() == Some(CLASSIFIER_ARCHITECTURE) {
        let classifier = ActionClassifier::from_store(&store)?;
        let text = if args.reporting.json {
            classifier_json(&classifier)?
        } else {
            classifier_text(&classifier)
        };
        print!("{text}");
        return Ok(());
    }
    let model = MotionModel::from_store(&store)?;
    let text = if args.reporting.json {
        json_summary(&model)?
    } else {
        text_summary(&model)
    };
    print!("{text}");
    Ok(())
}

/// Groups digits by thousands: 2724918 -> "2,724,918".
fn thousands(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

fn convention_formula(c: GruConvention) -> &'static str {
    match c {
        GruConvention::PyTorch => "n = tanh(W_n x + b_in + r * (U_n h + b_hn))",
        GruConvention::Paper => "n = tanh(W_n x + b_in + U_n (r * h) + b_hn)",
    }
}

fn text_summary(model: &MotionModel) -> String {
    let c = model.config();
    let mut s = String::new();
    let mut line = |key: &str, value: String| {
        let _ = writeln!(s, "{key:<15} {value}");
    };
    line("file", model.path().display().to_string());
    let mut sizes = String::new();
    for (key, value) in c.arch.describe(c) {
        if key == "sizes" {
            sizes = value;
        } else {
            line(key, value);
        }
    }
    line(
        "sizes",
        format!(
            "{sizes}; input {} = {} dims x (1 + derivative order {}); output {} dims",
            c.input_dims(),
            c.output_dims(),
            c.derivative_order,
            c.output_dims()
        ),
    );
    line(
        "parameters",
        format!(
            "{} (stored {}, computed in f32)",
            thousands(model.parameter_count()),
            model.stored_dtype()
        ),
    );
    line(
        "frames",
        format!(
            "{} dims, {} predicted (others restored to the training mean); skeleton {}",
            c.frame_dims,
            c.output_dims(),
            c.skeleton
        ),
    );
    if c.skeleton == motion_core::model::config::RIG_SKELETON {
        let rig = model.skeleton();
        line(
            "rig",
            format!(
                "{} joints ({} with End Sites), root {}, written in {} (the file holds it as BVH; poses and BVH output are on it)",
                rig.body_joint_names().len(),
                rig.len(),
                rig.joint(0).name,
                motion_core::takes::unit_name(c.mm_per_unit.unwrap_or(1.0))
            ),
        );
    }
    if let Some(prior) = model.prior() {
        line(
            "pose prior",
            format!(
                "radius {} (standard deviations; {} action group{}): generated frames beyond it are pulled back before feedback",
                prior.radius(),
                c.actions.len().max(1),
                if c.actions.len() > 1 { "s" } else { "" }
            ),
        );
    }
    line("fps", format!("{}", c.fps));
    line(
        "actions",
        if c.actions.is_empty() {
            "none (unconditioned)".into()
        } else {
            format!("{}: {}", c.actions.len(), c.actions.join(", "))
        },
    );
    line(
        "residual",
        if c.residual {
            "yes (output = input frame + decoder)".into()
        } else {
            "no".into()
        },
    );
    if c.architecture() != Architecture::DaeLstm {
        line(
            "gru convention",
            format!(
                "{} ({})",
                c.gru_convention.name(),
                convention_formula(c.gru_convention)
            ),
        );
    }
    line(
        "normalization",
        match c.normalization.as_str() {
            "min-max" => {
                "min-max (norm.mean = training minimum, norm.std = range; features in [0, 1])"
            }
            _ => "standard (norm.mean, norm.std = training mean and standard deviation)",
        }
        .into(),
    );
    line(
        "derivatives",
        format!(
            "order {}, padding {}",
            c.derivative_order, c.derivative_padding
        ),
    );
    line(
        "training",
        format!(
            "{} seed frames, horizon {} frames",
            c.seed_frames, c.horizon
        ),
    );
    provenance_lines(&mut s, model.provenance());
    s
}

/// A one-line rendering of a provenance value: strings bare, numbers rounded to 4 decimals,
/// arrays of scalars joined, objects as their scalar fields plus a count of nested entries
/// (`--json` prints everything).
fn brief(value: &serde_json::Value) -> String {
    use serde_json::Value;
    match value {
        Value::String(text) => text.clone(),
        Value::Number(n) => match (n.as_i64(), n.as_f64()) {
            (Some(i), _) => i.to_string(),
            (None, Some(f)) => format!("{f:.4}"),
            _ => n.to_string(),
        },
        Value::Array(items) if items.iter().all(|v| !v.is_object() && !v.is_array()) => {
            items.iter().map(brief).collect::<Vec<_>>().join(", ")
        }
        Value::Array(items) => format!("[{} entries]", items.len()),
        Value::Object(map) => map
            .iter()
            .map(|(k, v)| match v {
                Value::Object(inner) => format!("{k}: {{{} entries}}", inner.len()),
                Value::Array(inner) => format!("{k}: [{} entries]", inner.len()),
                _ => format!("{k}={}", brief(v)),
            })
            .collect::<Vec<_>>()
            .join(", "),
        other => other.to_string(),
    }
}

fn provenance_lines(s: &mut String, provenance: &motion_core::model::Provenance) {
    if provenance.is_empty() {
        let _ = writeln!(s, "{:<15} (none recorded)", "provenance");
        return;
    }
    let _ = writeln!(s, "provenance");
    let width = provenance.keys().map(String::len).max().unwrap_or(0);
    for (key, value) in provenance {
        let _ = writeln!(s, "  {key:<width$}  {}", brief(value));
    }
}

fn classifier_text(classifier: &ActionClassifier) -> String {
    let c = classifier.config();
    let mut s = String::new();
    let mut line = |key: &str, value: String| {
        let _ = writeln!(s, "{key:<15} {value}");
    };
    line("file", classifier.path().display().to_string());
    line(
        "architecture",
        "action-classifier (LSTM over windows + linear head, Ghosh et al. 2017 section 4.5)".into(),
    );
    line(
        "sizes",
        format!(
            "{} LSTM layers x {} units; input {} = {} dims x (1 + derivative order {})",
            c.layers,
            c.hidden,
            c.input_dims(),
            c.dims_used.len(),
            c.derivative_order
        ),
    );
    line(
        "parameters",
        thousands(classifier.parameter_count()) + " (computed in f32)",
    );
    line(
        "windows",
        format!(
            "{} frames ({} s) at {} Hz; {}",
            c.window,
            c.window_seconds(),
            c.fps,
            if c.center {
                "each non-root dim centred on its window mean"
            } else {
                "absolute poses"
            }
        ),
    );
    line(
        "frames",
        format!("{} dims, skeleton {}", c.frame_dims, c.skeleton),
    );
    line(
        "classes",
        format!("{}: {}", c.actions.len(), c.actions.join(", ")),
    );
    provenance_lines(&mut s, classifier.provenance());
    s
}

fn classifier_json(classifier: &ActionClassifier) -> anyhow::Result<String> {
    let summary = serde_json::json!({
        "file": classifier.path().display().to_string(),
        "parameters": classifier.parameter_count(),
        "config": classifier.config(),
        "provenance": classifier.provenance(),
    });
    Ok(format!("{}\n", serde_json::to_string_pretty(&summary)?))
}

fn json_summary(model: &MotionModel) -> anyhow::Result<String> {
    let summary = serde_json::json!({
        "file": model.path().display().to_string(),
        "parameters": model.parameter_count(),
        "stored_dtype": model.stored_dtype(),
        "config": model.config(),
        "provenance": model.provenance(),
    });
    Ok(format!("{}\n", serde_json::to_string_pretty(&summary)?))
}

/// The feature groups with their weights: `foot positions 0.75, ...`.
fn weighted_groups(db: &MatchingDatabase) -> String {
    GROUP_NAMES
        .iter()
        .zip(db.weights())
        .map(|(name, w)| format!("{name} {w}"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn database_text(args: &Args, db: &MatchingDatabase, file_bytes: u64) -> String {
    let mut s = String::new();
    let mut line = |key: &str, value: String| {
        let _ = writeln!(s, "{key:<15} {value}");
    };
    let skeleton = db.skeleton();
    line("file", args.weights.display().to_string());
    line(
        "format",
        format!("{FORMAT_NAME} version {FORMAT_VERSION} (a motion-matching database)"),
    );
    line(
        "rig",
        format!(
            "{} joints ({} with End Sites), root {}, {} ({} mm per unit)",
            skeleton.body_joint_names().len(),
            skeleton.len(),
            skeleton.joint(0).name,
            unit_name(db.mm_per_unit()),
            db.mm_per_unit()
        ),
    );
    line("fps", format!("{}", db.fps()));
    line(
        "frames",
        format!(
            "{} ({:.1} s), {} searchable",
            thousands(db.frames()),
            db.frames() as f64 / db.fps(),
            thousands(db.searchable_frames())
        ),
    );
    let takes = db.takes();
    let retargeted = takes.iter().filter(|t| t.retargeted).count();
    line(
        "takes",
        format!(
            "{}{}: {}",
            takes.len(),
            if retargeted > 0 {
                format!(" ({retargeted} retargeted from other rigs)")
            } else {
                String::new()
            },
            takes
                .iter()
                .map(|t| t.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    );
    line("features", weighted_groups(db));
    line(
        "trajectory",
        format!(
            "{} s ahead; a search every {} frames while steered",
            TRAJECTORY_TIMES_S
                .iter()
                .map(|t| format!("{t:.2}"))
                .collect::<Vec<_>>()
                .join(", "),
            db.search_frames()
        ),
    );
    line(
        "licence",
        if db.licence().is_empty() {
            "(none recorded)".into()
        } else {
            db.licence().to_string()
        },
    );
    line(
        "bytes",
        format!(
            "{} in the file, {} in memory",
            thousands(file_bytes as usize),
            thousands(db.bytes())
        ),
    );
    if db.provenance().is_empty() {
        let _ = writeln!(s, "{:<15} (none recorded)", "provenance");
    } else {
        let _ = writeln!(s, "provenance");
        let width = db.provenance().keys().map(String::len).max().unwrap_or(0);
        for (key, value) in db.provenance() {
            let _ = writeln!(s, "  {key:<width$}  {value}");
        }
    }
    s
}

fn database_json(args: &Args, db: &MatchingDatabase, file_bytes: u64) -> anyhow::Result<String> {
    let skeleton = db.skeleton();
    let summary = serde_json::json!({
        "file": args.weights.display().to_string(),
        "format": FORMAT_NAME,
        "format_version": FORMAT_VERSION,
        "rig": {
            "joints": skeleton.body_joint_names().len(),
            "joints_with_end_sites": skeleton.len(),
            "root": skeleton.joint(0).name,
            "joint_names": skeleton.body_joint_names(),
            "mm_per_unit": db.mm_per_unit(),
            "units": unit_name(db.mm_per_unit()),
        },
        "fps": db.fps(),
        "frames": db.frames(),
        "seconds": db.frames() as f64 / db.fps(),
        "searchable_frames": db.searchable_frames(),
        "takes": db.takes(),
        "feature_weights": GROUP_NAMES.iter().zip(db.weights()).map(|(n, w)| (n.to_string(), w)).collect::<std::collections::BTreeMap<_, _>>(),
        "trajectory_s": TRAJECTORY_TIMES_S,
        "search_frames": db.search_frames(),
        "licence": db.licence(),
        "provenance": db.provenance(),
        "file_bytes": file_bytes,
        "memory_bytes": db.bytes(),
    });
    Ok(format!("{}\n", serde_json::to_string_pretty(&summary)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_thousands() {
        assert_eq!(thousands(0), "0");
        assert_eq!(thousands(999), "999");
        assert_eq!(thousands(1000), "1,000");
        assert_eq!(thousands(2724918), "2,724,918");
    }

    #[test]
    fn summary_of_a_random_model() {
        let config = motion_core::model::ModelConfig::paper(Architecture::VgruD);
        let model = MotionModel::random(&config, 3).unwrap();
        let text = text_summary(&model);
        for needle in [
            "vgru-d",
            "2,748,982",
            "walkingdog",
            "paper",
            "fps",
            "25",
            "provenance",
        ] {
            assert!(text.contains(needle), "{needle} missing from:\n{text}");
        }
        let json: serde_json::Value = serde_json::from_str(&json_summary(&model).unwrap()).unwrap();
        assert_eq!(json["parameters"], 2748982);
        assert_eq!(json["config"]["architecture"], "vgru-d");
    }

    #[test]
    fn summary_of_an_intention_model() {
        let config = motion_core::model::ModelConfig::paper(Architecture::Intention);
        let model = MotionModel::random(&config, 3).unwrap();
        let text = text_summary(&model);
        for needle in [
            "intention (",
            "Tanke et al. 2021",
            "1,410,654",
            "8 intentions from 32 pose clusters",
            "128 units",
            "look-ahead 10 frames",
            "intent_conv 32 channels",
            "noise_dims 32",
            "pose encoder 224 units",
            "3 GRU layers x 256 units (first layer input 118",
            "pytorch",
            "none (unconditioned)",
        ] {
            assert!(text.contains(needle), "{needle} missing from:\n{text}");
        }
        let json: serde_json::Value = serde_json::from_str(&json_summary(&model).unwrap()).unwrap();
        assert_eq!(json["config"]["architecture"], "intention");
        assert_eq!(json["config"]["lookahead"], 10);
        assert_eq!(json["config"]["noise_dims"], 32);
    }
}
