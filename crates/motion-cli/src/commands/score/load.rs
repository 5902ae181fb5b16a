//! Reading the inputs of `score` and classifying them by rank and input space into
//! `sequences x samples x frames x width`.
use std::path::{Path, PathBuf};

use anyhow::Result;
use ndarray::{concatenate, Array4, ArrayD, Axis, Ix2, Ix3, Ix4, Ix5};

use motion_core::any_format::{read_array, read_bvh_continuation};
use motion_core::file_sets::{check_paired_by_name, expand};
use motion_core::formats::FileFormat;
use motion_core::motion::expmap_layout_for_width;

use super::{usage, Args, InputSpace};

/// Loaded data: `sequences x samples x frames x width`; `joints` is set for positions
/// (width = joints · 3).
#[derive(Debug, Clone)]
pub struct Batch {
    /// `sequences x samples x frames x width`.
    pub data: Array4<f64>,
    /// The input held samples (`N x S x T x D`).
    pub has_samples: bool,
    /// Joints of raw positions (`None` for frames of numbers, e.g. exp-map).
    pub joints: Option<usize>,
    /// The file (or flag) it was read from, for messages.
    pub what: String,
}

/// The inputs of one `score` run, classified.
pub struct Inputs {
    /// How the numbers are read.
    pub space: InputSpace,
    /// `--pred`.
    pub pred: Batch,
    /// `--gt`.
    pub gt: Option<Batch>,
    /// `--seed`.
    pub seed: Option<Batch>,
}

/// Reads `--pred`, `--gt` and `--seed` (paired by file name) in the input space of `--input-space`
/// or, by default, of the predictions' width.
pub fn inputs(args: &Args) -> Result<Inputs> {
    use anyhow::Context;
    check_paired_by_name(&args.pred, &args.gt).context("--pred and --gt")?;
    check_paired_by_name(&args.pred, &args.seed).context("--pred and --seed")?;
    let mut pred_raw = load_predictions(&args.pred, &args.seed)?;
    let seed_split = match args.seed_frames {
        Some(n) => Some(split_seeds(&mut pred_raw, n)?),
        None => None,
    };
    let space = args.input_space.unwrap_or_else(|| default_space(&pred_raw));
    let pred = classify_group(pred_raw, space, "--pred")?;
    if let Some(path) = &args.skeleton {
        check_skeleton_file(path, &pred)?;
    }
    let gt = if args.gt.is_empty() {
        None
    } else {
        Some(classify_group(
            load_group(&args.gt, "--gt")?,
            space,
            "--gt",
        )?)
    };
    if let Some(gt) = &gt {
        if gt.has_samples {
            return Err(usage(format!(
                "--gt must hold sequences (N x T x D), not samples: {}",
                gt.what
            )));
        }
    }
    let seed = if let Some(seeds) = seed_split {
        Some(classify_group(seeds, space, "--seed-frames")?)
    } else if args.seed.is_empty() {
        None
    } else {
        Some(classify_group(
            load_group(&args.seed, "--seed")?,
            space,
            "--seed",
        )?)
    };
    Ok(Inputs {
        space,
        pred,
        gt,
        seed,
    })
}

/// `--seed-frames n`: the first `n` frames of every `T x D` prediction become its seed (returned),
/// the rest stays the prediction.
fn split_seeds(
    preds: &mut [(PathBuf, ArrayD<f64>)],
    n: usize,
) -> Result<Vec<(PathBuf, ArrayD<f64>)>> {
    if n == 0 {
        return Err(usage("--seed-frames must be at least 1".to_string()));
    }
    preds
        .iter_mut()
        .map(|(path, array)| {
            let frames = match array.view().into_dimensionality::<Ix2>() {
                Ok(frames) => frames,
                Err(_) => {
                    return Err(usage(format!(
                        "{}: --seed-frames splits T x D frames, not shape {:?}",
                        path.display(),
                        array.shape()
                    )))
                }
            };
            if frames.nrows() <= n {
                return Err(usage(format!(
                    "{}: {} frames leave nothing after --seed-frames {n}",
                    path.display(),
                    frames.nrows()
                )));
            }
            let seed = frames.slice(ndarray::s![..n, ..]).to_owned().into_dyn();
            let rest = frames.slice(ndarray::s![n.., ..]).to_owned().into_dyn();
            *array = rest;
            Ok((path.clone(), seed))
        })
        .collect()
}

/// The arrays of `--pred`, as read, except that a BVH prediction paired with a BVH seed is read
/// as the seed's continuation ([`read_bvh_continuation`]: its first root delta from the seed's
/// last pose, not from the origin).
fn load_predictions(paths: &[PathBuf], seeds: &[PathBuf]) -> Result<Vec<(PathBuf, ArrayD<f64>)>> {
    let files = expand(paths)?;
    let seeds = if seeds.is_empty() {
        Vec::new()
    } else {
        expand(seeds)?
    };
    if files.is_empty() {
        return Err(usage("--pred: no files given".to_string()));
    }
    let is_bvh = |p: &Path| matches!(FileFormat::from_path(p), Ok(FileFormat::Bvh));
    files
        .into_iter()
        .enumerate()
        .map(|(k, path)| {
            // Paired by position; one seed for every prediction is that seed's.
            let seed = seeds.get(k).or(if seeds.len() == 1 {
                seeds.first()
            } else {
                None
            });
            let array = match seed {
                Some(seed) if is_bvh(&path) && is_bvh(seed) => read_bvh_continuation(seed, &path)?,
                _ => read_array(&path, false)?,
            };
            Ok((path, array))
        })
        .collect()
}

/// The arrays of every file of a flag, as read.
fn load_group(paths: &[PathBuf], flag: &str) -> Result<Vec<(PathBuf, ArrayD<f64>)>> {
    let files = expand(paths)?;
    if files.is_empty() {
        return Err(usage(format!("{flag}: no files given")));
    }
    files
        .into_iter()
        .map(|path| {
            let array = read_array(&path, false)?;
            Ok((path, array))
        })
        .collect()
}

/// `expmap` when the first array's width names a built-in exp-map layout (99 = H3.6M,
/// 117 = CMU: [`expmap_layout_for_width`]), else `raw`.
fn default_space(group: &[(PathBuf, ArrayD<f64>)]) -> InputSpace {
    let width = group
        .first()
        .map(|(_, a)| *a.shape().last().unwrap_or(&0))
        .unwrap_or(0);
    if expmap_layout_for_width(width).is_some() {
        InputSpace::Expmap
    } else {
        InputSpace::Raw
    }
}

/// The NDMS reference sequences of `--db`, one batch per file. Positions are read by shape
/// (`T x J x 3` / `N x T x J x 3`), anything else as exp-map frames; exp-map text files are the
/// dataset's 50 Hz files, downsampled to the protocol's 25 Hz.
pub fn database(paths: &[PathBuf]) -> Result<Vec<Batch>> {
    let mut batches = Vec::new();
    for path in expand(paths)? {
        let array = read_array(&path, true)?;
        let what = path.display().to_string();
        let batch = if array.shape().last() == Some(&3) && array.ndim() >= 3 {
            let array = if array.ndim() == 3 {
                array.insert_axis(Axis(0))
            } else {
                array
            };
            classify(array, InputSpace::Raw, &what)?
        } else {
            classify(array, InputSpace::Expmap, &what)?
        };
        batches.push(batch);
    }
    Ok(batches)
}

/// Reads one array as `sequences x samples x frames x width` by its rank and the input space:
/// 2: `T x D`; 3: `N x T x D`; 4: positions `N x T x J x 3` (raw, last axis 3) or samples
/// `N x S x T x D`; 5: sample positions `N x S x T x J x 3` (raw).
fn classify(array: ArrayD<f64>, space: InputSpace, what: &str) -> Result<Batch> {
    let shape = array.shape().to_vec();
    let last = *shape.last().unwrap_or(&0);
    let bad = |expected: &str| usage(format!("{what}: shape {shape:?} is not {expected}"));
    let batch = match shape.len() {
        2 => {
            let a = array.into_dimensionality::<Ix2>().expect("rank 2");
            let (t, d) = a.dim();
            Batch { data: a.into_shape_with_order((1, 1, t, d)).expect("contiguous"), has_samples: false, joints: None, what: what.into() }
        }
        3 => {
            let a = array.into_dimensionality::<Ix3>().expect("rank 3").as_standard_layout().into_owned();
            let (n, t, d) = a.dim();
            Batch { data: a.into_shape_with_order((n, 1, t, d)).expect("contiguous"), has_samples: false, joints: None, what: what.into() }
        }
        4 if space == InputSpace::Raw && last == 3 => {
            let a = array.into_dimensionality::<Ix4>().expect("rank 4").as_standard_layout().into_owned();
            let (n, t, j, _) = a.dim();
            Batch { data: a.into_shape_with_order((n, 1, t, j * 3)).expect("contiguous"), has_samples: false, joints: Some(j), what: what.into() }
        }
        4 => {
            let a = array.into_dimensionality::<Ix4>().expect("rank 4").as_standard_layout().into_owned();
            Batch { data: a, has_samples: true, joints: None, what: what.into() }
        }
        5 if space == InputSpace::Raw && last == 3 => {
            let a = array.into_dimensionality::<Ix5>().expect("rank 5").as_standard_layout().into_owned();
            let (n, s, t, j, _) = a.dim();
            Batch { data: a.into_shape_with_order((n, s, t, j * 3)).expect("contiguous"), has_samples: true, joints: Some(j), what: what.into() }
        }
        _ => {
            return Err(bad(
                "T x D, N x T x D, N x S x T x D, or (raw space) positions N x T x J x 3 / N x S x T x J x 3",
            ))
        }
    };
    if space == InputSpace::Expmap && batch.joints.is_none() {
        let d = batch.data.dim().3;
        if d < 6 || d % 3 != 0 {
            return Err(usage(format!("{what}: {d} dims per frame is not an exp-map frame (3 + 3k); use --input-space raw")));
        }
    }
    Ok(batch)
}

/// `--skeleton` names the joints of raw positions: it must be a BVH that reads, and the
/// predictions must be positions (anything else would ignore it silently).
fn check_skeleton_file(path: &Path, pred: &Batch) -> Result<()> {
    if !matches!(FileFormat::from_path(path), Ok(FileFormat::Bvh)) {
        return Err(usage(format!(
            "{}: --skeleton takes a .bvh file (its hierarchy names the joints)",
            path.display()
        )));
    }
    motion_core::formats::bvh::read_bvh(path)?;
    if pred.joints.is_none() {
        return Err(usage(format!(
            "--skeleton names the joints of raw positions (N x T x J x 3), but {} is not positions; leave --skeleton out",
            pred.what
        )));
    }
    Ok(())
}

/// All files of a flag classified and stacked along the sequence axis.
fn classify_group(
    group: Vec<(PathBuf, ArrayD<f64>)>,
    space: InputSpace,
    flag: &str,
) -> Result<Batch> {
    let mut batches = Vec::new();
    for (path, array) in group {
        batches.push(classify(array, space, &path.display().to_string())?);
    }
    let first = batches[0].clone();
    for b in &batches[1..] {
        let (_, s, t, w) = b.data.dim();
        let (_, s0, t0, w0) = first.data.dim();
        if (s, t, w, b.joints) != (s0, t0, w0, first.joints) {
            return Err(usage(format!(
                "{flag}: {} has samples x frames x width {s} x {t} x {w} but {} has {s0} x {t0} x {w0}",
                b.what, first.what
            )));
        }
    }
    let views: Vec<_> = batches.iter().map(|b| b.data.view()).collect();
    let data = concatenate(Axis(0), &views).expect("checked shapes");
    let what = if batches.len() == 1 {
        first.what.clone()
    } else {
        format!("{flag} ({} files)", batches.len())
    };
    Ok(Batch {
        data,
        has_samples: first.has_samples,
        joints: first.joints,
        what,
    })
}
