//! `motion-cli matching build --takes DIR --out DB.safetensors`: a motion-matching database from
//! a folder of BVH takes on any rig (`motion_core::takes`, `motion_core::matching`). The CLI only
//! parses, reports and writes; the rules live in motion-core.
use std::path::{Path, PathBuf};

use motion_core::matching::{MatchingDatabase, DEFAULT_WEIGHTS};
use motion_core::takes::{unit_name, Takes};
use serde_json::json;

use super::UsageError;

/// The `licence` entry written when `--licence` is not given.
pub const UNSPECIFIED_LICENCE: &str =
    "unspecified: whoever builds a database must state the takes' licence (motion-cli matching build --licence TEXT)";

const BUILD_HELP: &str = "\
Reads every .bvh file of --takes (not recursive, sorted by name) onto one rig (--rig, by default \
the first readable take's; takes on other rigs are retargeted through the built-in joint maps, \
CMU ASF, cgspeed 3dsMax and MotionBuilder names, Mixamo, Unreal, or --joint-map), resamples \
them to --fps, finds each frame's root trajectory and foot contacts, and writes one \
self-describing safetensors file: the rig, the frames, the matching features (Clavet 2016: foot \
positions and velocities, hip velocity, the trajectory 1/3, 2/3 and 1 s ahead), their \
normalisation and weights, the source takes, a `licence` and a `provenance` entry. `motion-cli \
info` prints them; `motion-cli predict --model DB.safetensors --seed TAKE.bvh --path path.json` \
plays it on the takes' own rig.

Takes that cannot be read, mapped onto the rig or are shorter than --min-seconds are reported \
by name (one line each on stderr, or in --json's `skipped`) and the rest are used. --exclude \
drops takes by name (file name without .bvh), e.g. to hold test takes out of the database.

State the takes' licence with --licence: it is stored in the file for whoever ships it.

Examples:
  motion-cli matching build --takes ../shared/data/cmu_locomotion --out db.safetensors \\
      --licence 'CMU Graphics Lab Motion Capture Database: free for all uses (mocap.cs.cmu.edu)'
  motion-cli matching build --takes takes/ --exclude 16_15,16_17 --fps 30 --out db.safetensors --json
  motion-cli info db.safetensors";

/// Arguments of `motion-cli matching`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands of `motion-cli matching`.
#[derive(clap::Subcommand, Debug)]
pub enum Command {
    /// Build a motion-matching database from a folder of BVH takes (any rig).
    Build(BuildArgs),
}

/// Arguments of `motion-cli matching build`.
#[derive(clap::Args, Debug)]
#[command(after_long_help = BUILD_HELP)]
pub struct BuildArgs {
    #[command(flatten)]
    pub source: super::takes::TakeArgs,
    /// The database file to write (.safetensors).
    #[arg(long, value_name = "FILE.safetensors")]
    pub out: PathBuf,
    /// The licence of the takes, stored in the file's `licence` entry.
    #[arg(long, value_name = "TEXT")]
    pub licence: Option<String>,
    #[command(flatten)]
    pub reporting: super::output::Output,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    match args.command {
        Command::Build(args) => build(args),
    }
}

fn build(args: BuildArgs) -> anyhow::Result<()> {
    check_database_output(&args.out)?;
    motion_core::clip::check_not_an_input(&args.out, &args.source.inputs())?;
    if let Some(licence) = &args.licence {
        if licence.trim().is_empty() {
            return Err(UsageError("--licence is empty: state the takes' licence".into()).into());
        }
    }
    let (takes, excluded) = args.source.read()?;
    let mut notices = Vec::new();
    for skipped in &takes.skipped {
        let notice = format!("skipped {}: {}", skipped.path.display(), skipped.reason);
        args.reporting.notice(&notice);
        notices.push(notice);
    }
    let mut db = MatchingDatabase::from_takes(&takes, DEFAULT_WEIGHTS)?;
    db.set_licence(
        args.licence
            .clone()
            .unwrap_or_else(|| UNSPECIFIED_LICENCE.to_string()),
    );
    for (key, value) in provenance(&args, &takes, &excluded) {
        db.set_provenance(key, value);
    }
    let bytes = db.to_bytes()?;
    motion_core::formats::atomic::write_bytes_atomically(&args.out, &bytes)?;
    if args.licence.is_none() {
        let notice =
            "note: no --licence given: the file says the takes' licence is unspecified".to_string();
        args.reporting.notice(&notice);
        notices.push(notice);
    }
    let seconds = db.frames() as f64 / db.fps();
    let skeleton = db.skeleton();
    let retargeted = takes.takes.iter().filter(|t| t.retargeted).count();
    if args.reporting.json {
        let report = json!({
            "out": args.out,
            "bytes": bytes.len(),
            "takes": takes.takes.iter().map(|t| &t.name).collect::<Vec<_>>(),
            "takes_used": takes.takes.len(),
            "retargeted": retargeted,
            "excluded": excluded,
            "skipped": takes.skipped.iter().map(|s| json!({"path": s.path, "reason": s.reason})).collect::<Vec<_>>(),
            "frames": db.frames(),
            "seconds": seconds,
            "fps": db.fps(),
            "rig": {
                "source": takes.rig.source,
                "joints": skeleton.body_joint_names().len(),
                "root": skeleton.joint(0).name,
                "mm_per_unit": db.mm_per_unit(),
                "units": unit_name(db.mm_per_unit()),
            },
            "licence": db.licence(),
            "provenance": db.provenance(),
            "notices": notices,
        });
        args.reporting.print_json(&report)?;
    } else {
        println!("wrote {} ({} bytes)", args.out.display(), bytes.len());
        println!(
            "takes    {} used{}{}{}",
            takes.takes.len(),
            if retargeted > 0 {
                format!(" ({retargeted} retargeted)")
            } else {
                String::new()
            },
            if takes.skipped.is_empty() {
                String::new()
            } else {
                format!(", {} skipped", takes.skipped.len())
            },
            if excluded.is_empty() {
                String::new()
            } else {
                format!(", {} excluded ({})", excluded.len(), excluded.join(", "))
            }
        );
        println!(
            "frames   {} at {} Hz ({:.1} s)",
            db.frames(),
            db.fps(),
            seconds
        );
        println!(
            "rig      {} ({} joints, root {}), {}",
            takes.rig.source.display(),
            skeleton.body_joint_names().len(),
            skeleton.joint(0).name,
            unit_name(db.mm_per_unit())
        );
        println!("licence  {}", db.licence());
    }
    Ok(())
}

/// Refuses an output that is not a `.safetensors` file in an existing directory.
pub fn check_database_output(out: &Path) -> anyhow::Result<()> {
    let is_safetensors = out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("safetensors"));
    if !is_safetensors {
        return Err(UsageError(format!(
            "{}: a database is written as .safetensors",
            out.display()
        ))
        .into());
    }
    let dir = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(UsageError(format!(
            "{}: the output directory {} does not exist",
            out.display(),
            dir.display()
        ))
        .into());
    }
    if out.is_dir() {
        return Err(UsageError(format!("{}: is a directory", out.display())).into());
    }
    Ok(())
}

/// The provenance entries of a build: where the frames came from and how it was made.
fn provenance(args: &BuildArgs, takes: &Takes, excluded: &[String]) -> Vec<(&'static str, String)> {
    let none = |v: String| if v.is_empty() { "none".to_string() } else { v };
    let mut entries = vec![
        ("takes_folder", args.source.takes.display().to_string()),
        ("rig_file", takes.rig.source.display().to_string()),
        ("fps", format!("{}", takes.fps)),
        ("min_seconds", format!("{}", args.source.min_seconds)),
        ("excluded_takes", none(excluded.join(", "))),
        (
            "skipped_takes",
            none(
                takes
                    .skipped
                    .iter()
                    .map(|s| {
                        s.path
                            .file_name()
                            .map(|n| n.to_string_lossy().into_owned())
                            .unwrap_or_default()
                    })
                    .collect::<Vec<_>>()
                    .join(", "),
            ),
        ),
        (
            "built_by",
            format!("motion-cli {} matching build", env!("CARGO_PKG_VERSION")),
        ),
        ("build_date", build_date()),
    ];
    if let Some(map) = &args.source.joint_map {
        entries.push(("joint_map", map.display().to_string()));
    }
    entries
}

/// Today's date (UTC, `YYYY-MM-DD`), or that of `SOURCE_DATE_EPOCH` (reproducible builds).
fn build_date() -> String {
    let seconds = std::env::var("SOURCE_DATE_EPOCH")
        .ok()
        .and_then(|s| s.trim().parse::<i64>().ok())
        .unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs() as i64)
        });
    let (y, m, d) = civil_from_days(seconds.div_euclid(86_400));
    format!("{y:04}-{m:02}-{d:02}")
}

/// The proleptic Gregorian date of a day count since 1970-01-01 (H. Hinnant's algorithm).
fn civil_from_days(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates_from_day_counts() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(19_723), (2024, 1, 1));
        assert_eq!(civil_from_days(19_782), (2024, 2, 29));
        assert_eq!(civil_from_days(-1), (1969, 12, 31));
    }
}
