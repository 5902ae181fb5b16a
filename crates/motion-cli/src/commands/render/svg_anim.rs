//! The SVG animation (SMIL): one path per motion and body side whose `d` attribute is animated
//! through every frame (browsers interpolate between frames), strokes switching from grey to the
//! motion's colour where the prediction starts, a legend, and a progress bar with the
//! seed/prediction boundary. The first frame is the static picture for viewers without SMIL.
use std::fmt::Write as _;

use super::paint::Picture;
use super::scene::{bounds, Side, Viewport};
use super::style::{bone_colour, track_colour, BOUNDARY, GRID, SEED_BAR, TEXT};

/// Height of the progress bar strip at the bottom.
const STRIP: f64 = 18.0;

/// The SVG document of the animation of `picture` over `times`, `width x height` pixels.
pub fn animate(picture: &Picture<'_>, times: &[f64], width: usize, height: usize) -> String {
    let (w, h) = (width as f64, height as f64);
    let (min, max) = bounds(&picture.camera, &picture.tracks);
    let viewport = Viewport::fit(min, max, 0.0, 0.0, w, h - STRIP, 16.0);
    let fps = picture.tracks[0].fps;
    let duration = (times.len().max(2) - 1) as f64 / fps;
    let px = |p: [f64; 3]| {
        let (u, v, _) = picture.camera.project(p);
        viewport.to_pixels((u, v))
    };
    let boundary = picture
        .seed_frames
        .map(|n| (n as f64 / fps / duration).clamp(0.0, 1.0));

    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {width} {height}" width="{width}" height="{height}" font-family="sans-serif">"#
    );
    let _ = writeln!(svg, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = write!(svg, r#"<g stroke="{}" stroke-width="1">"#, GRID.hex());
    for &(a, b) in &picture.grid {
        let (a, b) = (px(a), px(b));
        let _ = write!(
            svg,
            r#"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}"/>"#,
            a.0, a.1, b.0, b.1
        );
    }
    let _ = writeln!(svg, "</g>");

    // The camera looks at the character's right side: its left limbs are farther, drawn first.
    for (k, track) in picture.tracks.iter().enumerate() {
        for side in [Side::Left, Side::Centre, Side::Right] {
            let bones: Vec<_> = track.bones.iter().filter(|b| b.side == side).collect();
            if bones.is_empty() {
                continue;
            }
            let path_at = |t: f64| {
                let f = track.frame_at(t);
                let joint = |j: usize| px([0, 1, 2].map(|a| track.positions[[f, j, a]]));
                let mut d = String::new();
                for bone in &bones {
                    let (a, b) = (joint(bone.from), joint(bone.to));
                    let _ = write!(d, "M{:.1} {:.1}L{:.1} {:.1}", a.0, a.1, b.0, b.1);
                }
                d
            };
            let values: Vec<String> = times.iter().map(|&t| path_at(t)).collect();
            let seed_colour = bone_colour(k, side, true).hex();
            let colour = bone_colour(k, side, false).hex();
            // Only IN has a seed; the compared motion keeps its colour throughout.
            let boundary = boundary.filter(|_| k == 0);
            let first_colour = if boundary.is_some() {
                &seed_colour
            } else {
                &colour
            };
            let _ = writeln!(
                svg,
                r#"<path d="{}" fill="none" stroke="{first_colour}" stroke-width="3" stroke-linecap="round">"#,
                values[0]
            );
            let _ = writeln!(
                svg,
                r#"<animate attributeName="d" dur="{duration:.3}s" repeatCount="indefinite" values="{}"/>"#,
                values.join(";")
            );
            if let Some(b) = boundary {
                let _ = writeln!(
                    svg,
                    r#"<animate attributeName="stroke" dur="{duration:.3}s" repeatCount="indefinite" calcMode="discrete" keyTimes="0;{b:.4}" values="{seed_colour};{colour}"/>"#
                );
            }
            let _ = writeln!(svg, "</path>");
        }
    }

    // Legend.
    let mut x = 10.0;
    for (k, track) in picture.tracks.iter().enumerate() {
        let label = if k == 0 {
            escape(&track.name)
        } else {
            format!("vs {}", escape(&track.name))
        };
        let _ = writeln!(
            svg,
            r#"<rect x="{x:.1}" y="10" width="14" height="8" fill="{}"/><text x="{:.1}" y="19" font-size="13" fill="{}">{label}</text>"#,
            track_colour(k).hex(),
            x + 20.0,
            TEXT.hex()
        );
        x += 30.0 + 7.5 * label.chars().count() as f64;
    }
    if let Some(b) = boundary {
        let _ = writeln!(
            svg,
            r#"<text x="{:.1}" y="38" font-size="13" fill="{}">seed<animate attributeName="visibility" dur="{duration:.3}s" repeatCount="indefinite" calcMode="discrete" keyTimes="0;{b:.4}" values="visible;hidden"/></text>"#,
            10.0,
            TEXT.hex()
        );
        let _ = writeln!(
            svg,
            r#"<text x="{:.1}" y="38" font-size="13" fill="{}" visibility="hidden">prediction<animate attributeName="visibility" dur="{duration:.3}s" repeatCount="indefinite" calcMode="discrete" keyTimes="0;{b:.4}" values="hidden;visible"/></text>"#,
            10.0,
            BOUNDARY.hex()
        );
    }

    // Progress bar: seed part grey, prediction coloured, red boundary tick, moving playhead.
    let (x0, x1, y) = (8.0, w - 8.0, h - STRIP + 6.0);
    let split = x0 + (x1 - x0) * boundary.unwrap_or(0.0);
    let _ = writeln!(
        svg,
        r#"<rect x="{x0}" y="{y}" width="{:.1}" height="6" fill="{}"/><rect x="{split:.1}" y="{y}" width="{:.1}" height="6" fill="{}"/>"#,
        split - x0,
        SEED_BAR.hex(),
        x1 - split,
        track_colour(0).hex()
    );
    if boundary.is_some() {
        let _ = writeln!(
            svg,
            r#"<rect x="{:.1}" y="{:.1}" width="3" height="14" fill="{}"/>"#,
            split - 1.5,
            y - 4.0,
            BOUNDARY.hex()
        );
    }
    let _ = writeln!(
        svg,
        r#"<rect x="{:.1}" y="{:.1}" width="2" height="12" fill="black"><animate attributeName="x" dur="{duration:.3}s" repeatCount="indefinite" values="{:.1};{:.1}"/></rect>"#,
        x0 - 1.0,
        y - 3.0,
        x0 - 1.0,
        x1 - 1.0
    );
    svg.push_str("</svg>\n");
    svg
}

/// Text escaped for XML.
pub fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
