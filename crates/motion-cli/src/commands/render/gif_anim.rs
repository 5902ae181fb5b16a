//! The GIF animation: every frame (at most 25 per second) from one fixed camera framing the whole
//! trajectory, a time label, and a progress bar along the bottom (grey over the seed, coloured
//! over the prediction, a red tick at the boundary, a black playhead).
use std::collections::HashMap;

use super::paint::Picture;
use super::scene::{bounds, Viewport};
use super::style::{all_colours, track_colour, BACKGROUND, BOUNDARY, SEED_BAR, TEXT};
use crate::raster::{Anchor, Canvas, Rgb};

/// Height of the progress bar strip at the bottom.
const STRIP: usize = 18;

/// A palette of `colours` blended with the background at 8 levels each (at most 256 entries).
fn palette() -> Vec<Rgb> {
    let mut out = vec![BACKGROUND];
    for c in all_colours().into_iter().chain([Rgb::BLACK]) {
        for level in 1..=8 {
            let a = level as f32 / 8.0;
            let mix = |x: u8, bg: u8| (bg as f32 + (x as f32 - bg as f32) * a).round() as u8;
            let blended = Rgb(
                mix(c.0, BACKGROUND.0),
                mix(c.1, BACKGROUND.1),
                mix(c.2, BACKGROUND.2),
            );
            if !out.contains(&blended) {
                out.push(blended);
            }
        }
    }
    out.truncate(256);
    out
}

/// Palette indices of a canvas (nearest colour, memoized per distinct pixel).
fn quantize(canvas: &Canvas, palette: &[Rgb], cache: &mut HashMap<[u8; 3], u8>) -> Vec<u8> {
    canvas
        .to_rgb8()
        .chunks_exact(3)
        .map(|p| {
            let key = [p[0], p[1], p[2]];
            if key == [BACKGROUND.0, BACKGROUND.1, BACKGROUND.2] {
                return 0; // most pixels; palette entry 0 is the background
            }
            *cache.entry(key).or_insert_with(|| {
                let d = |c: &Rgb| {
                    let e = |a: u8, b: u8| (a as i32 - b as i32).pow(2);
                    e(c.0, key[0]) + e(c.1, key[1]) + e(c.2, key[2])
                };
                (0..palette.len())
                    .min_by_key(|&i| d(&palette[i]))
                    .unwrap_or(0) as u8
            })
        })
        .collect()
}

/// One drawn frame in this many of `fps`: browsers slow delays under 2/100 s down to 1/10 s, so
/// a GIF keeps at most 25 frames per second.
fn frame_step(fps: f64) -> usize {
    (fps / 25.0).ceil().max(1.0) as usize
}

/// How many frames [`animate`] draws for `times`.
pub fn drawn_frames(picture: &Picture<'_>, times: &[f64]) -> usize {
    times.len().div_ceil(frame_step(picture.tracks[0].fps))
}

/// Encodes the animation of `picture` over `times` as GIF bytes, `width x height` pixels,
/// advancing `bar` by one per drawn frame.
pub fn animate(
    picture: &Picture<'_>,
    times: &[f64],
    width: usize,
    height: usize,
    bar: &indicatif::ProgressBar,
) -> anyhow::Result<Vec<u8>> {
    let fps = picture.tracks[0].fps;
    let every = frame_step(fps);
    let delay = ((every as f64 / fps) * 100.0).round().max(2.0) as u16;
    let (min, max) = bounds(&picture.camera, &picture.tracks);
    let viewport = Viewport::fit(
        min,
        max,
        0.0,
        0.0,
        width as f64,
        (height - STRIP) as f64,
        16.0,
    );
    let palette = palette();
    let flat: Vec<u8> = palette.iter().flat_map(|c| [c.0, c.1, c.2]).collect();
    let mut bytes = Vec::new();
    {
        let mut encoder = gif::Encoder::new(&mut bytes, width as u16, height as u16, &flat)?;
        encoder.set_repeat(gif::Repeat::Infinite)?;
        let mut cache = HashMap::new();
        let duration = times.last().copied().unwrap_or(0.0).max(1e-9);
        let boundary = picture.seed_frames.map(|n| n as f64 / fps);
        let mut background = Canvas::new(width, height, BACKGROUND);
        picture.paint_grid(&mut background, &viewport);
        for &t in times.iter().step_by(every) {
            let mut canvas = background.clone();
            picture.paint_bones(&mut canvas, &viewport, t, 3.0);
            let label = match boundary {
                Some(_) if picture.is_seed(t) => format!("{t:.2}S SEED"),
                Some(_) => format!("{t:.2}S PREDICTION"),
                None => format!("{t:.2}S"),
            };
            canvas.text(8.0, 8.0, &label, 2, Anchor::Start, TEXT);
            progress_bar(
                &mut canvas,
                t / duration,
                boundary.map(|b| b / duration),
                STRIP,
            );
            let mut frame = gif::Frame {
                width: width as u16,
                height: height as u16,
                delay,
                buffer: std::borrow::Cow::Owned(quantize(&canvas, &palette, &mut cache)),
                ..gif::Frame::default()
            };
            frame.dispose = gif::DisposalMethod::Keep;
            encoder.write_frame(&frame)?;
            bar.inc(1);
        }
    }
    Ok(bytes)
}

/// The bar along the bottom `strip` pixels: `at` and `boundary` are fractions of the duration.
pub fn progress_bar(canvas: &mut Canvas, at: f64, boundary: Option<f64>, strip: usize) {
    let w = canvas.width() as f64;
    let y = (canvas.height() - strip) as f64 + 6.0;
    let (x0, x1) = (8.0, w - 8.0);
    let split = boundary.map_or(x0, |b| x0 + (x1 - x0) * b.clamp(0.0, 1.0));
    canvas.fill_rect(x0, y, split - x0, 6.0, SEED_BAR);
    canvas.fill_rect(split, y, x1 - split, 6.0, track_colour(0));
    if boundary.is_some() {
        canvas.fill_rect(split - 1.5, y - 4.0, 3.0, 14.0, BOUNDARY);
    }
    let head = x0 + (x1 - x0) * at.clamp(0.0, 1.0);
    canvas.fill_rect(head - 1.0, y - 3.0, 2.0, 12.0, Rgb::BLACK);
}
