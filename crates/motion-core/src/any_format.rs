//! Any motion file, as `motion-cli convert` (and any front end) handles it: exp-map text or `.npy`
//! on a built-in skeleton (by column count: 99 H3.6M, 117 CMU), exp-map columns of no known
//! skeleton (copied only), or a BVH; read by extension, resampled to any rate, turned into world
//! positions, and written as BVH, exp-map text or `.npy`.
use std::path::{Path, PathBuf};

use ndarray::{s, Array2, Array3, ArrayD, Ix2, Ix3};

use crate::error::{FormatError, MotionError};
use crate::formats::bvh::{read_bvh, write_bvh, Bvh};
use crate::formats::expmap_bvh::{bvh_to_expmap, expmap_to_bvh, offset_difference, ExpMapTarget};
use crate::formats::h36m_text::{downsample_protocol, read_expmap_text, write_expmap_text};
use crate::formats::npy::{read_npy_dyn, read_npy_frames, write_npy};
use crate::formats::FileFormat;
use crate::kinematics::channel_positions;
use crate::motion::{
    check_fps, check_frame_time, expmap_layout_for_width, Motion, MotionLayout, RootEncoding,
};
use crate::resample::resample_bvh;
use crate::skeleton::{Skeleton, CMU_FRAME_DIMS, H36M_FRAME_DIMS};

/// Why a motion file could not be read, converted or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AnyMotionError {
    /// Reading or writing failed.
    #[error(transparent)]
    Format(#[from] FormatError),
    /// Frames that are not a motion on their skeleton.
    #[error(transparent)]
    Motion(#[from] MotionError),
    /// The motion cannot be converted as asked (names the file).
    #[error("{}: {problem}", path.display())]
    Invalid {
        /// The input file.
        path: PathBuf,
        /// What is impossible.
        problem: String,
    },
}

fn invalid(path: &Path, problem: impl std::fmt::Display) -> AnyMotionError {
    AnyMotionError::Invalid {
        path: path.to_path_buf(),
        problem: problem.to_string(),
    }
}

/// A motion read from any file.
#[derive(Debug, Clone)]
pub enum AnyMotion {
    /// Exp-map frames on a built-in skeleton.
    ExpMap(Motion),
    /// Exp-map frames of a width no built-in skeleton has (copy only).
    Unknown {
        /// `frames x columns`.
        frames: Array2<f64>,
        /// The rate it was read at.
        fps: f64,
    },
    /// A BVH file.
    Bvh(Bvh),
}

/// Reads `path` (format by extension); exp-map files are taken to be at `input_fps`.
/// Rates outside [`crate::motion::check_fps`] (a BVH's `Frame Time`, or `input_fps` for the
/// others) are refused.
pub fn read_any(path: &Path, input_fps: f64) -> Result<AnyMotion, AnyMotionError> {
    let format = FileFormat::from_path(path)?;
    if format != FileFormat::Bvh {
        check_fps(input_fps).map_err(|p| invalid(path, format!("read at {p}")))?;
    }
    let frames = match format {
        FileFormat::Bvh => {
            let bvh = read_bvh(path)?;
            check_frame_time(bvh.frame_time).map_err(|p| invalid(path, p))?;
            return Ok(AnyMotion::Bvh(bvh));
        }
        FileFormat::ExpMapText => read_expmap_text(path)?,
        FileFormat::Npy => read_npy_frames(path)?,
    };
    if expmap_layout_for_width(frames.ncols()).is_none() {
        return Ok(AnyMotion::Unknown {
            frames,
            fps: input_fps,
        });
    }
    let motion = Motion::expmap_of_width(frames, input_fps)
        .expect("a built-in width")
        .map_err(|e| invalid(path, format!("cannot be read as a motion: {e}")))?;
    Ok(AnyMotion::ExpMap(motion))
}

/// `loaded` at `target` fps: a whole ratio k keeps every k-th frame (0, k, 2k, ...; for H3.6M the
/// protocol's downsampling, root deltas untouched); any other ratio resamples by slerp in BVH
/// space ([`crate::resample::resample_bvh`]). Returns the result and how it was done.
pub fn resample_any(
    loaded: AnyMotion,
    target: f64,
    input: &Path,
) -> Result<(AnyMotion, String), AnyMotionError> {
    let source_fps = match &loaded {
        AnyMotion::ExpMap(motion) => motion.fps(),
        AnyMotion::Unknown { fps, .. } => *fps,
        AnyMotion::Bvh(bvh) => bvh.fps(),
    };
    let ratio = source_fps / target;
    let k = ratio.round();
    // BVH frame times are rounded in files (0.00833333 for 120 Hz): allow for that.
    if k >= 1.0 && (ratio - k).abs() < 1e-3 * k {
        let k = k as usize;
        let keep = |frames: &Array2<f64>| frames.slice(s![..;k, ..]).to_owned();
        let resampled = match loaded {
            AnyMotion::ExpMap(motion) => {
                let frames = keep(&motion.frames().to_owned());
                AnyMotion::ExpMap(Motion::new(
                    motion.skeleton().clone(),
                    motion.layout(),
                    frames,
                    target,
                )?)
            }
            AnyMotion::Unknown { frames, .. } => AnyMotion::Unknown {
                frames: keep(&frames),
                fps: target,
            },
            AnyMotion::Bvh(bvh) => AnyMotion::Bvh(Bvh {
                frames: keep(&bvh.frames),
                frame_time: bvh.frame_time * k as f64,
                skeleton: bvh.skeleton,
            }),
        };
        return Ok((resampled, format!("keeping 1 frame in {k}")));
    }
    let bvh = match loaded {
        AnyMotion::Bvh(bvh) => bvh,
        AnyMotion::ExpMap(motion) => expmap_to_bvh(&motion).map_err(|e| invalid(input, e))?,
        AnyMotion::Unknown { frames, .. } => {
            return Err(invalid(
                input,
                format!(
                    "{} columns fit no built-in skeleton, so only whole-ratio resampling (keeping every k-th frame) is possible, not {source_fps} fps to {target} fps",
                    frames.ncols()
                ),
            ))
        }
    };
    Ok((
        AnyMotion::Bvh(resample_bvh(&bvh, target).map_err(|e| invalid(input, e))?),
        "interpolating (rotations by slerp, positions linearly)".into(),
    ))
}

/// Writes the channels of `loaded` (BVH, exp-map text or `.npy`); returns the written shape
/// (BVH: frames x channels).
pub fn write_channels(
    loaded: AnyMotion,
    input: &Path,
    output: &Path,
    out_format: FileFormat,
    notices: &mut Vec<String>,
) -> Result<Vec<usize>, AnyMotionError> {
    match out_format {
        FileFormat::Bvh => {
            let bvh = match loaded {
                AnyMotion::Bvh(bvh) => bvh,
                AnyMotion::ExpMap(motion) => {
                    expmap_to_bvh(&motion).map_err(|e| invalid(input, e))?
                }
                AnyMotion::Unknown { frames, .. } => {
                    return Err(no_skeleton(input, frames.ncols()))
                }
            };
            write_bvh(output, &bvh)?;
            Ok(bvh.frames.shape().to_vec())
        }
        FileFormat::ExpMapText | FileFormat::Npy => {
            let frames = match loaded {
                AnyMotion::ExpMap(motion) => motion.into_frames(),
                AnyMotion::Unknown { frames, .. } => frames,
                AnyMotion::Bvh(bvh) => {
                    let bad = |e: crate::formats::expmap_bvh::ConvertError| invalid(input, e);
                    let target = ExpMapTarget::detect(&bvh).map_err(bad)?;
                    let difference = offset_difference(&bvh, target);
                    if difference > 1e-6 {
                        notices.push(format!(
                            "warning: {}: joint offsets differ from the built-in {} skeleton by up to {difference}; exp-map frames keep only rotations and the root motion (in the BVH's units)",
                            input.display(),
                            target.name()
                        ));
                    }
                    bvh_to_expmap(&bvh, target).map_err(bad)?.into_frames()
                }
            };
            if out_format == FileFormat::Npy {
                write_npy(output, &frames)?;
            } else {
                write_expmap_text(output, frames.view())?;
            }
            Ok(frames.shape().to_vec())
        }
    }
}

/// Frames, rate and skeleton of a loaded motion, for the report.
pub struct Described {
    /// Frames.
    pub frames: usize,
    /// Frame rate.
    pub fps: f64,
    /// `None` for exp-map columns no built-in skeleton has.
    pub skeleton: Option<String>,
}

impl Described {
    /// Describes `loaded`.
    pub fn of(loaded: &AnyMotion) -> Described {
        match loaded {
            AnyMotion::ExpMap(motion) => Described {
                frames: motion.len(),
                fps: motion.fps(),
                // `load` puts H3.6M (root deltas) and CMU (absolute root) frames on their skeletons.
                skeleton: Some(match motion.layout() {
                    MotionLayout::ExpMap {
                        root: RootEncoding::Deltas,
                    } => format!("H3.6M {}-joint", motion.skeleton().len()),
                    _ => format!("CMU {}-joint", motion.skeleton().len()),
                }),
            },
            AnyMotion::Unknown { frames, fps } => Described {
                frames: frames.nrows(),
                fps: *fps,
                skeleton: None,
            },
            AnyMotion::Bvh(bvh) => Described {
                frames: bvh.frames.nrows(),
                fps: bvh.fps(),
                skeleton: Some(match ExpMapTarget::detect(bvh) {
                    Ok(target) => format!("{} {}-joint", target.name(), target.skeleton().len()),
                    Err(_) => format!("BVH {}-joint", bvh.skeleton.len()),
                }),
            },
        }
    }
}

/// A format's name in reports.
pub fn format_name(format: FileFormat) -> &'static str {
    match format {
        FileFormat::ExpMapText => "exp-map text",
        FileFormat::Bvh => "bvh",
        FileFormat::Npy => "npy",
    }
}

/// World joint positions (`frames x joints x 3`, the file's units) of `loaded`.
/// Positions that are not finite (offsets or translations so large that they overflow) are
/// refused, naming the first frame and joint.
pub fn positions(loaded: &AnyMotion, input: &Path) -> Result<Array3<f64>, AnyMotionError> {
    let positions = match loaded {
        AnyMotion::ExpMap(motion) => motion.positions(),
        AnyMotion::Bvh(bvh) => channel_positions(&bvh.skeleton, bvh.frames.view())
            .map_err(|e| invalid(input, format!("forward kinematics: {e}")))?,
        AnyMotion::Unknown { frames, .. } => return Err(no_skeleton(input, frames.ncols())),
    };
    if let Some(((frame, joint, _), _)) = positions.indexed_iter().find(|(_, v)| !v.is_finite()) {
        return Err(invalid(
            input,
            format!(
                "frame {frame}, joint {joint}: the position is not finite (offsets or translations too large to add up)"
            ),
        ));
    }
    Ok(positions)
}

fn no_skeleton(input: &Path, columns: usize) -> AnyMotionError {
    invalid(
        input,
        format!("{columns} columns per frame fit no built-in skeleton ({H36M_FRAME_DIMS} = H3.6M, {CMU_FRAME_DIMS} = CMU), so there is no skeleton for BVH or positions"),
    )
}

/// The positions of a motion file ([`read_positions`]).
#[derive(Debug, Clone)]
pub struct PositionTrack {
    /// The skeleton the joints are of.
    pub skeleton: Skeleton,
    /// `frames x joints x 3`, the file's units.
    pub positions: Array3<f64>,
    /// Frames per second.
    pub fps: f64,
}

/// World joint positions of a motion file, for drawing: exp-map files (no stored rate) are read
/// at `input_fps`; a 3-D `.npy` is `samples x frames x dims` (sample `sample` is taken) or
/// positions `frames x joints x 3` on the H3.6M (32) or CMU (38) skeleton. Every value finite,
/// at least one frame.
pub fn read_positions(
    path: &Path,
    input_fps: f64,
    sample: usize,
) -> Result<PositionTrack, AnyMotionError> {
    let format = FileFormat::from_path(path)?;
    if format != FileFormat::Bvh {
        check_fps(input_fps).map_err(|p| invalid(path, format!("read at {p}")))?;
    }
    let (skeleton, positions, fps) = match format {
        FileFormat::Bvh => {
            let bvh = read_bvh(path)?;
            check_frame_time(bvh.frame_time).map_err(|p| invalid(path, p))?;
            let positions = channel_positions(&bvh.skeleton, bvh.frames.view())
                .map_err(|e| invalid(path, e))?;
            let fps = bvh.fps();
            (bvh.skeleton, positions, fps)
        }
        FileFormat::ExpMapText => {
            let frames = read_expmap_text(path)?;
            let (skeleton, positions) = frames_positions(path, frames, input_fps)?;
            (skeleton, positions, input_fps)
        }
        FileFormat::Npy => {
            let array = read_npy_dyn(path)?;
            match array.ndim() {
                2 => {
                    let frames = array.into_dimensionality::<Ix2>().expect("2-D");
                    let (skeleton, positions) = frames_positions(path, frames, input_fps)?;
                    (skeleton, positions, input_fps)
                }
                3 => {
                    let array = array.into_dimensionality::<Ix3>().expect("3-D");
                    let (a, _, c) = array.dim();
                    if c == 3 {
                        let skeleton = match array.dim().1 {
                            32 => Skeleton::h36m(),
                            38 => Skeleton::cmu(),
                            j => {
                                return Err(invalid(
                                    path,
                                    format!("positions of {j} joints fit no built-in skeleton (32 = H3.6M, 38 = CMU)"),
                                ))
                            }
                        };
                        (skeleton, array, input_fps)
                    } else {
                        if sample >= a {
                            return Err(invalid(
                                path,
                                format!(
                                    "--sample {sample} is out of range: the file has {a} samples"
                                ),
                            ));
                        }
                        let frames = array.index_axis(ndarray::Axis(0), sample).to_owned();
                        let (skeleton, positions) = frames_positions(path, frames, input_fps)?;
                        (skeleton, positions, input_fps)
                    }
                }
                _ => {
                    return Err(invalid(
                        path,
                        format!(
                            "expected a 2-D or 3-D array, found shape {:?}",
                            array.shape()
                        ),
                    ))
                }
            }
        }
    };
    if positions.dim().0 == 0 {
        return Err(invalid(path, "no frames"));
    }
    if positions.iter().any(|v| !v.is_finite()) {
        return Err(invalid(path, "has NaN or infinite values"));
    }
    Ok(PositionTrack {
        skeleton,
        positions,
        fps,
    })
}

/// World positions of exp-map frames on the skeleton their width names.
fn frames_positions(
    path: &Path,
    frames: Array2<f64>,
    fps: f64,
) -> Result<(Skeleton, Array3<f64>), AnyMotionError> {
    if let Some(t) = frames
        .rows()
        .into_iter()
        .position(|r| r.iter().any(|v| !v.is_finite()))
    {
        return Err(invalid(
            path,
            format!("frame {t} has a NaN or infinite value"),
        ));
    }
    let width = frames.ncols();
    let motion = Motion::expmap_of_width(frames, fps)
        .ok_or_else(|| {
            invalid(
                path,
                format!("{width} values per frame fit no built-in skeleton ({H36M_FRAME_DIMS} = H3.6M, {CMU_FRAME_DIMS} = CMU)"),
            )
        })?
        .map_err(|e| invalid(path, e))?;
    let skeleton = (**motion.skeleton()).clone();
    Ok((skeleton, motion.positions()))
}

/// A BVH continuation as exp-map frames whose root deltas continue from `seed` (a BVH on the same
/// skeleton at the same rate): H3.6M frames store each frame's root motion relative to the
/// previous frame, so the first frame of a continuation read on its own would start from the
/// origin (its delta the whole world offset: a jump of the hips by their height). Read together,
/// the continuation's first delta is taken from the seed's last pose, as `predict` meant it.
/// Checks as [`read_array`]; returns `T x D`.
pub fn read_bvh_continuation(seed: &Path, motion: &Path) -> Result<ArrayD<f64>, AnyMotionError> {
    let (seed_bvh, motion_bvh) = (read_bvh(seed)?, read_bvh(motion)?);
    if seed_bvh.skeleton.channel_count() != motion_bvh.skeleton.channel_count()
        || seed_bvh
            .skeleton
            .joints()
            .iter()
            .zip(motion_bvh.skeleton.joints())
            .any(|(a, b)| a.name != b.name || a.channels != b.channels)
    {
        return Err(invalid(
            motion,
            format!(
                "its hierarchy differs from its seed's ({}): a continuation is on the seed's skeleton",
                seed.display()
            ),
        ));
    }
    if (seed_bvh.frame_time - motion_bvh.frame_time).abs() > 1e-9 * seed_bvh.frame_time.abs() {
        return Err(invalid(
            motion,
            format!(
                "Frame Time {} differs from its seed's {} ({})",
                motion_bvh.frame_time,
                seed_bvh.frame_time,
                seed.display()
            ),
        ));
    }
    let seed_frames = seed_bvh.frames.nrows();
    let joined = Bvh {
        skeleton: motion_bvh.skeleton,
        frames: ndarray::concatenate(
            ndarray::Axis(0),
            &[seed_bvh.frames.view(), motion_bvh.frames.view()],
        )
        .map_err(|e| invalid(motion, e))?,
        frame_time: motion_bvh.frame_time,
    };
    let target = ExpMapTarget::detect(&joined).map_err(|e| {
        invalid(
            motion,
            format!("{e} (scoring reads H3.6M or CMU skeletons)"),
        )
    })?;
    let frames = bvh_to_expmap(&joined, target)
        .map_err(|e| invalid(motion, e))?
        .frames()
        .slice(s![seed_frames.., ..])
        .to_owned();
    if frames.is_empty() {
        return Err(invalid(motion, "empty input (no frames)"));
    }
    Ok(frames.into_dyn())
}

/// One file as an array, for scoring: `.npy` as stored (any rank), exp-map text and BVH (H3.6M
/// or CMU skeleton) as `T x D` exp-map frames (`downsample_text`: keep the even frames of text
/// files, the protocol's 50 -> 25 Hz). Not empty; every value finite (the error gives the index).
pub fn read_array(path: &Path, downsample_text: bool) -> Result<ArrayD<f64>, AnyMotionError> {
    let array = match FileFormat::from_path(path)? {
        FileFormat::Npy => read_npy_dyn(path)?,
        FileFormat::ExpMapText => {
            let frames = read_expmap_text(path)?;
            let frames = if downsample_text {
                downsample_protocol(frames.view())
            } else {
                frames
            };
            frames.into_dyn()
        }
        FileFormat::Bvh => {
            let bvh = read_bvh(path)?;
            let target = ExpMapTarget::detect(&bvh).map_err(|e| {
                invalid(path, format!("{e} (scoring reads H3.6M or CMU skeletons)"))
            })?;
            let motion = bvh_to_expmap(&bvh, target).map_err(|e| invalid(path, e))?;
            motion.frames().to_owned().into_dyn()
        }
    };
    if array.is_empty() {
        return Err(invalid(
            path,
            format!("empty input (shape {:?})", array.shape()),
        ));
    }
    if let Some(flat) = array.iter().position(|v| !v.is_finite()) {
        let mut index = vec![0; array.ndim()];
        let mut rest = flat;
        for (slot, &len) in index.iter_mut().zip(array.shape()).rev() {
            *slot = rest % len;
            rest /= len;
        }
        return Err(invalid(
            path,
            format!("non-finite value (NaN or infinity) at index {index:?}"),
        ));
    }
    Ok(array)
}
