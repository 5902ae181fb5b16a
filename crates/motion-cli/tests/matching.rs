//! `motion-cli matching build`, `info` on a database and `predict --model DB --path`, through
//! the built binary, on takes the project makes itself (copies of `examples/walk_seed.bvh`, one
//! rescaled to metres) and on the shipped `weights/matching_cmu.safetensors`. No `../shared` data
//! is needed.
mod common;

use common::{bad_input, motion_cli, repo, scratch, walk_seed};

use motion_core::formats::bvh::read_bvh;

/// `walk_seed.bvh` with every offset and root position divided by 1000 (metres).
fn in_metres(text: &str) -> String {
    let mut out = Vec::new();
    let mut motion = false;
    for line in text.lines() {
        let t = line.trim_start();
        if let Some(values) = t.strip_prefix("OFFSET") {
            let indent = &line[..line.len() - t.len()];
            let v: Vec<f64> = values
                .split_whitespace()
                .map(|x| x.parse().unwrap())
                .collect();
            out.push(format!(
                "{indent}OFFSET {} {} {}",
                v[0] / 1000.0,
                v[1] / 1000.0,
                v[2] / 1000.0
            ));
        } else if motion && !t.is_empty() && !t.starts_with("Frame") {
            let mut v: Vec<f64> = t.split_whitespace().map(|x| x.parse().unwrap()).collect();
            for x in &mut v[..3] {
                *x /= 1000.0;
            }
            let row: Vec<String> = v.iter().map(|x| x.to_string()).collect();
            out.push(row.join(" "));
        } else {
            motion |= t == "MOTION";
            out.push(line.to_string());
        }
    }
    out.join("\n") + "\n"
}

#[test]
fn a_folder_of_takes_builds_a_database_that_predict_steers_along_a_path() {
    let dir = scratch("build");
    let takes = dir.join("takes");
    std::fs::create_dir_all(&takes).unwrap();
    let text = std::fs::read_to_string(walk_seed()).unwrap();
    std::fs::write(takes.join("a_walk.bvh"), &text).unwrap();
    std::fs::write(takes.join("b_walk_m.bvh"), in_metres(&text)).unwrap();
    std::fs::write(takes.join("c_broken.bvh"), "HIERARCHY\nROOT").unwrap();
    std::fs::write(takes.join("d_held_out.bvh"), &text).unwrap();
    let db = dir.join("db.safetensors");
    let out = motion_cli([
        "matching".as_ref(),
        "build".as_ref(),
        "--takes".as_ref(),
        takes.as_os_str(),
        "--exclude".as_ref(),
        "d_held_out".as_ref(),
        "--licence".as_ref(),
        "made by the project's own code".as_ref(),
        "--out".as_ref(),
        db.as_os_str(),
        "--json".as_ref(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["takes_used"], 2, "{report}");
    assert_eq!(report["excluded"][0], "d_held_out");
    let skipped = report["skipped"].as_array().unwrap();
    assert_eq!(skipped.len(), 1, "{report}");
    assert!(skipped[0]["path"]
        .as_str()
        .unwrap()
        .ends_with("c_broken.bvh"));
    // `info` reads it back: format, takes, licence.
    let info = motion_cli(["info".as_ref(), db.as_os_str(), "--json".as_ref()]);
    assert!(info.status.success());
    let info: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(info["format"], "motion-matching");
    assert_eq!(info["licence"], "made by the project's own code");
    // Steered along a path to a point 3 m to the side: the BVH is on the takes' rig and ends
    // near it.
    let path = dir.join("path.json");
    std::fs::write(&path, r#"{"waypoints": [[3.0, 0.0]], "speed": 0.7}"#).unwrap();
    let bvh = dir.join("out.bvh");
    let out = motion_cli([
        "predict".as_ref(),
        "--model".as_ref(),
        db.as_os_str(),
        "--seed".as_ref(),
        walk_seed().as_os_str(),
        "--path".as_ref(),
        path.as_os_str(),
        "--seconds".as_ref(),
        "8".as_ref(),
        "--out".as_ref(),
        bvh.as_os_str(),
        "--json".as_ref(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let (x, z) = (
        report["seed_end"]["x"].as_f64().unwrap(),
        report["seed_end"]["z"].as_f64().unwrap(),
    );
    let written = read_bvh(&bvh).unwrap();
    let seed = read_bvh(walk_seed()).unwrap();
    assert_eq!(written.skeleton.len(), seed.skeleton.len());
    let last = written.frames.row(written.frames.nrows() - 1);
    // The walk seed's units are millimetres.
    let end = (last[0] / 1000.0, last[2] / 1000.0);
    let start_distance = ((3.0 - x).powi(2) + z.powi(2)).sqrt();
    let end_distance = ((3.0 - end.0).powi(2) + end.1.powi(2)).sqrt();
    assert!(
        end_distance < 1.0 && end_distance < start_distance - 1.0,
        "from ({x:.2}, {z:.2}) to {end:?}"
    );
}

#[test]
fn the_shipped_database_plays_on_its_rig_and_bad_input_is_refused() {
    let dir = scratch("refusals");
    let db = repo().join("weights/matching_cmu.safetensors");
    let out = dir.join("out.bvh");
    let run = motion_cli([
        "predict".as_ref(),
        "--model".as_ref(),
        db.as_os_str(),
        "--seed".as_ref(),
        walk_seed().as_os_str(),
        "--seconds".as_ref(),
        "2".as_ref(),
        "--out".as_ref(),
        out.as_os_str(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let written = read_bvh(&out).unwrap();
    assert_eq!(written.skeleton.joint(0).name, "pelvis");
    std::fs::remove_file(&out).unwrap();
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    bad_input(
        &dir,
        &[
            &"matching",
            &"build",
            &"--takes",
            &"empty",
            &"--out",
            &"db.safetensors",
        ],
        &["empty"],
    );
    bad_input(
        &dir,
        &[
            &"matching",
            &"build",
            &"--takes",
            &"empty",
            &"--out",
            &"db.bvh",
        ],
        &["db.bvh", ".safetensors"],
    );
    std::fs::write(dir.join("path.json"), r#"{"waypoints": "nowhere"}"#).unwrap();
    bad_input(
        &dir,
        &[
            &"predict",
            &"--model",
            &db,
            &"--seed",
            &walk_seed(),
            &"--path",
            &"path.json",
            &"--out",
            &"x.bvh",
        ],
        &["path.json"],
    );
    bad_input(
        &dir,
        &[
            &"predict",
            &"--model",
            &db,
            &"--seed",
            &walk_seed(),
            &"--action",
            &"walking",
            &"--out",
            &"x.bvh",
        ],
        &["--action", "no actions"],
    );
}
