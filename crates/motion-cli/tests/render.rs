//! `motion-cli render`, driven through the built binary on the procedural seed
//! `examples/walk_seed.bvh` and a fixture-model prediction (no `../shared` data needed). The
//! pictures are decoded and checked for size, frame count and the colours that should be there;
//! `CARGO_TARGET_TMPDIR/render-*/` keeps them (and PNGs of two GIF frames) for a look.
mod common;

use common::{repo, scratch, walk_seed};
use std::path::{Path, PathBuf};
use std::process::Command;

fn motion_cli(args: &[&dyn AsRef<std::ffi::OsStr>]) -> (i32, String, String) {
    let output = Command::new(env!("CARGO_BIN_EXE_motion-cli"))
        .args(args.iter().map(|a| a.as_ref()))
        .output()
        .expect("runs motion-cli");
    (
        output.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&output.stdout).into_owned(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

fn ok(args: &[&dyn AsRef<std::ffi::OsStr>]) -> String {
    let (code, stdout, stderr) = motion_cli(args);
    assert_eq!(code, 0, "motion-cli failed: {stderr}");
    stdout
}

/// A fixture-model prediction from the walk seed: 10 seed + 40 predicted frames.
fn prediction(dir: &Path) -> PathBuf {
    let out = dir.join("pred.bvh");
    ok(&[
        &"predict",
        &"--model",
        &repo().join("tests/fixtures/parity/vgru_d.safetensors"),
        &"--seed",
        &walk_seed(),
        &"--frames",
        &"40",
        &"--out",
        &out,
        &"--quiet",
    ]);
    out
}

/// Decoded RGB8 pixels and size of a PNG.
fn read_png(path: &Path) -> (usize, usize, Vec<u8>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    buf.truncate(info.buffer_size());
    (info.width as usize, info.height as usize, buf)
}

/// Counts pixels that are clearly blue (the first motion) / orange (the second) / grey (seed).
fn colour_counts(rgb: &[u8]) -> (usize, usize, usize) {
    let (mut blue, mut orange, mut grey) = (0, 0, 0);
    for p in rgb.chunks_exact(3) {
        let (r, g, b) = (p[0] as i32, p[1] as i32, p[2] as i32);
        if b > r + 60 && b > 150 {
            blue += 1;
        } else if r > b + 100 && g > 60 {
            orange += 1;
        } else if (r - g).abs() < 6 && (g - b).abs() < 6 && r < 180 && r > 60 {
            grey += 1;
        }
    }
    (blue, orange, grey)
}

fn write_rgb_png(path: &Path, width: usize, height: usize, rgb: &[u8]) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut encoder = png::Encoder::new(file, width as u32, height as u32);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder
        .write_header()
        .unwrap()
        .write_image_data(rgb)
        .unwrap();
}

#[test]
fn contact_sheet_of_the_walk_shows_a_person() {
    let dir = scratch("sheet");
    let out = dir.join("walk.png");
    let report = ok(&[&"render", &walk_seed(), &"--out", &out, &"--json"]);
    let report: serde_json::Value = serde_json::from_str(&report).unwrap();
    assert_eq!(report["frames"], 75);
    let (w, h, rgb) = read_png(&out);
    assert_eq!((w, h), (6 * 180, 30 + 2 * 250));
    let (blue, orange, _) = colour_counts(&rgb);
    assert!(blue > 3000, "{blue} blue pixels");
    assert_eq!(orange, 0);
    // Each cell holds a figure: blue pixels in every one of the 12 cells below the label bar.
    for cell in 0..12 {
        let (x0, y0) = ((cell % 6) * 180, 30 + (cell / 6) * 250 + 18);
        let mut n = 0;
        for y in y0..y0 + 232 {
            for x in x0..x0 + 180 {
                let p = &rgb[3 * (y * w + x)..3 * (y * w + x) + 3];
                if p[2] as i32 > p[0] as i32 + 60 {
                    n += 1;
                }
            }
        }
        assert!(n > 200, "cell {cell}: {n} figure pixels");
    }
}

#[test]
fn gif_animation_with_compare_and_seed_boundary() {
    let dir = scratch("gif");
    let pred = prediction(&dir);
    let out = dir.join("compare.gif");
    ok(&[
        &"render",
        &pred,
        &"--compare",
        &walk_seed(),
        &"--seed-frames",
        &"10",
        &"--width",
        &"240",
        &"--height",
        &"180",
        &"--out",
        &out,
    ]);
    let mut options = gif::DecodeOptions::new();
    options.set_color_output(gif::ColorOutput::RGBA);
    let mut decoder = options
        .read_info(std::fs::File::open(&out).unwrap())
        .unwrap();
    assert_eq!((decoder.width(), decoder.height()), (240, 180));
    let mut frames = Vec::new();
    while let Some(frame) = decoder.read_next_frame().unwrap() {
        assert_eq!(frame.delay, 4, "25 Hz");
        let rgb: Vec<u8> = frame
            .buffer
            .chunks_exact(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect();
        frames.push(rgb);
    }
    // The longer motion (the 75-frame seed) sets the length.
    assert_eq!(frames.len(), 75);
    // Above the progress bar (bottom 18 rows), which is blue over the prediction.
    let picture = |rgb: &[u8]| rgb[..(180 - 18) * 240 * 3].to_vec();
    let (blue0, orange0, grey0) = colour_counts(&picture(&frames[2]));
    assert!(grey0 > 100, "seed frames are grey: {grey0}");
    assert!(orange0 > 100, "the compared motion is orange: {orange0}");
    assert!(blue0 < grey0, "IN is not blue before the boundary");
    let (blue, orange, _) = colour_counts(&picture(&frames[30]));
    assert!(blue > 100 && orange > 100, "{blue} blue, {orange} orange");
    write_rgb_png(&dir.join("frame02.png"), 240, 180, &frames[2]);
    write_rgb_png(&dir.join("frame30.png"), 240, 180, &frames[30]);
}

#[test]
fn svg_animation_is_smil_over_every_frame() {
    let dir = scratch("svg");
    let pred = prediction(&dir);
    let out = dir.join("pred.svg");
    ok(&[
        &"render",
        &pred,
        &"--seed-frames",
        &"10",
        &"--out",
        &out,
        &"--quiet",
    ]);
    let svg = std::fs::read_to_string(&out).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    let animate = svg
        .lines()
        .find(|l| l.contains(r#"attributeName="d""#))
        .expect("an animated path");
    let values = animate.split("values=\"").nth(1).unwrap();
    assert_eq!(values.matches(';').count() + 1, 50, "one value per frame");
    // Frame k is shown at k/49 of the loop: grey until frame 10.
    assert!(
        svg.contains("keyTimes=\"0;0.2041\""),
        "grey until frame 10 of 50"
    );
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        2,
        "no temporary file left"
    );
}

#[test]
fn exp_map_and_npy_inputs_render_too() {
    let dir = scratch("inputs");
    let pred = dir.join("pred.npy");
    ok(&[
        &"predict",
        &"--model",
        &repo().join("tests/fixtures/parity/vgru_d.safetensors"),
        &"--seed",
        &walk_seed(),
        &"--frames",
        &"10",
        &"--samples",
        &"2",
        &"--out",
        &pred,
        &"--quiet",
    ]);
    let out = dir.join("sample1.png");
    ok(&[
        &"render",
        &pred,
        &"--input-fps",
        &"25",
        &"--sample",
        &"1",
        &"--cells",
        &"4",
        &"--columns",
        &"4",
        &"--out",
        &out,
        &"--quiet",
    ]);
    let (w, h, _) = read_png(&out);
    assert_eq!((w, h), (4 * 180, 30 + 250));
    let (code, _, stderr) = motion_cli(&[&"render", &pred, &"--sample", &"2", &"--out", &out]);
    assert_eq!(code, 2);
    assert!(stderr.contains("--sample 2 is out of range"), "{stderr}");
}

/// Exp-map frames (50 Hz) of a still rest pose that stays upright for 50 frames, then tips over:
/// a root rotation of 0.01 rad per frame about z (57° after 100 frames).
fn tipping_over(dir: &Path) -> PathBuf {
    let frames =
        ndarray::Array2::from_shape_fn(
            (150, 99),
            |(t, d)| {
                if d == 5 && t >= 50 {
                    0.01
                } else {
                    0.0
                }
            },
        );
    let path = dir.join("tipping.npy");
    motion_core::formats::npy::write_npy(&path, &frames).unwrap();
    path
}

#[test]
fn a_growing_lean_is_drawn_unless_upright_is_asked_for() {
    let dir = scratch("lean");
    let input = tipping_over(&dir);
    let out = dir.join("lean.svg");
    // Default: the first frame is upright, so nothing is turned and the fall is drawn.
    let (code, stdout, stderr) = motion_cli(&[&"render", &input, &"--out", &out, &"--json"]);
    assert_eq!(code, 0, "{stderr}");
    let report: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(report["upright"], "first frame");
    let (code, _, stderr) = motion_cli(&[&"render", &input, &"--out", &out]);
    assert_eq!(code, 0, "{stderr}");
    assert!(!stderr.contains("note:"), "{stderr}");
    // --upright straightens the average lean of the whole motion, and says so.
    let (code, _, stderr) = motion_cli(&[&"render", &input, &"--upright", &"--out", &out]);
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stderr.contains("the whole motion is drawn upright (--upright)"),
        "{stderr}"
    );
    // Both at once is a usage error.
    let (code, _, stderr) = motion_cli(&[
        &"render",
        &input,
        &"--upright",
        &"--no-upright",
        &"--out",
        &out,
    ]);
    assert_eq!(code, 2, "{stderr}");
}
