//! Exit codes mean something: 2 for the user's input or arguments, 1 for the environment (an
//! output that cannot be written: full disk, permission denied), and nothing left behind.
mod common;

use std::process::Command;

use common::{motion_cli, repo, scratch};

fn code(output: &std::process::Output) -> i32 {
    output.status.code().expect("exited")
}

#[test]
fn bad_input_and_arguments_exit_2() {
    let dir = scratch("exit-input");
    let missing = motion_cli([
        "convert",
        "no_such_file.bvh",
        dir.join("o.npy").to_str().unwrap(),
    ]);
    assert_eq!(
        code(&missing),
        2,
        "{}",
        String::from_utf8_lossy(&missing.stderr)
    );
    // An output directory that does not exist is a wrong argument, not the machine's failure.
    let seed = repo().join("examples/walk_seed.bvh");
    let nowhere = motion_cli([
        "convert",
        seed.to_str().unwrap(),
        dir.join("no/such/dir/out.npy").to_str().unwrap(),
    ]);
    assert_eq!(
        code(&nowhere),
        2,
        "{}",
        String::from_utf8_lossy(&nowhere.stderr)
    );
}

#[test]
fn an_output_that_cannot_be_written_exits_1() {
    // /sys refuses new files even to root (permission denied or a read-only file system).
    let seed = repo().join("examples/walk_seed.bvh");
    let out = motion_cli(["convert", seed.to_str().unwrap(), "/sys/motion-out.npy"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(code(&out), 1, "{stderr}");
    assert!(
        stderr.contains("/sys/motion-out.npy") && stderr.contains("cannot write"),
        "{stderr}"
    );
}

#[test]
fn a_full_disk_exits_1_and_leaves_nothing_behind() {
    // A file-size limit of 1 KiB (`ulimit -f 1`, SIGXFSZ ignored): every write past it fails
    // with EFBIG, as a full disk fails with ENOSPC.
    let dir = scratch("exit-full");
    let seed = repo().join("examples/walk_seed.bvh");
    let out = dir.join("walk.npy");
    let script = format!(
        "ulimit -f 1; trap '' XFSZ; exec '{}' convert '{}' '{}'",
        env!("CARGO_BIN_EXE_motion-cli"),
        seed.display(),
        out.display()
    );
    let run = Command::new("sh").args(["-c", &script]).output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(code(&run), 1, "{stderr}");
    assert!(stderr.contains("cannot write"), "{stderr}");
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[test]
fn sigterm_and_sigint_exit_1_and_remove_the_unfinished_output() {
    // `eval --save-predictions` streams its .npy through a temporary file for the whole run:
    // a signal in the middle must leave nothing behind.
    let data = common::data_dir();
    if !data.join("h3.6m/dataset/S5/walking_1.txt.gz").exists()
        && !data.join("h3.6m/dataset/S5/walking_1.txt").exists()
    {
        eprintln!(
            "SKIPPED: the signal test runs eval, which needs the H3.6M data (set MOTION_DATA_DIR)"
        );
        return;
    }
    for signal in ["TERM", "INT"] {
        let dir = scratch(&format!("exit-signal-{signal}"));
        let out = dir.join("p.npy");
        let mut child = Command::new(env!("CARGO_BIN_EXE_motion-cli"))
            .args([
                "eval",
                "--data",
                data.to_str().unwrap(),
                "--actions",
                "walking,eating,smoking",
            ])
            .args([
                "--horizon",
                "300",
                "--samples",
                "4",
                "--no-classifier",
                "--quiet",
                "--save-predictions",
            ])
            .arg(&out)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let temp = dir.join(format!(".p.npy.tmp{}", child.id()));
        let start = std::time::Instant::now();
        while !temp.exists() {
            assert!(
                start.elapsed().as_secs() < 120,
                "{} never appeared",
                temp.display()
            );
            assert!(
                child.try_wait().unwrap().is_none(),
                "eval ended before the signal"
            );
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        let kill = Command::new("kill")
            .args([format!("-{signal}"), child.id().to_string()])
            .status()
            .unwrap();
        assert!(kill.success());
        let run = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(code(&run), 1, "SIG{signal}: {stderr}");
        assert!(stderr.contains("interrupted"), "SIG{signal}: {stderr}");
        let left: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert!(left.is_empty(), "SIG{signal} left behind: {left:?}");
    }
}

#[test]
fn verbose_prints_the_source_chain_one_cause_a_line() {
    let dir = scratch("exit-verbose");
    let out = motion_cli([
        "--verbose",
        "convert",
        "no_such_file.bvh",
        dir.join("o.npy").to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(code(&out), 2, "{stderr}");
    let lines: Vec<&str> = stderr.lines().collect();
    assert!(lines.len() >= 2, "{stderr}");
    assert!(
        lines[0].starts_with("error: ") && lines[0].contains("no_such_file.bvh"),
        "{stderr}"
    );
    assert!(lines[1].starts_with("  caused by: "), "{stderr}");
    // without --verbose: one line
    let plain = motion_cli([
        "convert",
        "no_such_file.bvh",
        dir.join("o.npy").to_str().unwrap(),
    ]);
    assert_eq!(String::from_utf8_lossy(&plain.stderr).lines().count(), 1);
}
