//! The metrics of `score` over the loaded inputs, as a typed [`ScoreReport`]: every number comes
//! from `motion_metrics`; this module checks shapes, arranges the arrays and names errors.
use std::path::{Path, PathBuf};

use anyhow::Result;
use ndarray::{concatenate, s, Array2, Array3, Array4, ArrayView2, ArrayView3, Axis};

use motion_core::formats::bvh::read_bvh;
use motion_core::motion::Motion;
use motion_core::protocol::expmap_batch_to_euler_protocol;
use motion_core::skeleton::{H36M_FRAME_DIMS, H36M_JOINT_COUNT, H36M_PROTOCOL_FPS as PROTOCOL_FPS};
use motion_metrics::ndms::{NdmsConfig, NdmsDatabase, NnMethod, WordFrame};
use motion_metrics::npss::{Npss, SpectrumPower, NPSS_WINDOWS_25HZ};
use motion_metrics::{apd_batch, euler_error, euler_error_at_horizons, MetricError};

use super::load::{self, Batch, Inputs};
use super::report::{NdmsSummary, NpssWindows, ScoreReport};
use super::{metric_error, usage, Args, InputSpace, Metric, NnChoice};

/// Scores `metrics` (each available for `inputs`, checked by the caller) into one report.
pub fn compute(
    args: &Args,
    metrics: &[Metric],
    action: Option<&'static str>,
    inputs: &Inputs,
) -> Result<ScoreReport> {
    let Inputs {
        space,
        pred,
        gt,
        seed,
    } = inputs;
    let (sequences, samples, frames, _) = pred.data.dim();
    let mut report = ScoreReport {
        action: None,
        apd: None,
        apd_per_sequence: None,
        classifier: None,
        drift: None,
        euler_error: None,
        euler_error_ms: None,
        foot_contact: None,
        frames,
        posture: None,
        input_space: *space,
        mpjpe: None,
        multimodal: None,
        ndms: None,
        npss: None,
        npss_reference: None,
        npss_windows: None,
        samples,
        sequences,
        speed_ratio: None,
        plausibility: None,
    };
    if let Some(gt) = gt {
        if metrics.contains(&Metric::Mpjpe) {
            report.mpjpe = Some(mpjpe_of(gt, pred, *space)?);
        }
        if metrics.contains(&Metric::Multimodal) {
            let seed = seed.as_ref().expect("checked by the caller");
            report.multimodal = Some(multimodal_of(
                gt,
                pred,
                seed,
                *space,
                args.multimodal_threshold,
            )?);
        }
        if metrics
            .iter()
            .any(|m| matches!(m, Metric::Npss | Metric::NpssReference | Metric::Euler))
        {
            score_against_ground_truth(metrics, gt, pred, *space, &mut report)?;
        }
    }
    if metrics.contains(&Metric::Ndms) {
        let method = match args.nn {
            NnChoice::BruteForce => NnMethod::BruteForce,
            NnChoice::PcaKdTree => NnMethod::PcaKdTree,
            NnChoice::PoseBound => NnMethod::PoseBound,
        };
        if *space == InputSpace::Raw && pred.joints.is_none() {
            return Err(usage(format!(
                "NDMS in the raw space needs positions (N x T x J x 3); {} has {} numbers per frame (exp-map frames are read without --input-space raw)",
                pred.what,
                pred.data.dim().3
            )));
        }
        report.ndms = Some(score_ndms(
            &args.db,
            pred,
            seed.as_ref(),
            method,
            args.skeleton.as_deref(),
        )?);
    }
    if metrics.contains(&Metric::Apd) {
        let positions = sample_positions(pred, *space)?;
        let (n, s, t, w) = positions.dim();
        let flat = positions
            .into_shape_with_order((n, s, t * w))
            .expect("contiguous");
        let (per, mean) = apd_batch(flat.view()).map_err(|e| metric_error("APD", e))?;
        report.apd = Some(mean);
        report.apd_per_sequence = Some(per);
    }
    if metrics.contains(&Metric::Classifier) {
        let action = action.expect("checked by the caller");
        let classifier = crate::model_source::load_classifier(args.classifier.as_deref())?;
        let curve = score_classifier(&classifier, action, pred, seed.as_ref())?;
        report.action = Some(action.to_string());
        report.classifier = Some(curve);
    }
    if metrics.contains(&Metric::Posture) {
        let action = action.expect("checked by the caller");
        let dataset = motion_metrics::evaluation::resolve_dataset(args.data.as_deref())
            .map_err(|e| super::super::UsageError(e.to_string()))?;
        report.action = Some(action.to_string());
        report.posture = Some(score_posture(&dataset, action, pred, seed.as_ref())?);
    }
    if metrics.iter().any(|m| m.is_plausibility()) {
        let (action, seed) = (
            action.expect("checked by the caller"),
            seed.as_ref().expect("checked by the caller"),
        );
        let dataset = motion_metrics::evaluation::resolve_dataset(args.data.as_deref())
            .map_err(|e| super::super::UsageError(e.to_string()))?;
        let plausibility = score_plausibility(&dataset, action, pred, seed)?;
        report.action = Some(action.to_string());
        if metrics.contains(&Metric::SpeedRatio) {
            report.speed_ratio = Some(plausibility.speed_ratio.clone());
        }
        if metrics.contains(&Metric::Drift) {
            report.drift = Some(plausibility.drift.clone());
        }
        if metrics.contains(&Metric::FootContact) {
            report.foot_contact = Some(plausibility.foot_contact.clone());
        }
        report.plausibility = Some(plausibility);
    }
    Ok(report)
}

/// `--seed` holds one sequence (no samples) per `--pred` sequence (`n`).
fn check_one_seed_each(seed: &Batch, n: usize) -> Result<()> {
    if seed.data.dim().0 != n || seed.has_samples {
        return Err(usage(format!(
            "--seed {} must hold one sequence per --pred sequence ({n}); found shape {:?}",
            seed.what,
            seed.data.shape()
        )));
    }
    Ok(())
}

// ---------- NPSS and Euler error ----------

/// `(N·S x T x D predictions, N·S x T x D' ground truth)`: every sample beside its sequence's
/// ground truth (repeated for each sample).
fn every_sample_with_its_truth(pred: &Batch, gt: &Batch) -> (Array3<f64>, Array3<f64>) {
    let (n, s, t, w) = pred.data.dim();
    let pred_flat = pred
        .data
        .to_shape((n * s, t, w))
        .expect("contiguous")
        .into_owned();
    let gt_seq = gt.data.index_axis(Axis(1), 0);
    let gw = gt_seq.dim().2;
    let gt_flat = Array3::from_shape_fn((n * s, t, gw), |(i, f, d)| gt_seq[[i / s, f, d]]);
    (pred_flat, gt_flat)
}

/// The multi-sample metrics of `N x K x T x D` samples against `N x T x D` futures, each window's
/// last observed pose the last frame of its seed.
fn multimodal_of(
    gt: &Batch,
    pred: &Batch,
    seed: &Batch,
    space: InputSpace,
    threshold: f64,
) -> Result<motion_metrics::multimodal::SampleSetScores> {
    use motion_metrics::multimodal::{score_sample_sets, SampleSets};
    if space != InputSpace::Raw {
        return Err(usage(format!(
            "multimodal: {} holds exp-map frames; the multi-sample metrics are distances between pose vectors: give positions with --input-space raw",
            pred.what
        )));
    }
    let (n, _, t, d) = pred.data.dim();
    let (gn, _, gt_frames, gd) = gt.data.dim();
    let (sn, _, seed_frames, sd) = seed.data.dim();
    if (gn, gt_frames, gd) != (n, t, d) || (sn, sd) != (n, d) {
        return Err(usage(format!(
            "shape mismatch: --pred {} is {n} windows x {t} frames x {d}, --gt {} {gn} x {gt_frames} x {gd}, --seed {} {sn} x {seed_frames} x {sd}",
            pred.what, gt.what, seed.what
        )));
    }
    let last = seed.data.slice(s![.., 0, seed_frames - 1, ..]);
    let report = score_sample_sets(SampleSets {
        samples: pred.data.view(),
        truth: gt.data.index_axis(Axis(1), 0),
        last_observed: last,
        threshold,
    })
    .map_err(|e| {
        metric_error(
            &format!(
                "multimodal metrics of --pred {} against --gt {}",
                pred.what, gt.what
            ),
            e,
        )
    })?;
    Ok(report.mean)
}

/// MPJPE of every sample against its sequence's ground truth (a prediction of the 22 predicted
/// H3.6M joints is completed from 32-joint truth).
fn mpjpe_of(
    gt: &Batch,
    pred: &Batch,
    space: InputSpace,
) -> Result<motion_metrics::mpjpe::MpjpeScores> {
    use motion_metrics::mpjpe::{score_mpjpe, MpjpeInput};
    let (n, _, t, _) = pred.data.dim();
    let (gn, _, gt_frames, _) = gt.data.dim();
    if (n, t) != (gn, gt_frames) {
        return Err(usage(format!(
            "shape mismatch: --pred {} has {n} sequences x {t} frames but --gt {} has {gn} x {gt_frames}",
            pred.what, gt.what
        )));
    }
    let (pred_flat, gt_flat) = every_sample_with_its_truth(pred, gt);
    let input = match space {
        InputSpace::Expmap => MpjpeInput::Expmap,
        InputSpace::Raw => MpjpeInput::Positions,
    };
    score_mpjpe(
        pred_flat.view().into_dyn(),
        gt_flat.view().into_dyn(),
        input,
        motion_metrics::JointMean::All32,
    )
    .map_err(|e| {
        metric_error(
            &format!("MPJPE of --pred {} against --gt {}", pred.what, gt.what),
            e,
        )
    })
}

/// NPSS (whole and per window) and the Euler error of every sample against its sequence's
/// ground truth, into `report`.
fn score_against_ground_truth(
    metrics: &[Metric],
    gt: &Batch,
    pred: &Batch,
    space: InputSpace,
    report: &mut ScoreReport,
) -> Result<()> {
    let (n, _, t, w) = pred.data.dim();
    let (gn, _, gt_frames, gw) = gt.data.dim();
    if (n, t, w) != (gn, gt_frames, gw) {
        return Err(usage(format!(
            "shape mismatch: --pred {} has {n} sequences x {t} frames x {w} dims but --gt {} has {gn} x {gt_frames} x {gw}",
            pred.what, gt.what
        )));
    }
    let (pred_flat, gt_flat) = every_sample_with_its_truth(pred, gt);
    let (gt_e, pred_e) = if space == InputSpace::Expmap {
        (
            expmap_batch_to_euler_protocol(gt_flat.view()),
            expmap_batch_to_euler_protocol(pred_flat.view()),
        )
    } else {
        (gt_flat, pred_flat)
    };
    // Errors name both files: a value the conversion cannot take (an exp map of 1e300) is in
    // one of them.
    let what = |metric: &str| format!("{metric} of --pred {} against --gt {}", pred.what, gt.what);
    let mut npss = Npss::new();
    let mut windows = NpssWindows::default();
    for (metric, power) in [
        (Metric::Npss, SpectrumPower::Modulus),
        (Metric::NpssReference, SpectrumPower::RealPart),
    ] {
        if !metrics.contains(&metric) {
            continue;
        }
        let value = npss
            .score(gt_e.view(), pred_e.view(), power)
            .map_err(|e| metric_error(&what("NPSS"), e))?;
        let per_window = npss
            .score_windows(gt_e.view(), pred_e.view(), power, &NPSS_WINDOWS_25HZ)
            .map_err(|e| metric_error(&what("NPSS"), e))?
            .iter()
            .map(|w| (w.window.label.to_string(), w.value))
            .collect();
        if metric == Metric::Npss {
            report.npss = Some(value);
            windows.npss = Some(per_window);
        } else {
            report.npss_reference = Some(value);
            windows.npss_reference = Some(per_window);
        }
    }
    if windows.npss.is_some() || windows.npss_reference.is_some() {
        report.npss_windows = Some(windows);
    }
    if metrics.contains(&Metric::Euler) {
        let per_frame = euler_error(gt_e.view(), pred_e.view())
            .map_err(|e| metric_error(&what("Euler error"), e))?;
        report.euler_error_ms = Some(
            euler_error_at_horizons(&per_frame)
                .iter()
                .map(|(ms, v)| (ms.to_string(), *v))
                .collect(),
        );
        report.euler_error = Some(per_frame);
    }
    Ok(())
}

// ---------- positions (NDMS, APD) ----------

/// `T x J x 3` positions of one `T x W` sequence (FK of exp-map frames, or raw positions).
fn sequence_positions(
    frames: ArrayView2<'_, f64>,
    joints: Option<usize>,
    what: &str,
) -> Result<Array3<f64>> {
    match joints {
        Some(j) => Ok(frames
            .to_owned()
            .into_shape_with_order((frames.nrows(), j, 3))
            .expect("width = J·3")),
        // Exp-map frames at the protocol's 25 Hz, on the skeleton their width names.
        None => Motion::expmap_of_width(frames.to_owned(), PROTOCOL_FPS)
            .ok_or_else(|| {
                usage(format!(
                    "{what}: no built-in skeleton has {}-dim exp-map frames (99 = H3.6M, 117 = CMU); give positions with --input-space raw",
                    frames.ncols()
                ))
            })?
            .map(|motion| motion.positions())
            .map_err(|e| usage(format!("{what}: {e}"))),
    }
}

/// Positions of every sample: `N x S x T x (J·3)`.
fn sample_positions(batch: &Batch, space: InputSpace) -> Result<Array4<f64>> {
    if space == InputSpace::Raw {
        return Ok(batch.data.clone());
    }
    let (n, s, t, _) = batch.data.dim();
    let mut out: Option<Array4<f64>> = None;
    for i in 0..n {
        for k in 0..s {
            let p = sequence_positions(batch.data.slice(s![i, k, .., ..]), None, &batch.what)?;
            let width = p.dim().1 * 3;
            let target = out.get_or_insert_with(|| Array4::zeros((n, s, t, width)));
            target
                .slice_mut(s![i, k, .., ..])
                .assign(&p.into_shape_with_order((t, width)).expect("contiguous"));
        }
    }
    Ok(out.expect("at least one sample"))
}

/// The NDMS configuration for the predictions' joints.
///
/// FK of integrated root deltas lives in the tilted pelvis frame of wherever integration started
/// (the file for --db, the seed for a forecast): only a rigid per-word frame makes the same motion
/// give the same word. Raw positions are taken as gravity-aligned (metrics.md's recipe).
fn ndms_config(pred: &Batch, skeleton: Option<&Path>) -> Result<NdmsConfig> {
    match (pred.joints, skeleton) {
        (None, _) if pred.data.dim().3 == H36M_FRAME_DIMS => Ok(NdmsConfig::h36m_body_frame()),
        (Some(H36M_JOINT_COUNT), None) => Ok(NdmsConfig::h36m()),
        (Some(joints), Some(path)) => {
            let named = read_bvh(path)?.skeleton;
            if named.len() != joints {
                return Err(usage(format!(
                    "{}: {} joints but the positions of {} have {joints}",
                    path.display(),
                    named.len(),
                    pred.what
                )));
            }
            NdmsConfig::h36m_by_name(&named).map_err(|name| {
                usage(format!(
                    "{}: no joint named {name:?} (an NDMS joint)",
                    path.display()
                ))
            })
        }
        _ => Err(usage(format!(
            "NDMS: {} is not on the 32-joint H3.6M skeleton (99-dim exp-map or 32 x 3 positions); \
             name the joints of raw positions with --skeleton FILE.bvh",
            pred.what
        ))),
    }
}

/// NDMS of every prediction sample against the words of `db_paths` (after its sequence's seed,
/// when given).
fn score_ndms(
    db_paths: &[PathBuf],
    pred: &Batch,
    seed: Option<&Batch>,
    method: NnMethod,
    skeleton: Option<&Path>,
) -> Result<NdmsSummary> {
    let config = ndms_config(pred, skeleton)?;
    let mut references = Vec::new();
    for batch in load::database(db_paths)? {
        for sequence in batch.data.index_axis(Axis(1), 0).outer_iter() {
            references.push(sequence_positions(sequence, batch.joints, &batch.what)?);
        }
    }
    let views: Vec<ArrayView3<'_, f64>> = references.iter().map(|r| r.view()).collect();
    let database = NdmsDatabase::from_sequences(config.clone(), &views, method)
        .map_err(|e| metric_error("NDMS database (--db)", e))?;

    let (n, s, t, _) = pred.data.dim();
    let prefix = config.kappa - 1;
    if let Some(seed) = seed {
        if seed.data.dim().0 != n
            || seed.has_samples
            || seed.joints != pred.joints
            || seed.data.dim().3 != pred.data.dim().3
        {
            return Err(usage(format!(
                "--seed {} must hold one sequence per --pred sequence ({n}) with the same frame width; found shape {:?}",
                seed.what,
                seed.data.shape()
            )));
        }
        if seed.data.dim().2 < prefix {
            return Err(usage(format!(
                "--seed {}: {} frames, NDMS needs the last κ-1 = {prefix}",
                seed.what,
                seed.data.dim().2
            )));
        }
    } else if t < config.kappa {
        return Err(metric_error(
            "NDMS",
            MetricError::TooShort {
                what: format!("--pred {}", pred.what),
                frames: t,
                kappa: config.kappa,
            },
        ));
    }
    // FK of seed + forecast together keeps the integrated root continuous across the seam.
    let mut forecasts = Vec::with_capacity(n * s);
    let mut seeds = Vec::with_capacity(n * s);
    for i in 0..n {
        for k in 0..s {
            let forecast = pred.data.slice(s![i, k, .., ..]);
            match seed {
                Some(seed) => {
                    let observed = seed.data.slice(s![i, 0, .., ..]);
                    let joined: Array2<f64> =
                        concatenate(Axis(0), &[observed, forecast]).expect("same width");
                    let positions = sequence_positions(joined.view(), pred.joints, &pred.what)?;
                    let split = observed.nrows();
                    seeds.push(
                        positions
                            .slice(s![split - prefix..split, .., ..])
                            .to_owned(),
                    );
                    forecasts.push(positions.slice(s![split.., .., ..]).to_owned());
                }
                None => forecasts.push(sequence_positions(forecast, pred.joints, &pred.what)?),
            }
        }
    }
    let forecast_views: Vec<_> = forecasts.iter().map(|f| f.view()).collect();
    let seed_views: Vec<_> = seeds.iter().map(|f| f.view()).collect();
    let report = database
        .score_forecasts(&forecast_views, seed.map(|_| seed_views.as_slice()))
        .map_err(|e| metric_error("NDMS", e))?;
    Ok(NdmsSummary {
        bins: report.bins,
        database_words: database.len(),
        exact: report.exact,
        first_word_end: report.first_word_end,
        mean: report.mean,
        nearest_neighbour: match method {
            NnMethod::BruteForce => "brute-force",
            NnMethod::PcaKdTree => "pca-kd-tree",
            NnMethod::PoseBound => "pose-bound",
        },
        per_word: report.per_word,
        word_frame: match config.frame {
            WordFrame::Heading => "heading (metrics.md recipe)",
            WordFrame::Body { .. } => "body (rigid, first frame's hips and shoulders)",
        },
    })
}

/// The classifier curve of every prediction sample (after its sequence's seed, when given).
fn score_classifier(
    classifier: &motion_core::model::ActionClassifier,
    action: &str,
    pred: &Batch,
    seed: Option<&Batch>,
) -> Result<motion_metrics::ClassifierCurve> {
    let frame_dims = classifier.config().frame_dims;
    for batch in std::iter::once(pred).chain(seed) {
        if batch.joints.is_some() || batch.data.dim().3 != frame_dims {
            return Err(usage(format!(
                "the action classifier reads H3.6M exp-map frames ({frame_dims} dims, {} Hz); {} has shape {:?}",
                classifier.config().fps,
                batch.what,
                batch.data.shape()
            )));
        }
    }
    let (n, samples, t, d) = pred.data.dim();
    if let Some(seed) = seed {
        check_one_seed_each(seed, n)?;
    }
    let flat = pred
        .data
        .view()
        .into_shape_with_order((n * samples, t, d))
        .map_err(|e| usage(format!("{}: {e}", pred.what)))?;
    let seeds = seed.map(|seed| {
        let frames = seed.data.dim().2;
        ndarray::Array3::from_shape_fn((n * samples, frames, d), |(i, f, k)| {
            seed.data[[i / samples, 0, f, k]]
        })
    });
    super::super::classifier::curve(
        classifier,
        seeds.as_ref().map(|s| s.view()),
        flat,
        action,
        &pred.what,
    )
}

// ---------- plausibility (speed_ratio, drift, foot_contact) ----------

/// The plausibility report of every prediction sample after its sequence's seed.
fn score_plausibility(
    dataset: &Path,
    action: &str,
    pred: &Batch,
    seed: &Batch,
) -> Result<motion_metrics::PlausibilityReport> {
    for batch in [pred, seed] {
        if batch.joints.is_some() || batch.data.dim().3 != H36M_FRAME_DIMS {
            return Err(usage(format!(
                "speed_ratio, drift and foot_contact read H3.6M exp-map frames (99 dims, 25 Hz); {} has shape {:?}",
                batch.what,
                batch.data.shape()
            )));
        }
    }
    let (n, s, t, _) = pred.data.dim();
    check_one_seed_each(seed, n)?;
    let reference = super::super::plausibility::reference(dataset, action)?;
    let pairs: Vec<_> = (0..n)
        .flat_map(|i| {
            (0..s).map(move |k| {
                (
                    seed.data.slice(s![i, 0, .., ..]),
                    pred.data.slice(s![i, k, .., ..]),
                )
            })
        })
        .collect();
    let measures = super::super::plausibility::measure(&pairs, &pred.what)?;
    Ok(super::super::plausibility::report(&measures, t, &reference))
}

// ---------- posture realism ----------

/// Posture realism of every prediction sample after its sequence's seed (when given).
fn score_posture(
    dataset: &Path,
    action: &str,
    pred: &Batch,
    seed: Option<&Batch>,
) -> Result<motion_metrics::evaluation::posture::PostureScore> {
    for batch in std::iter::once(pred).chain(seed) {
        if batch.joints.is_some() || batch.data.dim().3 != H36M_FRAME_DIMS {
            return Err(usage(format!(
                "posture reads H3.6M exp-map frames (99 dims, 25 Hz); {} has shape {:?}",
                batch.what,
                batch.data.shape()
            )));
        }
    }
    let (n, s, _, _) = pred.data.dim();
    if let Some(seed) = seed {
        check_one_seed_each(seed, n)?;
    }
    let clips: Vec<(ndarray::Array2<f64>, usize)> = (0..n)
        .flat_map(|i| (0..s).map(move |k| (i, k)))
        .map(|(i, k)| {
            let motion = pred.data.slice(s![i, k, .., ..]);
            match seed {
                Some(seed) => {
                    let seed = seed.data.slice(s![i, 0, .., ..]);
                    (
                        ndarray::concatenate(ndarray::Axis(0), &[seed, motion])
                            .expect("same width"),
                        seed.nrows(),
                    )
                }
                None => (motion.to_owned(), 0),
            }
        })
        .collect();
    let views: Vec<_> = clips.iter().map(|(c, n)| (None, c.view(), *n)).collect();
    motion_metrics::evaluation::posture::score_posture(dataset, action, &views)
        .map_err(|e| usage(format!("posture: {e}")))
}
