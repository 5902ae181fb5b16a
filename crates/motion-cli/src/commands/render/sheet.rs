//! The PNG contact sheet: evenly spaced moments of the motion in a grid of cells, each cell
//! following the character (centred on the floor point under the first motion's root, so the
//! floor is at the same height in every cell) at one fixed scale, labelled
//! with its time; seed cells have a grey bar, prediction cells a coloured one, and a red line
//! marks where the prediction starts.
use super::paint::Picture;
use super::scene::Viewport;
use super::style::{track_colour, BACKGROUND, BOUNDARY, SEED_BAR, TEXT};
use crate::raster::{Anchor, Canvas};

/// Cell size in pixels.
const CELL_W: usize = 180;
const CELL_H: usize = 250;
/// Header height (title and legend).
const HEADER: usize = 30;
/// Label bar height at the top of a cell.
const BAR: usize = 18;

/// Draws `cells` moments in rows of `columns`.
pub fn contact_sheet(picture: &Picture<'_>, times: &[f64], cells: usize, columns: usize) -> Canvas {
    let cells = cells.clamp(1, times.len());
    let columns = columns.clamp(1, cells);
    let rows = cells.div_ceil(columns);
    let mut canvas = Canvas::new(columns * CELL_W, HEADER + rows * CELL_H, BACKGROUND);

    // Legend: each motion's name in its colour.
    let mut x = 8.0;
    for (k, track) in picture.tracks.iter().enumerate() {
        let label = if k == 0 {
            track.name.clone()
        } else {
            format!("vs {}", track.name)
        };
        canvas.fill_rect(x, 11.0, 14.0, 8.0, track_colour(k));
        canvas.text(x + 20.0, 8.0, &label, 2, Anchor::Start, TEXT);
        x += 20.0 + (crate::raster::text_width(&label) * 2) as f64 + 24.0;
    }

    // One scale for every cell: the body's extent around the root over the whole motion.
    let first = picture.tracks[0];
    let (mut min, mut max) = (
        (f64::INFINITY, f64::INFINITY),
        (f64::NEG_INFINITY, f64::NEG_INFINITY),
    );
    let floor = picture.grid.first().map_or(0.0, |l| l.0[1]);
    // Each cell follows the point of the floor under the root: the floor sits at the same
    // height in every cell (the camera's height is fixed), so a float or a sink shows.
    let under_root = |f: usize| {
        let r = first.root(f);
        let (u, v, _) = picture.camera.project([r[0], floor, r[2]]);
        (u, v)
    };
    for f in 0..first.len() {
        let (ru, rv) = under_root(f);
        for j in 0..first.positions.dim().1 {
            let p = [0, 1, 2].map(|a| first.positions[[f, j, a]]);
            let (u, v, _) = picture.camera.project(p);
            min = (min.0.min(u - ru), min.1.min(v - rv));
            max = (max.0.max(u - ru), max.1.max(v - rv));
        }
    }
    min.1 = min.1.min(0.0);
    let half = (-min.0).max(max.0);
    let template = Viewport::fit(
        (-half, min.1),
        (half, max.1),
        0.0,
        0.0,
        CELL_W as f64,
        (CELL_H - BAR) as f64,
        10.0,
    );

    let span = times.len() - 1;
    let mut previous_seed = None;
    for i in 0..cells {
        let index = if cells == 1 {
            0
        } else {
            (i * span + (cells - 1) / 2) / (cells - 1)
        };
        let t = times[index];
        let (col, row) = (i % columns, i / columns);
        let (x0, y0) = ((col * CELL_W) as f64, (HEADER + row * CELL_H) as f64);
        let f = first.frame_at(t);
        let (ru, rv) = under_root(f);
        let mut cell = Canvas::new(CELL_W, CELL_H, BACKGROUND);
        let local = Viewport {
            centre: (ru, rv + template.centre.1),
            pixel_centre: (
                CELL_W as f64 / 2.0,
                BAR as f64 + (CELL_H - BAR) as f64 / 2.0,
            ),
            ..template
        };
        picture.paint(&mut cell, &local, t, 3.0);
        let seed = picture.is_seed(t);
        let bar = if seed { SEED_BAR } else { track_colour(0) };
        cell.fill_rect(0.0, 0.0, CELL_W as f64, BAR as f64, bar);
        let tag = match (picture.seed_frames, seed) {
            (None, _) => String::new(),
            (Some(_), true) => " SEED".to_string(),
            (Some(_), false) => " PRED".to_string(),
        };
        cell.text(
            6.0,
            2.0,
            &format!("{t:.2}S{tag}"),
            2,
            Anchor::Start,
            BACKGROUND,
        );
        canvas.paste(&cell, x0 as usize, y0 as usize);
        if previous_seed == Some(true) && !seed {
            canvas.fill_rect(x0 - 2.0, y0, 4.0, CELL_H as f64, BOUNDARY);
        }
        previous_seed = Some(seed);
    }
    // Thin separators between cells.
    for col in 1..columns {
        canvas.fill_rect(
            (col * CELL_W) as f64,
            HEADER as f64,
            1.0,
            (rows * CELL_H) as f64,
            super::style::GRID,
        );
    }
    canvas
}
