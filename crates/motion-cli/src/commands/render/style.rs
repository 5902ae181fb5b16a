//! Colours of the drawings: one hue per motion (blue, then orange), darker for the character's
//! left and lighter for its right; greys for seed frames; the seed/prediction boundary in red.
use super::scene::Side;
use crate::raster::Rgb;

/// Background.
pub const BACKGROUND: Rgb = Rgb::WHITE;
/// Floor grid lines.
pub const GRID: Rgb = Rgb(222, 222, 222);
/// Labels.
pub const TEXT: Rgb = Rgb(40, 40, 40);
/// The label bar of seed frames.
pub const SEED_BAR: Rgb = Rgb(150, 150, 150);
/// The seed/prediction boundary marker.
pub const BOUNDARY: Rgb = Rgb(214, 39, 40);

/// Bone colours `[left, right, centre]` of each motion (first: IN, second: --compare).
const TRACKS: [[Rgb; 3]; 2] = [
    [Rgb(21, 101, 192), Rgb(100, 181, 246), Rgb(30, 136, 229)],
    [Rgb(200, 70, 0), Rgb(255, 183, 77), Rgb(251, 140, 0)],
];
/// Bone colours `[left, right, centre]` of seed frames.
const SEED: [Rgb; 3] = [Rgb(90, 90, 90), Rgb(170, 170, 170), Rgb(128, 128, 128)];

/// The colour of a bone of motion `track` on `side`, in a seed frame or not.
pub fn bone_colour(track: usize, side: Side, seed: bool) -> Rgb {
    let shades = if seed { SEED } else { TRACKS[track.min(1)] };
    match side {
        Side::Left => shades[0],
        Side::Right => shades[1],
        Side::Centre => shades[2],
    }
}

/// The main colour of motion `track` (legends, progress bar).
pub fn track_colour(track: usize) -> Rgb {
    TRACKS[track.min(1)][2]
}

/// Every colour a drawing may use (the GIF palette is built from their blends with the
/// background).
pub fn all_colours() -> Vec<Rgb> {
    let mut colours = vec![GRID, TEXT, BOUNDARY, SEED_BAR];
    colours.extend(TRACKS.iter().flatten());
    colours.extend(SEED);
    colours
}
