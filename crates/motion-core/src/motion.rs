//! A motion clip: frames x channels, a frame rate, the skeleton and how to read the channels.
use std::sync::Arc;

use ndarray::{s, Array2, Array3, ArrayView2};

use crate::error::MotionError;
use crate::kinematics;
use crate::skeleton::{Skeleton, H36M_SOURCE_FPS};

pub use crate::root::RootEncoding;

/// The slowest frame rate any reader or command accepts: H3.6M root deltas are per 50 Hz source
/// frame, and below 1 fps one frame would span more than 50 of them.
pub const MIN_FPS: f64 = 1.0;
/// The fastest frame rate any reader or command accepts: above it a file's frame time is almost
/// surely in the wrong unit (a BVH `Frame Time` in milliseconds), and resampling it would take
/// thousands of times its frames.
pub const MAX_FPS: f64 = 10_000.0;

/// The one frame-rate rule of every command: `fps` finite and within [`MIN_FPS`] ..= [`MAX_FPS`];
/// `Err` says what is wrong.
pub fn check_fps(fps: f64) -> Result<(), String> {
    if fps.is_finite() && (MIN_FPS..=MAX_FPS).contains(&fps) {
        Ok(())
    } else {
        Err(format!(
            "{} fps is outside {MIN_FPS} ..= {MAX_FPS} frames per second",
            compact_number(fps)
        ))
    }
}

/// `x` for an error line: as written when it is of everyday size, else in scientific notation
/// with four significant digits (`1.000e300`, never three hundred digits).
pub fn compact_number(x: f64) -> String {
    if x == 0.0 || (x.is_finite() && (1e-4..1e7).contains(&x.abs())) {
        let short = format!("{x:.6}");
        let short = short.trim_end_matches('0').trim_end_matches('.');
        short.to_string()
    } else if x.is_finite() {
        format!("{x:.3e}")
    } else {
        format!("{x}")
    }
}

/// [`check_fps`] for a BVH `Frame Time` (seconds per frame), naming it and hinting at
/// milliseconds when it looks like them.
pub fn check_frame_time(frame_time: f64) -> Result<(), String> {
    check_fps(1.0 / frame_time).map_err(|_| {
        format!(
            "Frame Time {} s is {} fps, outside {MIN_FPS} ..= {MAX_FPS} fps{}",
            compact_number(frame_time),
            compact_number(1.0 / frame_time),
            if frame_time >= 1.0 {
                " (is it in milliseconds? BVH frame times are seconds)"
            } else {
                ""
            }
        )
    })
}

/// How the channels of a frame are laid out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MotionLayout {
    /// Exp-map frames: dims 0..2 root translation, then one exp-map triple per joint
    /// (`3 + 3 * joints` dims), row-vector FK (h36m.md).
    ExpMap {
        /// How the root is stored.
        root: RootEncoding,
    },
    /// BVH channels: each joint's channels in skeleton order (`Skeleton::channel_count()` dims),
    /// values as in the BVH file (rotations in **degrees**), column-vector FK.
    Channels,
}

impl MotionLayout {
    /// The number of channels a frame of this layout has on `skeleton`.
    pub fn width(&self, skeleton: &Skeleton) -> usize {
        match self {
            MotionLayout::ExpMap { .. } => skeleton.expmap_width(),
            MotionLayout::Channels => skeleton.channel_count(),
        }
    }
}

/// A motion clip: `frames x channels` values, a frame rate, a shared skeleton and a layout.
#[derive(Debug, Clone)]
pub struct Motion {
    frames: Array2<f64>,
    fps: f64,
    skeleton: Arc<Skeleton>,
    layout: MotionLayout,
}

/// The built-in skeleton and root encoding of exp-map frames `width` values wide: 99 = H3.6M
/// (root deltas), 117 = CMU (absolute root); `None` for any other width.
pub fn expmap_layout_for_width(width: usize) -> Option<(Skeleton, RootEncoding)> {
    match width {
        crate::skeleton::H36M_FRAME_DIMS => Some((Skeleton::h36m(), RootEncoding::Deltas)),
        crate::skeleton::CMU_FRAME_DIMS => Some((Skeleton::cmu(), RootEncoding::Absolute)),
        _ => None,
    }
}

impl Motion {
    /// A motion; checks that the frame width fits the layout and that `fps` is finite and at
    /// least 1 (slower rates are not motion capture, and would make [`Motion::root_step`] integrate
    /// an unbounded number of source frames per frame).
    pub fn new(
        skeleton: Arc<Skeleton>,
        layout: MotionLayout,
        frames: Array2<f64>,
        fps: f64,
    ) -> Result<Motion, MotionError> {
        let expected = layout.width(&skeleton);
        if frames.ncols() != expected {
            return Err(MotionError::ChannelCount {
                expected,
                found: frames.ncols(),
            });
        }
        if !(fps.is_finite() && fps >= 1.0) {
            return Err(MotionError::BadFps {
                fps: fps.to_string(),
            });
        }
        Ok(Motion {
            frames,
            fps,
            skeleton,
            layout,
        })
    }

    /// An H3.6M exp-map motion (root deltas) on the built-in 32-joint skeleton.
    pub fn h36m(frames: Array2<f64>, fps: f64) -> Result<Motion, MotionError> {
        Motion::new(
            Arc::new(Skeleton::h36m()),
            MotionLayout::ExpMap {
                root: RootEncoding::Deltas,
            },
            frames,
            fps,
        )
    }

    /// Exp-map frames on the built-in skeleton their width names: 99 columns are H3.6M (root
    /// deltas), 117 CMU (absolute root). `None` for any other width.
    pub fn expmap_of_width(frames: Array2<f64>, fps: f64) -> Option<Result<Motion, MotionError>> {
        let (skeleton, root) = expmap_layout_for_width(frames.ncols())?;
        Some(Motion::new(
            Arc::new(skeleton),
            MotionLayout::ExpMap { root },
            frames,
            fps,
        ))
    }

    /// All frames, `frames x channels`.
    pub fn frames(&self) -> ArrayView2<'_, f64> {
        self.frames.view()
    }

    /// Mutable access to the values (the shape cannot change).
    pub fn frames_mut(&mut self) -> ndarray::ArrayViewMut2<'_, f64> {
        self.frames.view_mut()
    }

    /// The frames, consuming the motion.
    pub fn into_frames(self) -> Array2<f64> {
        self.frames
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.frames.nrows()
    }

    /// True if there are no frames.
    pub fn is_empty(&self) -> bool {
        self.frames.nrows() == 0
    }

    /// Channels per frame.
    pub fn channels(&self) -> usize {
        self.frames.ncols()
    }

    /// Frames per second.
    pub fn fps(&self) -> f64 {
        self.fps
    }

    /// Seconds per frame.
    pub fn frame_time(&self) -> f64 {
        1.0 / self.fps
    }

    /// The skeleton.
    pub fn skeleton(&self) -> &Arc<Skeleton> {
        &self.skeleton
    }

    /// The channel layout.
    pub fn layout(&self) -> MotionLayout {
        self.layout
    }

    /// Source frames per frame for H3.6M root deltas, which are per 50 Hz source frame:
    /// `round(50 / fps)`, at least 1 (1 at 50 Hz, 2 at 25 Hz).
    pub fn root_step(&self) -> usize {
        ((H36M_SOURCE_FPS / self.fps).round() as usize).max(1)
    }

    /// A view of `len` frames from `start` (no copy).
    pub fn window(&self, start: usize, len: usize) -> Result<ArrayView2<'_, f64>, MotionError> {
        let frames = self.frames.nrows();
        match start.checked_add(len) {
            Some(end) if end <= frames => Ok(self.frames.slice(s![start..end, ..])),
            _ => Err(MotionError::WindowOutOfRange { start, len, frames }),
        }
    }

    /// World joint positions, `frames x joints x 3` (mm), with the FK of the layout
    /// (exp-map row-vector FK with the root integrated, or BVH channel FK).
    pub fn positions(&self) -> Array3<f64> {
        let result = match self.layout {
            MotionLayout::ExpMap { root } => kinematics::expmap_positions(
                &self.skeleton,
                self.frames.view(),
                root,
                self.root_step(),
            ),
            MotionLayout::Channels => {
                kinematics::channel_positions(&self.skeleton, self.frames.view())
            }
        };
        result.expect("Motion::new checked the width")
    }
}

/// A number frames may be given in (`f32` or `f64`); the models compute in `f32`, kinematics and
/// file formats in `f64`.
pub trait FrameScalar: Copy {
    /// The value as f32 (what the model computes with).
    fn to_f32(self) -> f32;
    /// The value as f64.
    fn to_f64(self) -> f64;
}

impl FrameScalar for f32 {
    fn to_f32(self) -> f32 {
        self
    }
    fn to_f64(self) -> f64 {
        self as f64
    }
}

impl FrameScalar for f64 {
    fn to_f32(self) -> f32 {
        self as f32
    }
    fn to_f64(self) -> f64 {
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn construction_checks_width_and_fps() {
        let err = Motion::h36m(Array2::zeros((3, 98)), 50.0).unwrap_err();
        assert_eq!(
            err,
            MotionError::ChannelCount {
                expected: 99,
                found: 98
            }
        );
        assert!(matches!(
            Motion::h36m(Array2::zeros((3, 99)), 0.0),
            Err(MotionError::BadFps { .. })
        ));
        assert!(Motion::h36m(Array2::zeros((3, 99)), f64::NAN).is_err());
        // A tiny rate would make root integration loop once per source frame without bound.
        assert!(matches!(
            Motion::h36m(Array2::zeros((3, 99)), 1e-300),
            Err(MotionError::BadFps { .. })
        ));
        let bvh = Motion::new(
            Arc::new(Skeleton::h36m()),
            MotionLayout::Channels,
            Array2::zeros((2, 99)),
            120.0,
        )
        .unwrap();
        assert_eq!(bvh.channels(), 99);
        assert!((bvh.frame_time() - 1.0 / 120.0).abs() < 1e-15);
    }

    #[test]
    fn windows_are_views_and_checked() {
        let frames = Array2::from_shape_fn((10, 99), |(t, k)| (t * 100 + k) as f64);
        let m = Motion::h36m(frames, 25.0).unwrap();
        assert_eq!(m.root_step(), 2);
        let w = m.window(3, 4).unwrap();
        assert_eq!(w.dim(), (4, 99));
        assert_eq!(w[[0, 5]], 305.0);
        assert!(m.window(7, 3).is_ok());
        assert_eq!(
            m.window(8, 3).unwrap_err(),
            MotionError::WindowOutOfRange {
                start: 8,
                len: 3,
                frames: 10
            }
        );
        assert!(m.window(usize::MAX, 2).is_err());
    }

    #[test]
    fn positions_dispatch_on_layout() {
        let m = Motion::h36m(Array2::zeros((2, 99)), 50.0).unwrap();
        let p = m.positions();
        assert_eq!(p.dim(), (2, 32, 3));
        let c = Motion::new(
            Arc::new(Skeleton::h36m()),
            MotionLayout::Channels,
            Array2::zeros((2, 99)),
            50.0,
        )
        .unwrap();
        assert_eq!(c.positions(), p);
    }

    #[test]
    fn numbers_in_error_lines_are_short() {
        assert_eq!(compact_number(25.0), "25");
        assert_eq!(compact_number(0.04), "0.04");
        assert_eq!(compact_number(1e300), "1.000e300");
        assert_eq!(compact_number(1e-38), "1.000e-38");
        assert!(compact_number(f64::MAX).len() < 12);
        assert_eq!(compact_number(f64::INFINITY), "inf");
    }
}
