//! Painting one moment of the scene onto a raster canvas (used by the GIF and the contact
//! sheet): floor grid, then every motion's bones, far ones first.
use super::scene::{Camera, Track, Viewport};
use super::style::{bone_colour, GRID};
use crate::raster::Canvas;

/// What a picture shows: the motions, the camera and the seed length.
pub struct Picture<'a> {
    /// The motions, first IN then --compare.
    pub tracks: Vec<&'a Track>,
    /// The camera.
    pub camera: Camera,
    /// Frames of IN that are seed (IN is drawn grey there; --compare keeps its colour), if known.
    pub seed_frames: Option<usize>,
    /// World floor grid segments.
    pub grid: Vec<([f64; 3], [f64; 3])>,
}

impl Picture<'_> {
    /// True if time `t` (s) lies in the seed.
    pub fn is_seed(&self, t: f64) -> bool {
        self.seed_frames
            .is_some_and(|n| self.tracks[0].frame_at(t) < n)
    }

    /// Paints the moment `t` (s) through `viewport`, with bones `width` pixels wide.
    pub fn paint(&self, canvas: &mut Canvas, viewport: &Viewport, t: f64, width: f64) {
        self.paint_grid(canvas, viewport);
        self.paint_bones(canvas, viewport, t, width);
    }

    /// Paints the floor grid (the same in every frame of a fixed camera).
    pub fn paint_grid(&self, canvas: &mut Canvas, viewport: &Viewport) {
        for &(a, b) in &self.grid {
            canvas.line(self.to_px(viewport, a), self.to_px(viewport, b), 1.0, GRID);
        }
    }

    fn to_px(&self, viewport: &Viewport, p: [f64; 3]) -> (f64, f64) {
        let (u, v, _) = self.camera.project(p);
        viewport.to_pixels((u, v))
    }

    /// Paints every motion's bones at moment `t` (s), far ones first.
    pub fn paint_bones(&self, canvas: &mut Canvas, viewport: &Viewport, t: f64, width: f64) {
        let to_px = |p: [f64; 3]| self.to_px(viewport, p);
        let seed = self.is_seed(t);
        // (depth, from, to, colour) of every bone of every motion, painted far to near.
        let mut strokes = Vec::new();
        for (k, track) in self.tracks.iter().enumerate() {
            let f = track.frame_at(t);
            let joint = |j: usize| [0, 1, 2].map(|a| track.positions[[f, j, a]]);
            for bone in &track.bones {
                let (a, b) = (joint(bone.from), joint(bone.to));
                let depth = (self.camera.project(a).2 + self.camera.project(b).2) / 2.0;
                strokes.push((
                    depth,
                    to_px(a),
                    to_px(b),
                    bone_colour(k, bone.side, seed && k == 0),
                ));
            }
        }
        strokes.sort_by(|x, y| y.0.total_cmp(&x.0));
        for (_, a, b, colour) in strokes {
            canvas.line(a, b, width, colour);
        }
    }
}
