//! Bad input, every class the CLI promises to handle, across commands: missing file, malformed
//! BVH (with its line), skeleton mismatch, NaN/Inf, too few frames, unknown action, weights that
//! fail validation, output directory missing or output not writable.
//!
//! Each case must exit with status 2, print exactly one line on stderr (`error: ...`) naming the
//! file and the problem, never panic, and leave no output (or temporary) file behind.
mod common;

use common::{bad_input, fixture_model, repo, scratch, walk_frames, walk_seed, walk_with_frames};
use std::path::PathBuf;
use std::process::Command;

use motion_core::formats::npy::write_npy;
use ndarray::Array2;

#[test]
fn missing_file() {
    let dir = scratch("missing");
    let m = fixture_model();
    bad_input(
        &dir,
        &[
            &"predict",
            &"--model",
            &m,
            &"--seed",
            &"nope.bvh",
            &"--out",
            &"p.bvh",
        ],
        &["nope.bvh"],
    );
    bad_input(
        &dir,
        &[&"render", &"nope.bvh", &"--out", &"p.png"],
        &["nope.bvh"],
    );
    bad_input(&dir, &[&"convert", &"nope.txt", &"p.bvh"], &["nope.txt"]);
    bad_input(
        &dir,
        &[
            &"predict",
            &"--model",
            &"nope.safetensors",
            &"--seed",
            &walk_seed(),
            &"--out",
            &"p.bvh",
        ],
        &["nope.safetensors"],
    );
    bad_input(&dir, &[&"info", &"nope.safetensors"], &["nope.safetensors"]);
    bad_input(
        &dir,
        &[&"score", &"--gt", &"gt.npy", &"--pred", &"nope.npy"],
        &["nope.npy"],
    );
    bad_input(
        &dir,
        &[&"eval", &"--model", &m, &"--data", &"no_data_here"],
        &["no_data_here", "does not exist"],
    );
}

#[test]
fn malformed_bvh_names_its_line() {
    let dir = scratch("malformed");
    std::fs::write(
        dir.join("bad.bvh"),
        "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 zero\n",
    )
    .unwrap();
    let m = fixture_model();
    bad_input(
        &dir,
        &[
            &"predict", &"--model", &m, &"--seed", &"bad.bvh", &"--out", &"p.bvh",
        ],
        &["bad.bvh:4:", "OFFSET"],
    );
    bad_input(
        &dir,
        &[&"render", &"bad.bvh", &"--out", &"p.svg"],
        &["bad.bvh:4:"],
    );
    bad_input(&dir, &[&"convert", &"bad.bvh", &"p.txt"], &["bad.bvh:4:"]);
    // A frame line with a missing value.
    let mut frames = walk_frames();
    frames[3] = frames[3].rsplit_once(' ').unwrap().0.to_string();
    std::fs::write(dir.join("short_line.bvh"), walk_with_frames(&frames)).unwrap();
    let line = std::fs::read_to_string(dir.join("short_line.bvh"))
        .unwrap()
        .lines()
        .count()
        - frames.len()
        + 4;
    bad_input(
        &dir,
        &[
            &"predict",
            &"--model",
            &m,
            &"--seed",
            &"short_line.bvh",
            &"--out",
            &"p.bvh",
        ],
        &[&format!("short_line.bvh:{line}:")],
    );
}

#[test]
fn skeleton_mismatch_says_what_differs() {
    let dir = scratch("skeleton");
    std::fs::copy(
        repo().join("tests/fixtures/bvh/cmu_style_odd_spacing.bvh"),
        dir.join("cmu.bvh"),
    )
    .unwrap();
    let m = fixture_model();
    bad_input(
        &dir,
        &[
            &"predict", &"--model", &m, &"--seed", &"cmu.bvh", &"--out", &"p.bvh",
        ],
        // A CMU-style rig is retargeted (it is not refused), but 5 frames are too few.
        &["cmu.bvh", "needs at least 10"],
    );
    // Same joint count, one joint renamed.
    let text = std::fs::read_to_string(walk_seed())
        .unwrap()
        .replace("JOINT LeftForeArm", "JOINT LeftElbow");
    std::fs::write(dir.join("renamed.bvh"), text).unwrap();
    bad_input(
        &dir,
        &[
            &"predict",
            &"--model",
            &m,
            &"--seed",
            &"renamed.bvh",
            &"--out",
            &"p.bvh",
        ],
        &["renamed.bvh", "#18", "\"LeftElbow\"", "\"LeftForeArm\""],
    );
    // An exp-map file of the wrong width.
    write_npy(dir.join("wide.npy"), &Array2::<f64>::zeros((60, 117))).unwrap();
    bad_input(
        &dir,
        &[
            &"predict",
            &"--model",
            &m,
            &"--seed",
            &"wide.npy",
            &"--out",
            &"p.bvh",
        ],
        &["wide.npy", "117 values per frame", "99"],
    );
}

#[test]
fn nan_and_infinity() {
    let dir = scratch("nan");
    let m = fixture_model();
    let mut seed = Array2::<f64>::zeros((60, 99));
    seed[[12, 40]] = f64::NAN;
    write_npy(dir.join("nan.npy"), &seed).unwrap();
    bad_input(
        &dir,
        &[
            &"predict", &"--model", &m, &"--seed", &"nan.npy", &"--out", &"p.bvh",
        ],
        &["nan.npy", "frame 12", "NaN"],
    );
    bad_input(
        &dir,
        &[&"render", &"nan.npy", &"--out", &"p.png"],
        &["nan.npy", "NaN"],
    );
    seed[[12, 40]] = f64::INFINITY;
    write_npy(dir.join("inf.npy"), &seed).unwrap();
    bad_input(
        &dir,
        &[
            &"predict", &"--model", &m, &"--seed", &"inf.npy", &"--out", &"p.npy",
        ],
        &["inf.npy", "infinite"],
    );
    std::fs::write(
        dir.join("nan.txt"),
        format!("{}\n{}\n", ["0"; 99].join(","), ["nan"; 99].join(",")),
    )
    .unwrap();
    bad_input(
        &dir,
        &[
            &"predict", &"--model", &m, &"--seed", &"nan.txt", &"--out", &"p.bvh",
        ],
        &["nan.txt:2:", "finite"],
    );
    let mut frames = walk_frames();
    frames[20] = frames[20].replacen(" 0 ", " inf ", 1);
    std::fs::write(dir.join("inf.bvh"), walk_with_frames(&frames)).unwrap();
    bad_input(
        &dir,
        &[
            &"predict", &"--model", &m, &"--seed", &"inf.bvh", &"--out", &"p.bvh",
        ],
        &["inf.bvh:", "inf"],
    );
}

#[test]
fn too_few_frames_names_the_minimum() {
    let dir = scratch("short");
    let m = fixture_model();
    std::fs::write(dir.join("short.bvh"), walk_with_frames(&walk_frames()[..5])).unwrap();
    bad_input(
        &dir,
        &[
            &"predict",
            &"--model",
            &m,
            &"--seed",
            &"short.bvh",
            &"--out",
            &"p.bvh",
        ],
        &["short.bvh", "5 frames", "at least 10"],
    );
    // 15 exp-map frames read as 50 Hz leave 8 at the model's 25 Hz.
    write_npy(dir.join("short.npy"), &Array2::<f64>::zeros((15, 99))).unwrap();
    bad_input(
        &dir,
        &[
            &"predict",
            &"--model",
            &m,
            &"--seed",
            &"short.npy",
            &"--out",
            &"p.npy",
            &"--quiet",
        ],
        &["short.npy", "8 frames", "at least 10"],
    );
    bad_input(
        &dir,
        &[
            &"render",
            &"short.bvh",
            &"--seed-frames",
            &"6",
            &"--out",
            &"p.png",
        ],
        &["short.bvh", "--seed-frames 6", "5 frames"],
    );
}

#[test]
fn unknown_action_lists_the_valid_ones() {
    let dir = scratch("action");
    let m = fixture_model();
    bad_input(
        &dir,
        &[
            &"predict",
            &"--model",
            &m,
            &"--seed",
            &walk_seed(),
            &"--action",
            &"walkin",
            &"--out",
            &"p.bvh",
        ],
        &[
            "unknown action `walkin`",
            "valid actions: directions,",
            "walking,",
            "walkingtogether",
        ],
    );
    let gru = repo().join("tests/fixtures/parity/gru_d.safetensors");
    bad_input(
        &dir,
        &[
            &"predict",
            &"--model",
            &gru,
            &"--seed",
            &walk_seed(),
            &"--action",
            &"walking",
            &"--out",
            &"p.bvh",
        ],
        &["--action", "not action-conditioned"],
    );
    // eval, on the real data (it checks the data directory first).
    let data = std::env::var_os("MOTION_DATA_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join("../shared/data"));
    if data.join("h3.6m/dataset/S5").is_dir() {
        bad_input(
            &dir,
            &[
                &"eval",
                &"--model",
                &m,
                &"--data",
                &data,
                &"--actions",
                &"walkin",
            ],
            &["unknown action `walkin`", "walking"],
        );
    } else {
        eprintln!(
            "SKIPPED: eval's unknown-action check needs the H3.6M data (set MOTION_DATA_DIR)"
        );
    }
}

#[test]
fn weights_that_fail_validation() {
    let dir = scratch("weights");
    let bytes = std::fs::read(fixture_model()).unwrap();
    std::fs::write(dir.join("truncated.safetensors"), &bytes[..3000]).unwrap();
    // Same length, invalid config: a negative frame rate.
    let text = String::from_utf8_lossy(&bytes[..4096]).into_owned();
    assert!(
        text.contains("\\\"fps\\\": 25"),
        "fixture header layout changed"
    );
    let mut bad = bytes.clone();
    let at = text.find("\\\"fps\\\": 25").unwrap() + "\\\"fps\\\": ".len();
    bad[at..at + 2].copy_from_slice(b"-1");
    std::fs::write(dir.join("negative_fps.safetensors"), &bad).unwrap();
    for (file, problem) in [
        ("truncated.safetensors", "not a valid safetensors file"),
        ("negative_fps.safetensors", "fps -1"),
    ] {
        bad_input(
            &dir,
            &[
                &"predict",
                &"--model",
                &file,
                &"--seed",
                &walk_seed(),
                &"--out",
                &"p.bvh",
            ],
            &[file, problem],
        );
        bad_input(&dir, &[&"info", &file], &[file, problem]);
    }
}

#[test]
fn output_directory_missing_or_not_writable() {
    let dir = scratch("output");
    let m = fixture_model();
    bad_input(
        &dir,
        &[
            &"predict",
            &"--model",
            &m,
            &"--seed",
            &walk_seed(),
            &"--out",
            &"missing/p.bvh",
        ],
        &["missing/p.bvh", "does not exist"],
    );
    bad_input(
        &dir,
        &[&"render", &walk_seed(), &"--out", &"missing/p.gif"],
        &["missing/p.gif", "does not exist"],
    );
    bad_input(
        &dir,
        &[&"convert", &walk_seed(), &"missing/p.txt"],
        &["missing/p.txt"],
    );
    // A directory where the output file should go: the rename fails, the temporary file goes.
    std::fs::create_dir(dir.join("taken.bvh")).unwrap();
    std::fs::create_dir(dir.join("taken.png")).unwrap();
    bad_input(
        &dir,
        &[
            &"predict",
            &"--model",
            &m,
            &"--seed",
            &walk_seed(),
            &"--out",
            &"taken.bvh",
        ],
        &["taken.bvh"],
    );
    bad_input(
        &dir,
        &[&"render", &walk_seed(), &"--out", &"taken.png"],
        &["taken.png", "cannot write"],
    );
    // Batch mode needs an existing output directory.
    bad_input(
        &dir,
        &[
            &"predict",
            &"--model",
            &m,
            &"--seed",
            &repo().join("examples"),
            &"--out",
            &"nowhere",
        ],
        &["nowhere", "existing directory"],
    );
}

#[test]
fn an_output_that_is_an_input_is_refused() {
    let dir = scratch("same-file");
    let m = fixture_model();
    let seed = dir.join("walk.bvh");
    std::fs::copy(walk_seed(), &seed).unwrap();
    let original = std::fs::read(&seed).unwrap();
    bad_input(
        &dir,
        &[
            &"predict",
            &"--model",
            &m,
            &"--seed",
            &"walk.bvh",
            &"--out",
            &"./walk.bvh",
        ],
        &["walk.bvh", "also an input"],
    );
    bad_input(
        &dir,
        &[
            &"predict",
            &"--model",
            &m,
            &"--seed",
            &"walk.bvh",
            &"--out",
            &"p.bvh",
            &"--truth",
            &"p.bvh",
        ],
        &["p.bvh", "also an input"],
    );
    assert_eq!(
        std::fs::read(&seed).unwrap(),
        original,
        "the seed was overwritten"
    );
}

#[test]
fn predictions_too_large_for_memory_are_refused_up_front() {
    let dir = scratch("too-large");
    let m = fixture_model();
    for (samples, frames) in [
        ("1000000000", "100"),
        ("1", "18446744073709551615"),
        ("10000", "10000"),
    ] {
        bad_input(
            &dir,
            &[
                &"predict",
                &"--model",
                &m,
                &"--seed",
                &walk_seed(),
                &"--out",
                &"p.npy",
                &"--samples",
                &samples,
                &"--frames",
                &frames,
            ],
            &["over the limit"],
        );
    }
}

#[test]
fn score_pairs_folders_by_file_name() {
    let dir = scratch("pairing");
    for (folder, names) in [("gt", ["a.npy", "b.npy"]), ("pred", ["a.npy", "c.npy"])] {
        std::fs::create_dir_all(dir.join(folder)).unwrap();
        for name in names {
            let array = ndarray::Array3::<f64>::zeros((1, 10, 6));
            motion_core::formats::npy::write_npy(dir.join(folder).join(name), &array).unwrap();
        }
    }
    bad_input(
        &dir,
        &[
            &"score",
            &"--gt",
            &"gt",
            &"--pred",
            &"pred",
            &"--metric",
            &"npss",
        ],
        &["no file named", "c.npy", "paired by file name"],
    );
}

#[test]
fn a_huge_name_in_a_file_gives_a_short_error_line() {
    let dir = scratch("huge-name");
    let name = "J".repeat(5_000_000);
    let text = std::fs::read_to_string(walk_seed()).unwrap().replacen(
        "ROOT Hips",
        &format!("ROOT {name}"),
        1,
    );
    std::fs::write(dir.join("big.bvh"), text).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_motion-cli"))
        .current_dir(&dir)
        .args(["predict", "--model"])
        .arg(fixture_model())
        .args(["--seed", "big.bvh", "--out", "p.bvh"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}",
        &stderr[..stderr.len().min(300)]
    );
    assert!(
        stderr.len() < 1200 && stderr.contains("big.bvh"),
        "{} bytes",
        stderr.len()
    );
}

#[test]
fn one_frame_rate_rule_for_every_command() {
    // A Frame Time in milliseconds (20 for 50 Hz) or one of 1e-9 s, and --input-fps outside
    // 1 ..= 10,000: refused by convert, render (and predict, tested with the seeds) alike.
    let dir = scratch("rates");
    let text = walk_with_frames(&walk_frames());
    for (name, frame_time, expected) in [
        ("ms.bvh", "20", "milliseconds"),
        ("fast.bvh", "1e-9", "fps"),
    ] {
        std::fs::write(
            dir.join(name),
            text.replace("Frame Time: 0.04", &format!("Frame Time: {frame_time}")),
        )
        .unwrap();
        bad_input(&dir, &[&"convert", &name, &"o.npy"], &[name, expected]);
        bad_input(
            &dir,
            &[&"render", &name, &"--out", &"o.gif"],
            &[name, expected],
        );
        bad_input(
            &dir,
            &[
                &"render",
                &walk_seed(),
                &"--compare",
                &name,
                &"--out",
                &"o.gif",
            ],
            &[name, expected],
        );
        std::fs::remove_file(dir.join(name)).unwrap();
    }
    std::fs::write(dir.join("w.bvh"), &text).unwrap();
    bad_input(
        &dir,
        &[&"convert", &"w.bvh", &"o.npy", &"--fps", &"0.5"],
        &["--fps", "0.5 fps"],
    );
    bad_input(
        &dir,
        &[&"convert", &"w.bvh", &"o.npy", &"--fps", &"1e300"],
        &["--fps"],
    );
    bad_input(
        &dir,
        &[
            &"render",
            &"w.bvh",
            &"--out",
            &"o.gif",
            &"--input-fps",
            &"0",
        ],
        &["--input-fps"],
    );
}

#[test]
fn render_sizes_are_bounded() {
    let dir = scratch("render-sizes");
    std::fs::write(dir.join("w.bvh"), walk_with_frames(&walk_frames())).unwrap();
    bad_input(
        &dir,
        &[
            &"render", &"w.bvh", &"--out", &"o.png", &"--cells", &"1000000",
        ],
        &["--cells", "400"],
    );
    bad_input(
        &dir,
        &[&"render", &"w.bvh", &"--out", &"o.png", &"--columns", &"0"],
        &["--columns"],
    );
    // 40,000 frames: over the 30,000-frame limit of an animation, refused before drawing
    let many: Vec<String> = walk_frames().into_iter().cycle().take(40_000).collect();
    std::fs::write(dir.join("long.bvh"), walk_with_frames(&many)).unwrap();
    bad_input(
        &dir,
        &[&"render", &"long.bvh", &"--out", &"o.gif"],
        &["long.bvh", "30000"],
    );
}

#[test]
fn only_regular_files_are_read() {
    // A symlink to /dev/zero used to be read until 8 GB; a directory or a FIFO is no file either.
    let dir = scratch("regular");
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.bvh")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.safetensors")).unwrap();
    std::fs::create_dir(dir.join("folder.npy")).unwrap();
    bad_input(
        &dir,
        &[&"convert", &"zero.bvh", &"o.npy"],
        &["zero.bvh", "not a regular file"],
    );
    bad_input(
        &dir,
        &[&"convert", &"folder.npy", &"o.bvh"],
        &["folder.npy", "not a regular file"],
    );
    bad_input(
        &dir,
        &[&"info", &"zero.safetensors"],
        &["zero.safetensors", "not a regular file"],
    );
    bad_input(
        &dir,
        &[
            &"predict",
            &"--model",
            &"zero.safetensors",
            &"--seed",
            &walk_seed(),
            &"--out",
            &"o.bvh",
        ],
        &["zero.safetensors", "not a regular file"],
    );
}

/// A FIFO named as weights, a motion or a joint map is refused at once (opening one for reading
/// blocks until a writer comes).
#[cfg(unix)]
#[test]
fn fifos_as_inputs_are_refused_not_waited_on() {
    let dir = scratch("fifo-inputs");
    for name in ["w.safetensors", "m.npy", "map.json"] {
        let made = Command::new("mkfifo").arg(dir.join(name)).status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("SKIPPED: mkfifo is not available");
            return;
        }
    }
    let out = dir.join("o.bvh");
    bad_input(
        &dir,
        &[
            &"predict",
            &"--seed",
            &walk_seed(),
            &"--model",
            &dir.join("w.safetensors"),
            &"--out",
            &out,
        ],
        &["w.safetensors", "not a regular file"],
    );
    bad_input(
        &dir,
        &[
            &"score",
            &"--gt",
            &dir.join("m.npy"),
            &"--pred",
            &dir.join("m.npy"),
            &"--metric",
            &"euler",
        ],
        &["m.npy", "not a regular file"],
    );
    bad_input(
        &dir,
        &[
            &"predict",
            &"--seed",
            &walk_seed(),
            &"--joint-map",
            &dir.join("map.json"),
            &"--out",
            &out,
        ],
        &["map.json", "not a regular file"],
    );
}

/// An output that is (after symlinks) one of the command's inputs is refused, and the input is
/// left as it was.
#[test]
fn outputs_that_are_inputs_are_refused_for_every_command() {
    let dir = scratch("outputs-are-inputs");
    let text = dir.join("a.txt");
    let row = vec!["0.01"; 99].join(",");
    std::fs::write(&text, vec![row; 60].join("\n")).unwrap();
    let model = dir.join("m.npy");
    std::fs::copy(fixture_model(), &model).unwrap();
    let map = dir.join("map.txt");
    std::fs::write(&map, "{}").unwrap();
    #[cfg(unix)]
    std::os::unix::fs::symlink(&text, dir.join("link.txt")).unwrap();
    let before: Vec<Vec<u8>> = [&text, &model, &map]
        .iter()
        .map(|p| std::fs::read(p).unwrap())
        .collect();
    bad_input(&dir, &[&"convert", &text, &text], &["also an input"]);
    bad_input(
        &dir,
        &[&"convert", &"--fps", &"25", &text, &text],
        &["also an input"],
    );
    #[cfg(unix)]
    bad_input(
        &dir,
        &[&"convert", &text, &dir.join("link.txt")],
        &["also an input"],
    );
    bad_input(
        &dir,
        &[
            &"predict",
            &"--seed",
            &walk_seed(),
            &"--joint-map",
            &map,
            &"--out",
            &map,
        ],
        &["map.txt", "also an input"],
    );
    bad_input(
        &dir,
        &[
            &"eval",
            &"--data",
            &dir,
            &"--model",
            &model,
            &"--save-predictions",
            &model,
        ],
        &["m.npy", "also an input"],
    );
    bad_input(
        &dir,
        &[
            &"eval",
            &"--data",
            &dir,
            &"--save-predictions",
            &dir.join("p.txt"),
        ],
        &["p.txt", ".npy"],
    );
    let after: Vec<Vec<u8>> = [&text, &model, &map]
        .iter()
        .map(|p| std::fs::read(p).unwrap())
        .collect();
    assert!(before == after, "an input was changed");
}

/// Usage errors are one line and exit 2; typed control characters come back escaped; numbers
/// are printed short.
#[test]
fn error_lines_are_one_short_printable_line() {
    let dir = scratch("error-lines");
    bad_input(
        &dir,
        &[&"predict", &"--bogus"],
        &["unexpected argument '--bogus'", "--help"],
    );
    bad_input(
        &dir,
        &[&"predict"],
        &["required arguments", "--seed", "--out"],
    );
    let out = dir.join("o.bvh");
    let (seed, model) = (walk_seed(), fixture_model());
    bad_input(
        &dir,
        &[
            &"predict",
            &"--seed",
            &seed,
            &"--model",
            &model,
            &"--action",
            &"walk\u{7}ing",
            &"--out",
            &out,
        ],
        &["walk\\u{7}ing"],
    );
    bad_input(
        &dir,
        &[
            &"predict",
            &"--seed",
            &walk_seed(),
            &"--input-fps",
            &"1e300",
            &"--out",
            &out,
        ],
        &["--input-fps", "1.000e300"],
    );
    let output = Command::new(env!("CARGO_BIN_EXE_motion-cli"))
        .args(["predict", "--action", "walk\u{7}ing", "--seed"])
        .arg(walk_seed())
        .arg("--model")
        .arg(fixture_model())
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        !output.stderr.contains(&7u8),
        "a raw BEL reached the terminal"
    );
}

/// A BVH whose offsets overflow gives no NaN or infinite positions with exit 0.
#[test]
fn offsets_that_overflow_are_refused() {
    let dir = scratch("overflowing-offsets");
    let mut text = std::fs::read_to_string(walk_seed()).unwrap();
    let mut from = 0;
    for _ in 0..3 {
        let joint = from + text[from..].find("JOINT").unwrap();
        let at = joint + text[joint..].find("OFFSET").unwrap();
        let end = at + text[at..].find('\n').unwrap();
        text.replace_range(at..end, "OFFSET 0 1e308 1e308");
        from = at + 1;
    }
    let bvh = dir.join("big.bvh");
    std::fs::write(&bvh, text).unwrap();
    bad_input(
        &dir,
        &[&"convert", &"--positions", &bvh, &dir.join("p.npy")],
        &["big.bvh", "not finite"],
    );
}
