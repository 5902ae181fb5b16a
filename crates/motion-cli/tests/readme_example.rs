//! The README's first example over 60 s with the shipped game default: `motion-cli predict --seed
//! examples/walk_seed.bvh --action walking --frames 1500 --rng-seed S` (S = 0, 1, 2, the seeds
//! `docs/models.md` reports), scored by `motion-cli score --seed-frames 50 --action walking
//! --metric speed_ratio,drift,foot_contact`: on the floor, upright and moving in every window
//! from 0-2 s to 50-60 s.
//!
//! `score --action` reads the real walking statistics from the H3.6M data (`MOTION_DATA_DIR`,
//! default `<repo>/../shared/data`); without it the test is skipped with a visible message.
//!
//! The speed bound per sequence is 0.45, under the target of 0.5, because a stochastic model's
//! 60 s closed loop is chaotic: each SIMD path's float rounding (`MOTION_SIMD`) draws a different
//! trajectory from the same seed, and their smallest window ratios differ by up to 0.04
//! (avx512 / avx2 / portable, rng seeds 0-2: 0.515-0.573 / 0.554-0.562 / 0.543-0.572, measured
//! on a 2-core AMD EPYC VM with AVX-512, 2026-12-07). The mean over the three sequences must
//! reach 0.5 in every window. The game default's tensors at noise scale 0.75 instead of its
//! 0.25 fail it (rng seed 0: 0.41 in the 30-40 s window).
mod common;

use common::{data_dir, motion_cli, scratch, walk_seed};
use serde_json::Value;
use std::ffi::{OsStr, OsString};

const RNG_SEEDS: [u32; 3] = [0, 1, 2];

fn args(list: &[&dyn AsRef<OsStr>]) -> Vec<OsString> {
    list.iter().map(|a| a.as_ref().to_owned()).collect()
}

fn number(v: &Value, what: &str) -> f64 {
    v.as_f64()
        .unwrap_or_else(|| panic!("{what}: expected a number, found {v}"))
}

/// One window list of the score report, `field` of each window.
fn per_window(report: &Value, metric: &str, field: &str) -> Vec<f64> {
    report[metric]["windows"]
        .as_array()
        .unwrap_or_else(|| panic!("{metric}.windows missing in {report}"))
        .iter()
        .map(|w| number(&w[field], &format!("{metric}.{field}")))
        .collect()
}

#[test]
fn the_readme_walk_stays_on_the_floor_upright_and_moving_for_60_s() {
    let data = data_dir();
    if !data.join("h3.6m/dataset/S5/walking_1.txt.gz").is_file() {
        eprintln!(
            "SKIPPED: the README example's 60 s check needs the walking statistics in {} (set \
             MOTION_DATA_DIR)",
            data.display()
        );
        return;
    }
    let dir = scratch("readme-walk");
    let mut speeds: Vec<Vec<f64>> = Vec::new();
    for seed in RNG_SEEDS {
        let out = dir.join(format!("walk{seed}.bvh"));
        let predicted = motion_cli(args(&[
            &"predict",
            &"--seed",
            &walk_seed(),
            &"--action",
            &"walking",
            &"--frames",
            &"1500",
            &"--rng-seed",
            &seed.to_string(),
            &"--out",
            &out,
        ]));
        assert!(
            predicted.status.success(),
            "predict, rng seed {seed}: {}",
            String::from_utf8_lossy(&predicted.stderr)
        );
        let scored = motion_cli(args(&[
            &"score",
            &"--pred",
            &out,
            &"--seed-frames",
            &"50",
            &"--action",
            &"walking",
            &"--metric",
            &"speed_ratio,drift,foot_contact",
            &"--data",
            &data,
            &"--json",
        ]));
        assert!(
            scored.status.success(),
            "score, rng seed {seed}: {}",
            String::from_utf8_lossy(&scored.stderr)
        );
        let report: Value = serde_json::from_slice(&scored.stdout).expect("score --json is JSON");
        assert_eq!(report["frames"], 1500, "{report}");
        let airborne = per_window(&report, "foot_contact", "airborne_fraction");
        assert_eq!(airborne.len(), 9, "0-2 s ... 50-60 s");
        assert!(
            airborne.iter().all(|&a| a == 0.0),
            "rng seed {seed}: both feet more than 0.1 m over the floor in {airborne:?}"
        );
        for field in ["hip_height_within_p95", "lean_within_p95"] {
            let within = per_window(&report, "drift", field);
            assert!(
                within.iter().all(|&w| w == 1.0),
                "rng seed {seed}: {field} {within:?} (hip height or lean drifts past real walking's p95)"
            );
        }
        let speed = per_window(&report, "speed_ratio", "ratio");
        assert!(
            speed.iter().all(|&s| s >= 0.45),
            "rng seed {seed}: the body slows to {speed:?} of real walking's joint speed"
        );
        speeds.push(speed);
    }
    for (w, column) in (0..speeds[0].len()).map(|w| (w, speeds.iter().map(move |s| s[w]))) {
        let mean = column.sum::<f64>() / RNG_SEEDS.len() as f64;
        assert!(
            mean >= 0.5,
            "window {w}: mean speed ratio {mean:.3} over rng seeds {RNG_SEEDS:?} (all: {speeds:?})"
        );
    }
}
