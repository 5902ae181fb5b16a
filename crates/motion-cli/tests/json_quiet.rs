//! Every subcommand keeps the README's promise: with `--quiet --json` on valid input it prints
//! exactly one JSON object on stdout and nothing on stderr; errors stay one line on stderr with
//! exit status 2 whatever the flags.
mod common;

use std::ffi::OsString;
use std::path::Path;

use common::{data_dir, motion_cli, repo, scratch};
use serde_json::Value;

/// Runs `motion-cli ARGS --quiet --json`; checks exit 0, empty stderr and one JSON object.
fn quiet_json(args: &[&OsStr]) -> Value {
    let mut all: Vec<OsString> = args.iter().map(|a| a.to_os_string()).collect();
    all.extend(["--quiet".into(), "--json".into()]);
    let out = motion_cli(&all);
    let what = format!(
        "motion-cli {}",
        all.iter()
            .map(|a| a.to_string_lossy())
            .collect::<Vec<_>>()
            .join(" ")
    );
    assert!(
        out.status.success(),
        "{what}: exit {:?}: {}",
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.stderr.is_empty(),
        "{what}: stderr is not empty: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "{what}: stdout is not one JSON object ({e}): {}",
            String::from_utf8_lossy(&out.stdout)
        )
    })
}

use std::ffi::OsStr;

fn os(p: &Path) -> &OsStr {
    p.as_os_str()
}

#[test]
fn every_subcommand_prints_one_json_object_and_nothing_on_stderr() {
    let dir = scratch("json-quiet");
    let seed_bvh = repo().join("examples/walk_seed.bvh");
    let model = repo().join("tests/fixtures/parity/vgru_d.safetensors");
    let txt = dir.join("walk.txt");
    let npy = dir.join("walk.npy");
    let pred = dir.join("pred.bvh");
    let svg = dir.join("walk.svg");

    // convert: resampled, so it has a notice to keep off stderr (it goes into the JSON).
    let report = quiet_json(&[
        OsStr::new("convert"),
        os(&seed_bvh),
        os(&txt),
        OsStr::new("--fps"),
        OsStr::new("12.5"),
    ]);
    assert_eq!(report["output"]["format"], "exp-map text");
    assert_eq!(report["output"]["fps"], 12.5);
    assert_eq!(report["output"]["skeleton"], "H3.6M 32-joint");
    assert_eq!(report["output"]["shape"][1], 99);
    assert!(report["notices"][0].as_str().unwrap().contains("resampled"));
    let frames = report["output"]["frames"].as_u64().unwrap();
    // Frames 0, 2, 4, ... are kept.
    assert_eq!(
        report["input"]["frames"].as_u64().unwrap().div_ceil(2),
        frames
    );
    assert!(txt.is_file());
    let report = quiet_json(&[OsStr::new("convert"), os(&seed_bvh), os(&npy)]);
    assert_eq!(report["output"]["path"], npy.to_str().unwrap());

    let report = quiet_json(&[OsStr::new("info"), os(&model)]);
    assert_eq!(report["config"]["architecture"], "vgru-d");

    let report = quiet_json(&[
        OsStr::new("predict"),
        OsStr::new("--model"),
        os(&model),
        OsStr::new("--seed"),
        os(&seed_bvh),
        OsStr::new("--frames"),
        OsStr::new("10"),
        OsStr::new("--out"),
        os(&pred),
    ]);
    assert_eq!(report["predicted_frames"], 10);
    assert!(pred.is_file());

    let report = quiet_json(&[
        OsStr::new("score"),
        OsStr::new("--gt"),
        os(&npy),
        OsStr::new("--pred"),
        os(&npy),
    ]);
    assert_eq!(report["npss"].as_f64(), Some(0.0));

    // render: a first frame that leans would be a notice; either way stderr stays empty.
    let report = quiet_json(&[
        OsStr::new("render"),
        os(&pred),
        OsStr::new("--out"),
        os(&svg),
    ]);
    assert!(report["bytes"].as_u64().unwrap() > 0);

    let report = quiet_json(&[
        OsStr::new("bench"),
        OsStr::new("--hidden"),
        OsStr::new("8"),
        OsStr::new("--batch"),
        OsStr::new("1"),
        OsStr::new("--steps"),
        OsStr::new("2"),
    ]);
    assert!(report["results"].as_array().is_some_and(|r| !r.is_empty()));

    let data = data_dir();
    if !data.join("h3.6m/dataset/S5/walking_1.txt.gz").is_file() {
        eprintln!(
            "SKIPPED: eval --quiet --json needs the H3.6M data in {} (set MOTION_DATA_DIR)",
            data.display()
        );
        return;
    }
    let report = quiet_json(&[
        OsStr::new("eval"),
        OsStr::new("--data"),
        os(&data),
        OsStr::new("--model"),
        os(&model),
        OsStr::new("--actions"),
        OsStr::new("walking"),
        OsStr::new("--horizon"),
        OsStr::new("25"),
    ]);
    assert_eq!(report["actions"][0]["action"], "walking");
}

#[test]
fn errors_stay_one_line_on_stderr_with_exit_2_whatever_the_flags() {
    let dir = scratch("json-quiet-errors");
    let missing = dir.join("missing.bvh");
    for flags in [
        &[][..],
        &["--quiet"][..],
        &["--json"][..],
        &["--quiet", "--json"][..],
    ] {
        let mut args: Vec<OsString> = vec![
            "convert".into(),
            missing.clone().into(),
            dir.join("out.txt").into(),
        ];
        args.extend(flags.iter().map(OsString::from));
        let out = motion_cli(&args);
        assert_eq!(out.status.code(), Some(2), "{flags:?}");
        assert!(
            out.stdout.is_empty(),
            "{flags:?}: {}",
            String::from_utf8_lossy(&out.stdout)
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(stderr.lines().count(), 1, "{flags:?}: {stderr}");
        assert!(stderr.contains("missing.bvh"), "{stderr}");
        assert!(!dir.join("out.txt").exists());
    }
}
