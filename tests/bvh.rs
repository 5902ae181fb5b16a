//! BVH reader/writer and exp-map <-> BVH conversion, at library level.
//!
//! The CMU-style fixtures in `tests/fixtures/bvh/` are made by [`cmu_fixture_text`] below from
//! synthetic sine-wave motion (no mocap data); `cmu_fixtures_are_generated_by_this_test` checks
//! they are current, and rewrites them when run with `MOTION_REGENERATE_FIXTURES=1`.
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use motion::core::formats::bvh::{parse_bvh, read_bvh, to_bvh_string, write_bvh, Bvh};
use motion::core::formats::expmap_bvh::{
    bvh_to_expmap, expmap_to_bvh, offset_difference, ExpMapTarget,
};
use motion::core::formats::h36m_text::{downsample_protocol, parse_expmap_text};
use motion::core::kinematics::{channel_positions, expmap_positions};
use motion::core::motion::{Motion, MotionLayout, RootEncoding};
use motion::core::rotation::{expmap2rotmat, EulerOrder};
use motion::core::skeleton::{Channel, Joint, Skeleton};
use motion::core::FormatError;
use ndarray::{Array2, Array3};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/bvh")
}

fn max_abs_diff(a: &Array3<f64>, b: &Array3<f64>) -> f64 {
    assert_eq!(a.dim(), b.dim());
    a.iter()
        .zip(b.iter())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

fn max_abs_diff2(a: &Array2<f64>, b: &Array2<f64>) -> f64 {
    assert_eq!(a.dim(), b.dim());
    a.iter()
        .zip(b.iter())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

// ---------- a small hand-written file ----------

const SMALL: &str = "HIERARCHY\r\n\
ROOT\tHips\r\n\
{\r\n\
\tOFFSET 0.0 0.0 0.0 \r\n\
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\r\n\
\tJOINT  Chest\r\n\
\t{\r\n\
\t\tOFFSET\t0 10.5 0\r\n\
\t\tCHANNELS 3 Xrotation   Yrotation Zrotation\r\n\
\t\tEnd Site\r\n\
\t\t{\r\n\
\t\t\tOFFSET 0 5 0\r\n\
\t\t}\r\n\
\t}\r\n\
\tJOINT Leg {\r\n\
\t\tOFFSET 3 -2 0\r\n\
\t\tCHANNELS 1 Zrotation\r\n\
\t}\r\n\
}\r\n\
\r\n\
MOTION\r\n\
Frames:\t2\r\n\
Frame Time: 0.0333333\r\n\
1 2 3 90 0 0 10 20 30 -45\r\n\
\r\n\
   -1\t-2 -3 0 0 0 0 0 0 1e1   \r\n";

#[test]
fn reads_hierarchy_channels_and_frames_with_crlf_tabs_and_odd_spacing() {
    let bvh = parse_bvh(SMALL, "small.bvh").expect("parses");
    let names: Vec<&str> = bvh
        .skeleton
        .joints()
        .iter()
        .map(|j| j.name.as_str())
        .collect();
    assert_eq!(names, ["Hips", "Chest", "Chest_End", "Leg"]);
    let chest = bvh.skeleton.joint(1);
    assert_eq!(chest.parent, Some(0));
    assert_eq!(chest.offset, [0.0, 10.5, 0.0]);
    assert_eq!(
        chest.channels,
        [Channel::Xrotation, Channel::Yrotation, Channel::Zrotation]
    );
    let end = bvh.skeleton.joint(2);
    assert!(end.is_end_site);
    assert_eq!((end.parent, end.offset), (Some(1), [0.0, 5.0, 0.0]));
    assert_eq!(bvh.skeleton.joint(3).channels, [Channel::Zrotation]);
    assert_eq!(bvh.skeleton.channel_count(), 10);
    assert_eq!(bvh.frames.dim(), (2, 10));
    assert_eq!(bvh.frames[[0, 3]], 90.0);
    assert_eq!(bvh.frames[[1, 9]], 10.0);
    assert_eq!(bvh.frame_time, 0.0333333);
}

#[test]
fn written_file_reads_back_identically() {
    let bvh = parse_bvh(SMALL, "small.bvh").unwrap();
    let text = to_bvh_string(&bvh).unwrap();
    assert!(text.starts_with("HIERARCHY\nROOT Hips\n{\n\tOFFSET 0 0 0\n"));
    let back = parse_bvh(&text, "written.bvh").unwrap();
    assert_eq!(back, bvh);
    // And through a file.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("small.bvh");
    write_bvh(&path, &bvh).unwrap();
    assert_eq!(read_bvh(&path).unwrap(), bvh);
}

#[test]
fn writer_keeps_every_bit_of_awkward_numbers() {
    let mut bvh = parse_bvh(SMALL, "small.bvh").unwrap();
    let awkward = [
        0.1 + 0.2,
        -1e-300,
        1.0 / 3.0,
        123456789.12345679,
        -0.0,
        5e-324,
        motion_core::formats::bvh::MAX_CHANNEL_MAGNITUDE,
        2.0f64.sqrt(),
        -179.99999999999997,
        -999_999_999.999_999_9,
    ];
    for (k, v) in awkward.iter().enumerate() {
        bvh.frames[[0, k]] = *v;
    }
    let back = parse_bvh(&to_bvh_string(&bvh).unwrap(), "awkward.bvh").unwrap();
    for (a, b) in bvh.frames.iter().zip(back.frames.iter()) {
        assert_eq!(a.to_bits(), b.to_bits(), "{a} != {b}");
    }
    // Beyond the reader's bound a value is refused, in short form, with its place.
    bvh.frames[[0, 3]] = 1e22;
    let err = parse_bvh(&to_bvh_string(&bvh).unwrap(), "awkward.bvh")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("awkward.bvh")
            && err.contains("channel 4 of frame 1")
            && err.contains("1.000e22"),
        "{err}"
    );
}

#[test]
fn writer_rejects_frames_that_do_not_fit() {
    let mut bvh = parse_bvh(SMALL, "small.bvh").unwrap();
    bvh.frames = Array2::zeros((2, 9));
    assert!(to_bvh_string(&bvh).is_err());
    let mut bvh = parse_bvh(SMALL, "small.bvh").unwrap();
    bvh.frames[[1, 1]] = f64::NAN;
    assert!(to_bvh_string(&bvh).is_err());
}

// ---------- malformed input ----------

/// Parses `text` and returns the (line, problem) of the expected `FormatError::Parse`.
fn parse_error(text: &str) -> (usize, String) {
    match parse_bvh(text, "bad.bvh") {
        Err(FormatError::Parse {
            path,
            line,
            problem,
        }) => {
            assert_eq!(path, Path::new("bad.bvh"));
            let shown = FormatError::Parse {
                path,
                line,
                problem: problem.clone(),
            }
            .to_string();
            assert!(shown.starts_with(&format!("bad.bvh:{line}: ")), "{shown}");
            (line, problem)
        }
        Err(other) => panic!("expected a parse error, got {other}"),
        Ok(_) => panic!("expected a parse error, got a BVH"),
    }
}

fn small_lf() -> String {
    SMALL.replace("\r\n", "\n")
}

#[test]
fn truncated_file_names_the_last_line() {
    let text = small_lf();
    // Cut inside the hierarchy: the open joint is named.
    let cut: String = text.lines().take(8).collect::<Vec<_>>().join("\n");
    let (line, problem) = parse_error(&cut);
    assert_eq!(line, 8);
    assert!(problem.contains("unexpected end of file"), "{problem}");
    // Cut inside the last frame line: too few numbers on that line.
    let cut = &text[..text.len() - 12];
    let (line, problem) = parse_error(cut);
    assert_eq!(line, 26);
    assert!(problem.contains("expected 10 numbers"), "{problem}");
    // Cut before MOTION.
    let cut: String = text.lines().take(19).collect::<Vec<_>>().join("\n");
    let (_, problem) = parse_error(&cut);
    assert!(problem.contains("expected MOTION"), "{problem}");
}

#[test]
fn wrong_frame_count_says_both_numbers() {
    let text = small_lf().replace("Frames:\t2", "Frames: 3");
    let (line, problem) = parse_error(&text);
    assert_eq!(line, 22);
    assert!(
        problem.contains("Frames: 3") && problem.contains("has 2 frame lines"),
        "{problem}"
    );
    let text = small_lf().replace("Frames:\t2", "Frames: 1");
    let (_, problem) = parse_error(&text);
    assert!(
        problem.contains("Frames: 1") && problem.contains("has 2"),
        "{problem}"
    );
}

#[test]
fn non_number_names_line_and_column() {
    let text = small_lf().replace("10 20 30 -45", "10 2O 30 -45");
    let (line, problem) = parse_error(&text);
    assert_eq!(line, 24);
    assert!(
        problem.contains("\"2O\"") && problem.contains("channel 8"),
        "{problem}"
    );
    for bad in ["nan", "inf", "-infinity"] {
        let text = small_lf().replace("10 20 30 -45", &format!("10 {bad} 30 -45"));
        assert_eq!(parse_error(&text).0, 24);
    }
    let text = small_lf().replace("OFFSET\t0 10.5 0", "OFFSET 0 ten 0");
    let (line, problem) = parse_error(&text);
    assert_eq!(line, 8);
    assert!(
        problem.contains("OFFSET y") && problem.contains("\"Chest\""),
        "{problem}"
    );
}

#[test]
fn missing_channels_is_named() {
    let text = small_lf().replace("\t\tCHANNELS 3 Xrotation   Yrotation Zrotation\n", "");
    let (line, problem) = parse_error(&text);
    assert_eq!(line, 9);
    assert!(
        problem.contains("expected CHANNELS of joint \"Chest\""),
        "{problem}"
    );
}

#[test]
fn bad_channel_name_and_counts_are_named() {
    let text = small_lf().replace("Xrotation   Yrotation", "Xrotation Wrotation");
    let (line, problem) = parse_error(&text);
    assert_eq!(line, 9);
    assert!(problem.contains("\"Wrotation\""), "{problem}");
    let text = small_lf().replace("CHANNELS 3 Xrotation", "CHANNELS 7 Xrotation");
    let (line, problem) = parse_error(&text);
    assert_eq!(line, 9);
    assert!(problem.contains("0 to 6"), "{problem}");
    let text = small_lf().replace(
        "CHANNELS 3 Xrotation",
        "CHANNELS 99999999999999999999 Xrotation",
    );
    assert_eq!(parse_error(&text).0, 9);
    let text = small_lf().replace(
        "Xrotation   Yrotation Zrotation",
        "Xrotation Yrotation Xrotation",
    );
    let (_, problem) = parse_error(&text);
    assert!(problem.contains("twice"), "{problem}");
}

#[test]
fn unbalanced_braces_are_named() {
    // One '}' missing: MOTION is found where the root's '}' was expected.
    let text = small_lf().replacen("\t}\n\tJOINT Leg", "\tJOINT Leg", 1);
    let (line, problem) = parse_error(&text);
    assert!(problem.contains("closing joint \"Hips\""), "{problem}");
    assert_eq!(line, 20);
    // One '}' too many.
    let text = small_lf().replace("}\n\nMOTION", "}\n}\nMOTION");
    let (line, problem) = parse_error(&text);
    assert_eq!(line, 20);
    assert!(problem.contains("one '}' too many"), "{problem}");
    // A '{' missing.
    let text = small_lf().replace("JOINT Leg {", "JOINT Leg");
    let (line, problem) = parse_error(&text);
    assert_eq!(line, 16);
    assert!(
        problem.contains("expected '{' opening joint \"Leg\""),
        "{problem}"
    );
}

#[test]
fn other_malformed_headers_are_named() {
    let cases: &[(&str, &str, usize, &str)] = &[
        ("HIERARCHY\n", "HIERARCH\n", 1, "expected HIERARCHY"),
        ("ROOT\tHips", "ROOT", 2, "joint name"),
        ("Frames:\t2", "Frames: two", 22, "Frames: <count>"),
        ("Frames:\t2", "Frames: -2", 22, "Frames: <count>"),
        ("Frame Time: 0.0333333", "Frame Time: 0", 23, "positive"),
        ("Frame Time: 0.0333333", "FrameTime 0.03", 23, "Frame Time"),
        ("JOINT Leg {", "JOINT Chest {", 15, "used twice"),
        ("\t\tEnd Site", "\t\tEnd Sight", 10, "Site"),
        (
            "\t\t\tOFFSET 0 5 0\n",
            "\t\t\tOFFSET 0 5 0\n\t\t\tCHANNELS 1 Xrotation\n",
            13,
            "only an OFFSET",
        ),
        ("MOTION\n", "MOTION 2\n", 21, "end of the line"),
    ];
    for &(from, to, line, needle) in cases {
        let text = small_lf().replacen(from, to, 1);
        assert_ne!(text, small_lf(), "{from:?} not found");
        let (got_line, problem) = parse_error(&text);
        assert_eq!(got_line, line, "{to:?}: {problem}");
        assert!(problem.contains(needle), "{to:?}: {problem}");
    }
    assert_eq!(parse_error("").0, 1);
    let (line, problem) = parse_error(&format!("{}{}", small_lf(), "ROOT X"));
    assert_eq!(line, 27);
    assert!(problem.contains("frame 3, found \"ROOT\""), "{problem}");
}

#[test]
fn huge_declared_frame_count_allocates_nothing_and_fails_cleanly() {
    let text = small_lf().replace("Frames:\t2", "Frames: 18446744073709551615");
    let (_, problem) = parse_error(&text);
    assert!(problem.contains("has 2 frame lines"), "{problem}");
}

/// A chain of `depth` joints, each nested in the previous one.
fn text_with_depth(depth: usize) -> String {
    let mut text = String::from(
        "HIERARCHY\nROOT J0\n{\nOFFSET 0 0 0\nCHANNELS 3 Xrotation Yrotation Zrotation\n",
    );
    for k in 1..depth {
        text.push_str(&format!("JOINT J{k}\n{{\nOFFSET 0 1 0\nCHANNELS 0\n"));
    }
    text.push_str(&"}\n".repeat(depth));
    text.push_str("MOTION\nFrames: 1\nFrame Time: 0.01\n1 2 3\n");
    text
}

#[test]
fn deep_nesting_does_not_overflow_the_stack() {
    let depth = 100_000;
    let bvh = parse_bvh(&text_with_depth(depth), "deep.bvh").expect("parses");
    assert_eq!(bvh.skeleton.len(), depth);
    // The writer indents by depth (quadratic size): write back a shallower chain.
    let bvh = parse_bvh(&text_with_depth(2_000), "shallow.bvh").unwrap();
    let back = parse_bvh(&to_bvh_string(&bvh).unwrap(), "deep2.bvh").unwrap();
    assert_eq!(back, bvh);
}

#[test]
fn garbage_never_panics() {
    // A deterministic sweep of truncations and byte substitutions of a valid file.
    let text = small_lf();
    for cut in 0..text.len() {
        if text.is_char_boundary(cut) {
            let _ = parse_bvh(&text[..cut], "cut.bvh");
        }
    }
    let bytes = text.as_bytes();
    for (k, replacement) in (0..bytes.len()).zip(
        [b'}', b'{', b'\n', b' ', b'9', b'-', b'.', b'x']
            .iter()
            .cycle(),
    ) {
        let mut mutated = bytes.to_vec();
        mutated[k] = *replacement;
        if let Ok(s) = std::str::from_utf8(&mutated) {
            let _ = parse_bvh(s, "mutated.bvh");
        }
    }
}

// ---------- CMU-style files of other exporters (fixtures generated here) ----------

/// The 31-joint hierarchy of the CMU BVH conversions (joint names and tree), with offsets of our
/// own (plausible proportions, not taken from any file) and End Sites at the 7 leaves.
fn cmu_style_skeleton() -> Skeleton {
    use Channel::*;
    // (name, parent name, offset); "_End" names are End Sites.
    let tree: &[(&str, &str, [f64; 3])] = &[
        ("Hips", "", [0.0, 0.0, 0.0]),
        ("LHipJoint", "Hips", [0.0, 0.0, 0.0]),
        ("LeftUpLeg", "LHipJoint", [1.4, -1.8, 0.8]),
        ("LeftLeg", "LeftUpLeg", [2.4, -6.7, 0.0]),
        ("LeftFoot", "LeftLeg", [2.5, -7.0, 0.0]),
        ("LeftToeBase", "LeftFoot", [0.2, -0.4, 2.3]),
        ("LeftToeBase_End", "LeftToeBase", [0.0, 0.0, 1.2]),
        ("RHipJoint", "Hips", [0.0, 0.0, 0.0]),
        ("RightUpLeg", "RHipJoint", [-1.4, -1.8, 0.8]),
        ("RightLeg", "RightUpLeg", [-2.4, -6.7, 0.0]),
        ("RightFoot", "RightLeg", [-2.5, -7.0, 0.0]),
        ("RightToeBase", "RightFoot", [-0.2, -0.4, 2.3]),
        ("RightToeBase_End", "RightToeBase", [0.0, 0.0, 1.2]),
        ("LowerBack", "Hips", [0.0, 0.0, 0.0]),
        ("Spine", "LowerBack", [0.0, 2.1, -0.1]),
        ("Spine1", "Spine", [0.0, 2.1, -0.05]),
        ("Neck", "Spine1", [0.0, 0.0, 0.0]),
        ("Neck1", "Neck", [0.0, 1.6, 0.1]),
        ("Head", "Neck1", [0.0, 1.6, -0.1]),
        ("Head_End", "Head", [0.0, 1.6, 0.0]),
        ("LeftShoulder", "Spine1", [0.0, 0.0, 0.0]),
        ("LeftArm", "LeftShoulder", [3.5, 0.9, -0.2]),
        ("LeftForeArm", "LeftArm", [4.9, 0.0, 0.0]),
        ("LeftHand", "LeftForeArm", [3.4, 0.0, 0.0]),
        ("LeftFingerBase", "LeftHand", [0.0, 0.0, 0.0]),
        ("LeftHandIndex1", "LeftFingerBase", [0.7, 0.0, 0.0]),
        ("LeftHandIndex1_End", "LeftHandIndex1", [0.5, 0.0, 0.0]),
        ("LThumb", "LeftHand", [0.0, 0.0, 0.0]),
        ("LThumb_End", "LThumb", [0.5, 0.0, 0.5]),
        ("RightShoulder", "Spine1", [0.0, 0.0, 0.0]),
        ("RightArm", "RightShoulder", [-3.5, 0.9, -0.2]),
        ("RightForeArm", "RightArm", [-4.9, 0.0, 0.0]),
        ("RightHand", "RightForeArm", [-3.4, 0.0, 0.0]),
        ("RightFingerBase", "RightHand", [0.0, 0.0, 0.0]),
        ("RightHandIndex1", "RightFingerBase", [-0.7, 0.0, 0.0]),
        ("RightHandIndex1_End", "RightHandIndex1", [-0.5, 0.0, 0.0]),
        ("RThumb", "RightHand", [0.0, 0.0, 0.0]),
        ("RThumb_End", "RThumb", [-0.5, 0.0, 0.5]),
    ];
    let index = |name: &str| tree.iter().position(|(n, _, _)| *n == name);
    let joints = tree
        .iter()
        .map(|&(name, parent, offset)| match index(parent) {
            None => Joint::new(
                name,
                None,
                offset,
                vec![
                    Xposition, Yposition, Zposition, Zrotation, Yrotation, Xrotation,
                ],
            ),
            Some(p) if name.ends_with("_End") => Joint::end_site(name, p, offset),
            Some(p) => Joint::new(name, Some(p), offset, vec![Zrotation, Yrotation, Xrotation]),
        })
        .collect();
    Skeleton::new(joints).unwrap()
}

/// Sine-wave motion at 120 fps on [`cmu_style_skeleton`], rounded to 6 decimals as exporters
/// write it (so the file holds exactly these values).
fn cmu_style_frames(frames: usize) -> Array2<f64> {
    let channels = cmu_style_skeleton().channel_count();
    Array2::from_shape_fn((frames, channels), |(t, c)| {
        let time = t as f64 / 120.0;
        let c_f = c as f64;
        let value = match c {
            0 => 3.0 * (2.0 * PI * 0.5 * time).sin(),
            1 => 17.0 + 0.3 * (2.0 * PI * 2.0 * time).cos(),
            2 => 12.0 * time,
            _ => (20.0 + (c_f * 7.0) % 40.0) * (2.0 * PI * (0.3 + 0.05 * c_f) * time + c_f).sin(),
        };
        format!("{value:.6}").parse().unwrap()
    })
}

/// How a fixture's text is laid out, mimicking real exporters' quirks.
#[derive(Clone, Copy)]
enum Quirks {
    /// CRLF, tab indentation, a trailing space after every frame value.
    CrlfTabs,
    /// LF, space indentation mixed with tabs, `{` on the keyword line, doubled spaces,
    /// tab-separated values, blank lines, trailing whitespace.
    OddSpacing,
}

/// The text of a CMU-style fixture: our own formatting code, not a copy of any file.
fn cmu_fixture_text(quirks: Quirks, frames: &Array2<f64>) -> String {
    let skeleton = cmu_style_skeleton();
    let mut lines: Vec<String> = vec!["HIERARCHY".into()];
    let indent = |depth: usize| match quirks {
        Quirks::CrlfTabs => "\t".repeat(depth),
        Quirks::OddSpacing => "  ".repeat(depth / 2) + &"\t".repeat(depth % 2),
    };
    let number = |v: f64| format!("{v:.6}");
    // Depth-first with an explicit stack of (joint, depth, opened).
    let mut stack = vec![(0usize, 0usize, false)];
    while let Some((j, depth, opened)) = stack.pop() {
        let joint = skeleton.joint(j);
        let pad = indent(depth);
        if opened {
            lines.push(format!("{pad}}}"));
            continue;
        }
        let offset = joint.offset.map(number).join(match quirks {
            Quirks::CrlfTabs => " ",
            Quirks::OddSpacing => "  ",
        });
        if joint.is_end_site {
            lines.push(format!("{pad}End Site"));
            lines.push(format!("{pad}{{"));
            lines.push(format!("{pad}\tOFFSET {offset}"));
            lines.push(format!("{pad}}}"));
            continue;
        }
        let keyword = if j == 0 { "ROOT" } else { "JOINT" };
        match quirks {
            Quirks::CrlfTabs => {
                lines.push(format!("{pad}{keyword} {}", joint.name));
                lines.push(format!("{pad}{{"));
            }
            Quirks::OddSpacing => lines.push(format!("{pad}{keyword}  {} {{   ", joint.name)),
        }
        let inner = indent(depth + 1);
        lines.push(format!("{inner}OFFSET {offset}"));
        let names: Vec<&str> = joint.channels.iter().map(|c| c.bvh_name()).collect();
        lines.push(format!(
            "{inner}CHANNELS {} {}",
            names.len(),
            names.join(" ")
        ));
        stack.push((j, depth, true));
        for &child in skeleton.children(j).iter().rev() {
            stack.push((child, depth + 1, false));
        }
    }
    lines.push("MOTION".into());
    match quirks {
        Quirks::CrlfTabs => {
            lines.push(format!("Frames: {}", frames.nrows()));
            lines.push("Frame Time: 0.00833333".into());
        }
        Quirks::OddSpacing => {
            lines.push(String::new());
            lines.push(format!("Frames:  {}\t", frames.nrows()));
            lines.push("Frame Time:\t0.00833333 ".into());
        }
    }
    for row in frames.rows() {
        let values: Vec<String> = row.iter().map(|&v| number(v)).collect();
        lines.push(match quirks {
            Quirks::CrlfTabs => values.join(" ") + " ",
            Quirks::OddSpacing => values.join("\t") + "  ",
        });
    }
    match quirks {
        Quirks::CrlfTabs => lines.join("\r\n") + "\r\n",
        Quirks::OddSpacing => lines.join("\n") + "\n\n",
    }
}

const CMU_FIXTURES: [(&str, Quirks); 2] = [
    ("cmu_style_crlf_tabs.bvh", Quirks::CrlfTabs),
    ("cmu_style_odd_spacing.bvh", Quirks::OddSpacing),
];
const CMU_FIXTURE_FRAMES: usize = 24;

#[test]
fn cmu_fixtures_are_generated_by_this_test() {
    let frames = cmu_style_frames(CMU_FIXTURE_FRAMES);
    let regenerate = std::env::var_os("MOTION_REGENERATE_FIXTURES").is_some();
    for (name, quirks) in CMU_FIXTURES {
        let text = cmu_fixture_text(quirks, &frames);
        let path = fixtures().join(name);
        if regenerate {
            std::fs::write(&path, &text).unwrap();
        }
        let committed = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(
            committed == text,
            "{} is stale: run MOTION_REGENERATE_FIXTURES=1 cargo test --test bvh",
            path.display()
        );
    }
}

#[test]
fn cmu_style_files_read_write_and_read_back_with_identical_fk() {
    let expected_frames = cmu_style_frames(CMU_FIXTURE_FRAMES);
    for (name, _) in CMU_FIXTURES {
        let bvh = read_bvh(fixtures().join(name)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(bvh.skeleton, cmu_style_skeleton(), "{name}");
        assert_eq!(bvh.skeleton.len() - 7, 31);
        assert_eq!(bvh.frames, expected_frames, "{name}");
        assert_eq!(bvh.frame_time, 0.00833333);
        assert!((bvh.fps() - 120.0).abs() < 1e-3);
        let zyx = [Channel::Zrotation, Channel::Yrotation, Channel::Xrotation];
        assert_eq!(bvh.skeleton.joint(1).channels, zyx);

        let dir = tempfile::tempdir().unwrap();
        let written = dir.path().join(name);
        write_bvh(&written, &bvh).unwrap();
        let back = read_bvh(&written).unwrap();
        assert_eq!(back, bvh, "{name}");
        let fk = channel_positions(&bvh.skeleton, bvh.frames.view()).unwrap();
        let fk_back = channel_positions(&back.skeleton, back.frames.view()).unwrap();
        assert_eq!(fk, fk_back, "{name}");
        // The motion moves: the root walks 12 units per second along z.
        let last = CMU_FIXTURE_FRAMES - 1;
        assert!((fk[[last, 0, 2]] - 12.0 * last as f64 / 120.0).abs() < 1e-12);
    }
}

// ---------- exp-map <-> BVH ----------

/// Synthetic H3.6M-like exp-map frames (99 dims): a root walking forward and turning (deltas per
/// 50 Hz frame), joints swinging, a few exp-maps with angle > π and some exactly zero.
fn synthetic_h36m(frames: usize) -> Array2<f64> {
    Array2::from_shape_fn((frames, 99), |(t, d)| {
        let time = t as f64 / 50.0;
        let df = d as f64;
        match d {
            0 => 0.5 * (2.0 * PI * time).sin(),
            1 => 0.2,
            2 => 14.0 + 2.0 * (2.0 * PI * 2.0 * time).sin(),
            3 => 0.003 * (2.0 * PI * 0.5 * time).cos(),
            4 => 0.02 + 0.01 * (2.0 * PI * time).sin(),
            5 => 0.002,
            // Leaves of the skeleton with constant zero dims, as in the data.
            18..=20 | 33..=35 => 0.0,
            // One joint with exp-map angles beyond π.
            45 => 3.0 + 0.5 * (2.0 * PI * time).sin(),
            46 => 1.0,
            _ => 0.8 * (2.0 * PI * (0.2 + 0.03 * df) * time + df).sin(),
        }
    })
}

fn h36m_motion(frames: Array2<f64>, fps: f64) -> Motion {
    Motion::h36m(frames, fps).unwrap()
}

/// Max difference between exp-maps as rotations (row-vector matrices).
fn max_rotation_diff(a: &Array2<f64>, b: &Array2<f64>) -> f64 {
    let mut worst = 0.0f64;
    for (ra, rb) in a.rows().into_iter().zip(b.rows()) {
        for k in (6..ra.len()).step_by(3) {
            let ma = expmap2rotmat([ra[k], ra[k + 1], ra[k + 2]]);
            let mb = expmap2rotmat([rb[k], rb[k + 1], rb[k + 2]]);
            for i in 0..3 {
                for j in 0..3 {
                    worst = worst.max((ma[i][j] - mb[i][j]).abs());
                }
            }
        }
    }
    worst
}

#[test]
fn h36m_to_bvh_fk_equals_expmap_fk_and_round_trips() {
    for (fps, step) in [(50.0, 1usize), (25.0, 2)] {
        let source = synthetic_h36m(300);
        let source = if step == 2 {
            downsample_protocol(source.view())
        } else {
            source
        };
        let motion = h36m_motion(source.clone(), fps);
        let bvh = expmap_to_bvh(&motion).unwrap();
        assert_eq!(bvh.frame_time, 1.0 / fps);
        assert_eq!(bvh.skeleton.len(), 32);
        assert_eq!(bvh.skeleton.channel_count(), 6 + 31 * 3);

        let reference =
            expmap_positions(&Skeleton::h36m(), source.view(), RootEncoding::Deltas, step).unwrap();
        let bvh_fk = channel_positions(&bvh.skeleton, bvh.frames.view()).unwrap();
        // Not closer than ~1e-4 mm: the evaluation's expmap2rotmat is not exactly orthonormal
        // (its float32 ε shrinks vectors by ~1e-7), BVH rotations are.
        let fk_error = max_abs_diff(&reference, &bvh_fk);
        eprintln!("{fps} Hz: BVH FK vs exp-map FK: max difference {fk_error:e} mm");
        assert!(fk_error < 1e-3, "{fps} Hz: FK differs by {fk_error} mm");
        // The character moves: about 14 mm per source frame, along a circle.
        let travelled: f64 = (1..bvh_fk.dim().0)
            .map(|t| {
                let dx = bvh_fk[[t, 0, 0]] - bvh_fk[[t - 1, 0, 0]];
                let dz = bvh_fk[[t, 0, 2]] - bvh_fk[[t - 1, 0, 2]];
                dx.hypot(dz)
            })
            .sum();
        assert!(travelled > 3000.0, "root travelled only {travelled} mm");

        // Through text and back to exp-map.
        let text = to_bvh_string(&bvh).unwrap();
        let read = parse_bvh(&text, "h36m.bvh").unwrap();
        assert_eq!(read, bvh);
        assert_eq!(ExpMapTarget::detect(&read), Ok(ExpMapTarget::H36m));
        assert_eq!(offset_difference(&read, ExpMapTarget::H36m), 0.0);
        let back = bvh_to_expmap(&read, ExpMapTarget::H36m).unwrap();
        assert_eq!(
            back.layout(),
            MotionLayout::ExpMap {
                root: RootEncoding::Deltas
            }
        );
        assert_eq!(back.fps(), fps);
        let back = back.into_frames();
        // Exactly the same numbers, except exp-maps of angle > π (dims 45..47) that come back as
        // the equivalent rotation with angle < π.
        let mut same = back.clone();
        let mut original = source.clone();
        for arr in [&mut same, &mut original] {
            arr.slice_mut(ndarray::s![.., 45..48]).fill(0.0);
        }
        let error = max_abs_diff2(&original, &same);
        let root_error = max_abs_diff2(
            &original.slice(ndarray::s![.., 0..6]).to_owned(),
            &same.slice(ndarray::s![.., 0..6]).to_owned(),
        );
        eprintln!("{fps} Hz: exp-map -> BVH -> exp-map: max difference {error:e} (root dims {root_error:e})");
        assert!(
            error < 1e-7,
            "{fps} Hz: exp-map round trip differs by {error}"
        );
        let rotation_error = max_rotation_diff(&source, &back);
        // (Angles > π come back as 2π - θ about the opposite axis, for which the float32 ε of
        // expmap2rotmat weighs a little differently.)
        assert!(
            rotation_error < 1e-6,
            "{fps} Hz: rotations differ by {rotation_error}"
        );

        // And BVH -> exp-map -> BVH gives the same angles.
        let again = expmap_to_bvh(&h36m_motion(back, fps)).unwrap();
        let error = max_abs_diff2(&again.frames, &bvh.frames);
        eprintln!("{fps} Hz: BVH -> exp-map -> BVH: max difference {error:e} (degrees or mm)");
        assert!(
            error < 1e-7,
            "{fps} Hz: BVH round trip differs by {error} degrees"
        );
    }
}

#[test]
fn h36m_bvh_text_keeps_every_joint_name_and_reads_back_as_text() {
    let motion = h36m_motion(synthetic_h36m(10), 50.0);
    let bvh = expmap_to_bvh(&motion).unwrap();
    let text = to_bvh_string(&bvh).unwrap();
    for joint in Skeleton::h36m().joints() {
        assert!(text.contains(&format!("JOINT {}\n", joint.name)) || joint.parent.is_none());
    }
    assert!(text.contains("ROOT Hips\n"));
    assert!(text.contains("CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"));
    assert!(text.contains("Frame Time: 0.02\n"));
    // The exp-map text of the BVH parses as 99 columns again.
    let back = bvh_to_expmap(&bvh, ExpMapTarget::H36m).unwrap();
    let mut csv = Vec::new();
    motion::core::formats::h36m_text::format_expmap_text(&mut csv, back.frames()).unwrap();
    let parsed = parse_expmap_text(&csv[..], Path::new("back.txt")).unwrap();
    assert_eq!(parsed, back.into_frames());
}

#[test]
fn bvh_with_other_rotation_orders_and_end_sites_converts_to_h36m() {
    // Rewrite the H3.6M BVH with XYZ joints and a YXZ root, plus End Sites at the leaves: the
    // conversion reads any order and ignores End Sites.
    let motion = h36m_motion(synthetic_h36m(40), 50.0);
    let bvh = expmap_to_bvh(&motion).unwrap();
    let reference = channel_positions(&bvh.skeleton, bvh.frames.view()).unwrap();
    let h36m = Skeleton::h36m();
    let mut joints = Vec::new();
    let mut index_of = Vec::new();
    // Depth-first order with End Sites appended right after each leaf.
    let mut stack = vec![0usize];
    while let Some(j) = stack.pop() {
        let joint = h36m.joint(j);
        let channels = if j == 0 {
            vec![
                Channel::Yrotation,
                Channel::Xposition,
                Channel::Xrotation,
                Channel::Yposition,
                Channel::Zposition,
                Channel::Zrotation,
            ]
        } else {
            vec![Channel::Xrotation, Channel::Yrotation, Channel::Zrotation]
        };
        let parent = joint
            .parent
            .map(|p| index_of.iter().position(|&k| k == p).unwrap());
        joints.push(Joint::new(
            joint.name.clone(),
            parent,
            joint.offset,
            channels,
        ));
        index_of.push(j);
        if h36m.children(j).is_empty() {
            let me = joints.len() - 1;
            joints.push(Joint::end_site(
                format!("{}_End", joint.name),
                me,
                [0.0, 10.0, 0.0],
            ));
            index_of.push(usize::MAX);
        }
        for &c in h36m.children(j).iter().rev() {
            stack.push(c);
        }
    }
    let skeleton = Skeleton::new(joints).unwrap();
    let mut frames = Array2::zeros((bvh.frames.nrows(), skeleton.channel_count()));
    let mut fk_frames = frames.clone();
    for t in 0..frames.nrows() {
        let src = bvh.frames.row(t);
        let mut out = frames.row_mut(t);
        for (new_j, &old_j) in index_of.iter().enumerate() {
            if old_j == usize::MAX {
                continue;
            }
            let start_old = bvh.skeleton.channel_start(old_j);
            let start_new = skeleton.channel_start(new_j);
            // Old channels: [X Y Z pos] Z X Y rotations (degrees).
            let rot_start = if old_j == 0 { start_old + 3 } else { start_old };
            let q = motion::core::formats::expmap_bvh::bvh_euler_to_quat(
                EulerOrder::ZXY,
                [src[rot_start], src[rot_start + 1], src[rot_start + 2]],
            );
            if old_j == 0 {
                let [y, x, z] =
                    motion::core::rotation::quat_to_euler(EulerOrder::YXZ, q).map(f64::to_degrees);
                let values = [
                    y,
                    src[start_old],
                    x,
                    src[start_old + 1],
                    src[start_old + 2],
                    z,
                ];
                for (k, v) in values.iter().enumerate() {
                    out[start_new + k] = *v;
                }
            } else {
                let angles =
                    motion::core::rotation::quat_to_euler(EulerOrder::XYZ, q).map(f64::to_degrees);
                for (k, v) in angles.iter().enumerate() {
                    out[start_new + k] = *v;
                }
            }
        }
        fk_frames.row_mut(t).assign(&out);
    }
    let reordered = Bvh {
        skeleton,
        frames,
        frame_time: bvh.frame_time,
    };
    // Same FK on the joints that exist in both.
    let fk = channel_positions(&reordered.skeleton, fk_frames.view()).unwrap();
    for (new_j, &old_j) in index_of.iter().enumerate() {
        if old_j != usize::MAX {
            for t in 0..fk.dim().0 {
                for k in 0..3 {
                    assert!((fk[[t, new_j, k]] - reference[[t, old_j, k]]).abs() < 1e-9);
                }
            }
        }
    }
    assert_eq!(ExpMapTarget::detect(&reordered), Ok(ExpMapTarget::H36m));
    let back = bvh_to_expmap(&reordered, ExpMapTarget::H36m)
        .unwrap()
        .into_frames();
    let direct = bvh_to_expmap(&bvh, ExpMapTarget::H36m)
        .unwrap()
        .into_frames();
    let error = max_abs_diff2(&back, &direct);
    assert!(error < 1e-9, "{error}");
}

#[test]
fn cmu_expmap_round_trips_through_bvh_with_an_absolute_root() {
    let skeleton = Arc::new(Skeleton::cmu());
    let frames = Array2::from_shape_fn((30, 117), |(t, d)| {
        let time = t as f64 / 120.0;
        match d {
            0 => 5.0 * time,
            1 => 17.0,
            2 => -3.0 * time,
            _ => 0.6 * (2.0 * PI * (0.2 + 0.02 * d as f64) * time + d as f64).sin(),
        }
    });
    let motion = Motion::new(
        skeleton.clone(),
        MotionLayout::ExpMap {
            root: RootEncoding::Absolute,
        },
        frames.clone(),
        120.0,
    )
    .unwrap();
    let bvh = expmap_to_bvh(&motion).unwrap();
    let fk = channel_positions(&bvh.skeleton, bvh.frames.view()).unwrap();
    let reference = expmap_positions(&skeleton, frames.view(), RootEncoding::Absolute, 1).unwrap();
    let fk_error = max_abs_diff(&fk, &reference);
    eprintln!("CMU: BVH FK vs exp-map FK: max difference {fk_error:e}");
    assert!(fk_error < 1e-5, "{fk_error}");
    assert_eq!(ExpMapTarget::detect(&bvh), Ok(ExpMapTarget::Cmu));
    let back = bvh_to_expmap(&bvh, ExpMapTarget::Cmu)
        .unwrap()
        .into_frames();
    assert!(max_abs_diff2(&back, &frames) < 1e-9);
}

#[test]
fn bvh_of_another_skeleton_is_rejected_clearly() {
    let bvh = parse_bvh(SMALL, "small.bvh").unwrap();
    let error = ExpMapTarget::detect(&bvh).unwrap_err().to_string();
    assert!(
        error.contains("no built-in exp-map skeleton fits"),
        "{error}"
    );
    let error = bvh_to_expmap(&bvh, ExpMapTarget::H36m)
        .unwrap_err()
        .to_string();
    assert!(error.contains("no joint \"RightUpLeg\""), "{error}");
}

#[test]
fn euler_channels_stay_continuous_through_gimbal_and_wrap() {
    use motion::core::formats::expmap_bvh::{bvh_euler_to_quat, continuous_euler_degrees};
    for order in EulerOrder::TAIT_BRYAN {
        // The middle angle sweeps through 90° while the others turn past 180°.
        let mut previous = None;
        for step in 0..=200 {
            let s = step as f64;
            let truth = [100.0 + 1.5 * s, 60.0 + 0.3 * s, -150.0 - 2.0 * s];
            let q = bvh_euler_to_quat(order, truth);
            let angles = continuous_euler_degrees(order, q, previous);
            let back = bvh_euler_to_quat(order, angles);
            assert!(
                back.dot(q).abs() > 1.0 - 1e-12,
                "{order:?}: not the same rotation"
            );
            if let Some(p) = previous {
                for k in 0..3 {
                    assert!(
                        (angles[k] - p[k]).abs() < 5.0,
                        "{order:?} step {step}: {p:?} -> {angles:?}"
                    );
                }
            }
            previous = Some(angles);
        }
    }
}

#[test]
fn absurd_frame_time_is_refused_not_looped_over() {
    let mut bvh = expmap_to_bvh(&h36m_motion(synthetic_h36m(3), 50.0)).unwrap();
    bvh.frame_time = 1e300;
    let text = to_bvh_string(&bvh).unwrap();
    let bvh = parse_bvh(&text, "slow.bvh").unwrap();
    let error = bvh_to_expmap(&bvh, ExpMapTarget::H36m)
        .unwrap_err()
        .to_string();
    assert!(error.contains("too low for H3.6M root deltas"), "{error}");
}

#[test]
fn bvh_is_a_motion_in_the_channels_layout() {
    let bvh = parse_bvh(SMALL, "small.bvh").unwrap();
    let motion = bvh.to_motion().unwrap();
    assert_eq!(motion.layout(), MotionLayout::Channels);
    assert_eq!(motion.len(), 2);
    assert!((motion.fps() - 1.0 / 0.0333333).abs() < 1e-9);
    let fk = channel_positions(&bvh.skeleton, bvh.frames.view()).unwrap();
    assert_eq!(motion.positions(), fk);
    let back = Bvh::from_motion(&motion).unwrap();
    assert_eq!((back.skeleton, back.frames), (bvh.skeleton, bvh.frames));
    assert!(Bvh::from_motion(&h36m_motion(synthetic_h36m(2), 50.0)).is_none());
}

/// `MOTION_DATA_DIR/cmu_locomotion/{name}` (default `<repo>/../shared/data`), or `None` after a
/// visible SKIPPED message.
fn cmu_locomotion_take(test: &str, name: &str) -> Option<PathBuf> {
    let root = std::env::var_os("MOTION_DATA_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data"));
    let path = root.join("cmu_locomotion").join(name);
    if path.exists() {
        Some(path)
    } else {
        eprintln!(
            "SKIPPED: {test}: {} not found (set MOTION_DATA_DIR)",
            path.display()
        );
        None
    }
}

/// The CMU takes on ASF names (16_15: `pelvis, lfemur, thorax, lhumerus, ...`, no `Spine` or
/// `Neck` counterpart) and 3dsMax-friendly names (131_01: `LeftHip`, `LeftCollar`, and
/// `LeftShoulder` for the upper arm) are recognised and retargeted onto an upright H3.6M body
/// moving at the take's pace.
#[test]
fn cmu_asf_and_3dsmax_takes_retarget_onto_an_upright_h36m_body() {
    use motion::core::retarget::{JointMap, Retargeter};
    // (take, built-in map, rig metres per unit, the take's hips path over its length in metres
    // (manifest.tsv: 1 s smoothing))
    for (take, preset, metres_per_unit, path_m) in [
        ("16_15.bvh", "CMU ASF-named", 0.01, 4.52),
        ("131_01.bvh", "CMU 3dsMax-friendly BVH", 0.056444, 4.53),
    ] {
        let test = "cmu_asf_and_3dsmax_takes_retarget_onto_an_upright_h36m_body";
        let Some(path) = cmu_locomotion_take(test, take) else {
            return;
        };
        let bvh = read_bvh(&path).unwrap();
        let map = JointMap::detect(&bvh.skeleton).unwrap();
        assert_eq!(map.name, preset, "{take}");
        let r = Retargeter::new(&bvh.skeleton, map).unwrap();
        let model = r.to_model(bvh.frames.view(), bvh.frame_time);
        let p = channel_positions(&model.skeleton, model.frames.view()).unwrap();
        let h36m = Skeleton::h36m();
        let at = |t: usize, joint: &str| {
            let j = h36m.joint_index(joint).unwrap();
            [p[[t, j, 0]], p[[t, j, 1]], p[[t, j, 2]]]
        };
        let y = |t: usize, joint: &str| at(t, joint)[1];
        // The first frame: hips above the ankles, head above the hips, each upper arm hanging
        // (the elbow below the shoulder), the head 1.4-1.9 m above the lower foot.
        let floor = y(0, "LeftFoot").min(y(0, "RightFoot"));
        assert!(
            y(0, "Hips") > y(0, "LeftFoot") + 600.0 && y(0, "Hips") > y(0, "RightFoot") + 600.0,
            "{take}: hips {} feet {} {}",
            y(0, "Hips"),
            y(0, "LeftFoot"),
            y(0, "RightFoot")
        );
        assert!(y(0, "Head") > y(0, "Hips") + 400.0, "{take}");
        assert!(
            (1400.0..1900.0).contains(&(y(0, "Head") - floor)),
            "{take}: head {} mm above the foot",
            y(0, "Head") - floor
        );
        for side in ["Left", "Right"] {
            let (shoulder, elbow) = (y(0, &format!("{side}Arm")), y(0, &format!("{side}ForeArm")));
            assert!(
                elbow < shoulder - 100.0,
                "{take}: {side} elbow {elbow} shoulder {shoulder}"
            );
        }
        // Upright throughout: the head above the hips in every frame.
        for t in 0..model.frames.nrows() {
            assert!(y(t, "Head") > y(t, "Hips") + 300.0, "{take} frame {t}");
        }
        // The pace: the hips' ground path (1 s moving average) on the model, against the take's
        // in metres, through the body-size ratio of the two skeletons (model metres per rig
        // metre), within 25 %.
        let fps = (1.0 / bvh.frame_time).round() as usize;
        let n = model.frames.nrows();
        let smooth: Vec<[f64; 2]> = (0..=n - fps)
            .map(|t| {
                let (mut x, mut z) = (0.0, 0.0);
                for k in t..t + fps {
                    x += at(k, "Hips")[0] / fps as f64;
                    z += at(k, "Hips")[2] / fps as f64;
                }
                [x, z]
            })
            .collect();
        let model_path_m: f64 = smooth
            .windows(2)
            .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
            .sum::<f64>()
            / 1000.0;
        let ratio = 1.0 / (r.scale() * 1000.0 * metres_per_unit);
        let rig_path_m = model_path_m / ratio;
        let seconds = n as f64 * bvh.frame_time;
        eprintln!(
            "{take}: model path {model_path_m:.2} m ({:.2} m/s), rig {rig_path_m:.2} m ({:.2} m/s), size ratio {ratio:.3}",
            model_path_m / seconds,
            rig_path_m / seconds
        );
        assert!(
            (rig_path_m / path_m - 1.0).abs() < 0.25,
            "{take}: {rig_path_m} m against {path_m} m"
        );
        assert!((0.8..1.4).contains(&ratio), "{take}: size ratio {ratio}");
    }
}
