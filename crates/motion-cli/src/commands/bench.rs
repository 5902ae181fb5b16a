//! `motion-cli bench [--model W | --arch gru-d|vgru-d --hidden 512] [--batch 1,16,256] [--steps N] [--json]`:
//! times closed-loop generation steps (derivative features, recurrent step, decoder,
//! un-normalization) per batch size and reports µs per step, character-steps per second and the
//! peak resident memory of the process.
//!
//! Only steps are timed: seeding happens outside the clock. The VGRU-d plan GRU runs once per plan
//! block, not per frame; by default each timed segment stays inside the plan computed at seeding
//! (like an exported one-step graph that takes the guide as input), `--with-plan` times a long
//! run that re-plans as generation does.
//!
//! The reported time is the median over steps timed one by one (robust to a busy machine); the
//! mean, the 99th percentile and the slowest step are reported too (a re-plan or any other stall
//! shows in `max`). `--repeats R` runs the same steps R times and adds the **steady** slowest
//! step: per step index its fastest run, then the slowest index, i.e. the engine's own worst step
//! with the host's one-off preemptions taken out (a stall of the engine recurs at its step in every
//! run). `--simd avx2,portable` times each SIMD path in turn (the model loaded again
//! under each, see `motion_core::nn::simd`), so every path the machine has can be measured.
//!
//! `--npss GT.npy PRED.npy` times NPSS instead (both spectra, files loaded outside the clock):
//! the median of `--reps` evaluations, for the comparison scripts in `benches/compare/`.
//!
//! `--ndms MANIFEST.json` times NDMS on many (database, forecasts) sets in one process, as a
//! whole evaluation does (e.g. every H3.6M action): the manifest is
//! `{"sets": [{"name": "walking", "pred": "forecasts.npy", "db": ["s5_1.npy", "s5_2.npy"]}]}` with
//! 32-joint H3.6M world positions (`pred`: `N x T x 32 x 3` or `T x 32 x 3`; `db`: `T x 32 x 3` or
//! `N x T x 32 x 3`), words in `metrics.md`'s heading frame (as `score --input-space raw`),
//! forecasts scored without seed. Files are read outside the clock; each repetition builds every
//! set's words and index and scores its forecasts (sets in parallel), and the median is reported
//! with a breakdown of one sequential pass into words, index build, search and similarity.
use anyhow::Context;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use motion_core::formats::npy::read_npy_as;
use motion_core::model::{Architecture, BatchGenerator, ModelConfig, MotionModel, Noise};
use motion_core::nn::simd::{self, SimdError, SimdPath};
use motion_metrics::ndms::index::NearestIndex;
use motion_metrics::ndms::{similarity, word, NdmsConfig, NdmsDatabase, NnMethod};
use motion_metrics::npss::{Npss, SpectrumPower};
use ndarray::{Array3, Array4, ArrayView3, Axis, Ix3};
use rayon::prelude::*;

use super::UsageError;

/// Seed frames given to each generator before timing.
const SEED_FRAMES: usize = 10;
/// Untimed steps after seeding (caches, page faults, rayon threads).
const WARM_UP_STEPS: usize = 3;

/// Architectures `--arch` accepts.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum ArchArg {
    /// Stacked GRU layers with derivative inputs (paper size: 2 x 512).
    #[value(name = "gru-d")]
    GruD,
    /// Plan GRU + body GRU with derivative inputs (paper size: 512).
    #[value(name = "vgru-d")]
    VgruD,
}

impl ArchArg {
    fn architecture(self) -> Architecture {
        match self {
            ArchArg::GruD => Architecture::GruD,
            ArchArg::VgruD => Architecture::VgruD,
        }
    }
}

/// Most timed steps per batch size (each step's time is kept: 80 MB at the limit).
pub const MAX_STEPS: usize = 10_000_000;
/// Most units per layer of a random model (a 4096-unit GRU layer holds 200 MB of weights).
pub const MAX_HIDDEN: usize = 4096;
/// Most characters x units of state a batch may hold (about 1 GB of buffers at the limit).
pub const MAX_BATCH_UNITS: usize = 1 << 24;

/// Arguments of `motion-cli bench`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A motion-weights file to time (default: random weights of the paper's sizes).
    #[arg(long, conflicts_with_all = ["arch", "hidden"])]
    pub model: Option<PathBuf>,
    /// Architecture of the random model; repeat or comma-separate for several (default: both).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub arch: Vec<ArchArg>,
    /// Units per GRU layer of the random model (paper: 512).
    #[arg(long, default_value_t = 512)]
    pub hidden: usize,
    /// Batch sizes (characters generated in lockstep), comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [1usize, 16, 256])]
    pub batch: Vec<usize>,
    /// Timed closed-loop steps per batch size.
    #[arg(long, default_value_t = 200)]
    pub steps: usize,
    /// VGRU-d: time one long run that re-plans every plan block (default: stay within a plan).
    #[arg(long)]
    pub with_plan: bool,
    /// Split small-batch steps over threads by output rows (BatchGenerator::set_row_split:
    /// lower latency at batch 1-4 on several cores; off by default because the step then runs on
    /// a rayon pool thread, whose queue allocates now and then).
    #[arg(long)]
    pub row_split: bool,
    /// Cut each batch into this many shards, one per thread (default: `BatchGenerator::new`'s
    /// rule for the selected SIMD path; 1 keeps a batch in one piece).
    #[arg(long, value_name = "N")]
    pub shards: Option<usize>,
    /// Run the same timed steps this many times (each run seeded identically) and also report
    /// `steady_max_us`: the slowest step index after taking, per index, its fastest run. A stall
    /// of the engine (e.g. a re-plan) recurs at its step in every run and stays in it; a host's
    /// preemption or a late wake-up rarely hits the same step twice and drops out.
    #[arg(long, default_value_t = 1, value_name = "R")]
    pub repeats: usize,
    /// SIMD paths to time, comma-separated (avx512, avx2, neon, portable; default: the one
    /// selected, i.e. $MOTION_SIMD or the best the CPU has). The model is loaded once per path,
    /// so each path also gets its own weight layout. A path the CPU lacks is refused.
    #[arg(long, value_delimiter = ',')]
    pub simd: Vec<SimdPath>,
    /// Seed of the random weights.
    #[arg(long, default_value_t = 42)]
    pub seed: u64,
    /// Time NPSS on these two .npy files (ground truth, prediction; N x T x D) instead of a model.
    #[arg(long, num_args = 2, value_names = ["GT.npy", "PRED.npy"], conflicts_with_all = ["model", "arch"])]
    pub npss: Vec<PathBuf>,
    /// Time NDMS on the (database, forecasts) sets of this JSON manifest instead of a model.
    #[arg(long, value_name = "MANIFEST.json", conflicts_with_all = ["model", "arch", "npss"])]
    pub ndms: Option<PathBuf>,
    /// Repetitions of the `--npss` or `--ndms` evaluation (the median is reported).
    #[arg(long, default_value_t = 5)]
    pub reps: usize,
    #[command(flatten)]
    pub reporting: super::output::Output,
}

/// The timing of one model at one batch size.
#[derive(Debug, Clone)]
struct Measurement {
    simd: SimdPath,
    arch: &'static str,
    hidden: usize,
    batch: usize,
    shards: usize,
    steps: usize,
    median_us: f64,
    mean_us: f64,
    p99_us: f64,
    max_us: f64,
    repeats: usize,
    steady_max_us: f64,
    steady_median_us: f64,
}

impl Measurement {
    fn char_steps_per_s(&self) -> f64 {
        self.batch as f64 * 1e6 / self.median_us
    }
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    if args.steps == 0 {
        return Err(UsageError("--steps must be at least 1".into()).into());
    }
    if args.batch.is_empty() || args.batch.contains(&0) {
        return Err(UsageError("--batch needs sizes of at least 1, e.g. 1,16,256".into()).into());
    }
    if args.shards == Some(0) {
        return Err(UsageError("--shards must be at least 1".into()).into());
    }
    if args.hidden == 0 {
        return Err(UsageError("--hidden must be at least 1".into()).into());
    }
    if args.repeats == 0 {
        return Err(UsageError("--repeats must be at least 1".into()).into());
    }
    // Sizes that decide memory, refused before anything is allocated.
    if args.steps > MAX_STEPS {
        return Err(UsageError(format!(
            "--steps {} is over the limit of {MAX_STEPS} (each step's time is kept): time fewer steps",
            args.steps
        ))
        .into());
    }
    if args.hidden > MAX_HIDDEN {
        return Err(UsageError(format!(
            "--hidden {} is over the limit of {MAX_HIDDEN} units (a layer's weights grow with its square): use a smaller model",
            args.hidden
        ))
        .into());
    }
    if let Some(&batch) = args
        .batch
        .iter()
        .find(|&&b| b.saturating_mul(args.hidden) > MAX_BATCH_UNITS)
    {
        return Err(UsageError(format!(
            "--batch {batch} x --hidden {} is over the limit of {MAX_BATCH_UNITS} units of state: use smaller batches",
            args.hidden
        ))
        .into());
    }
    if !args.npss.is_empty() {
        return run_npss(&args);
    }
    if let Some(manifest) = &args.ndms {
        return run_ndms(manifest, args.reps, args.reporting.json);
    }
    let paths = if args.simd.is_empty() {
        vec![simd::active()]
    } else {
        args.simd.clone()
    };
    if let Some(p) = paths.iter().find(|p| !p.supported()) {
        return Err(SimdError::Unsupported(*p).into());
    }
    let mut results = Vec::new();
    for &path in &paths {
        simd::set_simd_path(path)?;
        for model in &models(&args)? {
            for &batch in &args.batch {
                let run = TimedRun {
                    batch,
                    steps: args.steps,
                    with_plan: args.with_plan,
                    row_split: args.row_split,
                    shards: args.shards,
                };
                results.push(measure(model, &run, args.repeats)?);
            }
        }
    }
    let peak = peak_rss_mb();
    if args.reporting.json {
        println!("{}", json_report(&results, peak));
    } else {
        print!("{}", text_report(&results, peak));
    }
    Ok(())
}

/// The models to time: the file given, or random paper-size models of each architecture asked.
fn models(args: &Args) -> anyhow::Result<Vec<Arc<MotionModel>>> {
    if let Some(path) = &args.model {
        return Ok(vec![crate::model_source::load_model(
            Some(path),
            crate::model_source::BuiltIn::Game,
        )?]);
    }
    let arches = if args.arch.is_empty() {
        vec![ArchArg::GruD, ArchArg::VgruD]
    } else {
        args.arch.clone()
    };
    arches
        .into_iter()
        .map(|arch| {
            let mut config = ModelConfig::paper(arch.architecture());
            config.hidden = args.hidden;
            if let motion_core::model::ArchConfig::VgruD(fields) = &mut config.arch {
                fields.plan_hidden = args.hidden;
            }
            Ok(Arc::new(MotionModel::random(&config, args.seed)?))
        })
        .collect()
}

/// A generator for `batch` characters whose plan covers `steps` steps past the seed, seeded
/// with a smooth synthetic motion.
fn seeded(
    model: &Arc<MotionModel>,
    batch: usize,
    plan_horizon: usize,
    shards: Option<usize>,
) -> anyhow::Result<BatchGenerator> {
    let cfg = model.config();
    let mut generator = match shards {
        Some(n) => BatchGenerator::with_shards(Arc::clone(model), batch, n),
        None => BatchGenerator::new(Arc::clone(model), batch),
    };
    generator.set_plan_horizon(plan_horizon.max(1))?;
    let seeds = Array3::from_shape_fn((batch, SEED_FRAMES, cfg.frame_dims), |(b, t, d)| {
        0.1 * ((b * 7 + t * 3 + d) as f32 * 0.37).sin()
    });
    let action: Vec<&str> = cfg
        .actions
        .first()
        .map(String::as_str)
        .into_iter()
        .collect();
    let noise: Vec<Noise> = (0..batch as u64).map(Noise::Seed).collect();
    generator.start(seeds.view(), &action, &noise)?;
    Ok(generator)
}

/// What one timed run does: `steps` closed-loop steps at `batch`.
struct TimedRun {
    batch: usize,
    steps: usize,
    with_plan: bool,
    row_split: bool,
    shards: Option<usize>,
}

/// The median of sorted `times`.
fn median_sorted(times: &[f64]) -> f64 {
    let mid = times.len() / 2;
    if times.len() % 2 == 1 {
        times[mid]
    } else {
        0.5 * (times[mid - 1] + times[mid])
    }
}

/// Times `run` `repeats` times, each step on its own clock; statistics over every timed step,
/// and per step index over the repeats (see `Args::repeats`).
fn measure(
    model: &Arc<MotionModel>,
    run: &TimedRun,
    repeats: usize,
) -> anyhow::Result<Measurement> {
    let mut all = Vec::with_capacity(run.steps * repeats);
    let mut fastest = vec![f64::INFINITY; run.steps];
    let mut shard_count = 1;
    for _ in 0..repeats {
        let (times, shards) = time_steps(model, run)?;
        shard_count = shards;
        for (best, &t) in fastest.iter_mut().zip(&times) {
            *best = best.min(t);
        }
        all.extend(times);
    }
    let mean_us = all.iter().sum::<f64>() / all.len() as f64;
    all.sort_by(f64::total_cmp);
    let p99_us = all[(all.len() * 99).div_ceil(100).saturating_sub(1)];
    fastest.sort_by(f64::total_cmp);
    let cfg = model.config();
    Ok(Measurement {
        simd: simd::active(),
        arch: cfg.architecture().name(),
        hidden: cfg.hidden,
        batch: run.batch,
        shards: shard_count,
        steps: run.steps,
        median_us: median_sorted(&all),
        mean_us,
        p99_us,
        max_us: all[all.len() - 1],
        repeats,
        steady_max_us: fastest[fastest.len() - 1],
        steady_median_us: median_sorted(&fastest),
    })
}

/// One run: µs of each of `run.steps` steps (in order) and the generator's shard count.
fn time_steps(model: &Arc<MotionModel>, run: &TimedRun) -> anyhow::Result<(Vec<f64>, usize)> {
    let cfg = model.config();
    // Within-plan segments: the plan computed at seeding covers seed + horizon steps; re-seed
    // (untimed) before it runs out. Plan buffers grow with the horizon, so keep it the model's.
    let horizon = cfg.horizon.max(WARM_UP_STEPS + 2);
    let segment = if run.with_plan || cfg.architecture() == Architecture::GruD {
        run.steps
    } else {
        horizon - WARM_UP_STEPS - 1
    };
    let mut times = Vec::with_capacity(run.steps);
    let mut shard_count = 1;
    while times.len() < run.steps {
        let mut generator = seeded(model, run.batch, horizon, run.shards)?;
        generator.set_row_split(run.row_split);
        shard_count = generator.shards();
        for _ in 0..WARM_UP_STEPS {
            std::hint::black_box(generator.step()?[[0, 0]]);
        }
        let n = segment.min(run.steps - times.len());
        for _ in 0..n {
            let start = Instant::now();
            std::hint::black_box(generator.step()?[[0, 0]]);
            times.push(start.elapsed().as_secs_f64() * 1e6);
        }
    }
    Ok((times, shard_count))
}

/// `--npss GT PRED`: median seconds of `--reps` NPSS evaluations per spectrum.
fn run_npss(args: &Args) -> anyhow::Result<()> {
    if args.reps == 0 {
        return Err(UsageError("--reps must be at least 1".into()).into());
    }
    let gt = read_npy_as::<Ix3>(&args.npss[0])?;
    let pred = read_npy_as::<Ix3>(&args.npss[1])?;
    let mut npss = Npss::new();
    let mut rows = Vec::new();
    for (name, power) in [
        ("npss", SpectrumPower::Modulus),
        ("npss-reference", SpectrumPower::RealPart),
    ] {
        let mut value = 0.0;
        let mut times = Vec::with_capacity(args.reps);
        for _ in 0..args.reps {
            let start = Instant::now();
            value = npss.score(gt.view(), pred.view(), power).context("NPSS")?;
            times.push(start.elapsed().as_secs_f64() * 1e3);
        }
        times.sort_by(f64::total_cmp);
        rows.push((name, value, times[times.len() / 2], times[0]));
    }
    let peak = peak_rss_mb();
    if args.reporting.json {
        let results: Vec<serde_json::Value> = rows
            .iter()
            .map(|&(metric, value, median_ms, min_ms)| {
                serde_json::json!({
                    "metric": metric, "value": value, "median_ms": median_ms, "min_ms": min_ms,
                    "reps": args.reps, "shape": gt.shape(),
                })
            })
            .collect();
        println!(
            "{}",
            serde_json::json!({ "npss": results, "peak_rss_mb": peak })
        );
    } else {
        println!(
            "{:<16} {:>14} {:>12} {:>12}",
            "metric", "value", "median ms", "min ms"
        );
        for (metric, value, median_ms, min_ms) in rows {
            println!("{metric:<16} {value:>14.9} {median_ms:>12.2} {min_ms:>12.2}");
        }
    }
    Ok(())
}

/// One NDMS set of the manifest, read: database sequences and forecasts (positions).
struct NdmsSet {
    name: String,
    database: Vec<Array3<f64>>,
    forecasts: Array4<f64>,
}

/// Reads the manifest and every file it names.
fn read_ndms_sets(manifest: &std::path::Path) -> anyhow::Result<Vec<NdmsSet>> {
    let bad = |m: String| UsageError(format!("{}: {m}", manifest.display()));
    let text = std::fs::read_to_string(manifest)
        .map_err(|e| bad(format!("cannot read the manifest: {e}")))?;
    let json: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| bad(format!("not JSON: {e}")))?;
    let sets = json["sets"]
        .as_array()
        .filter(|s| !s.is_empty())
        .ok_or_else(|| bad("expected {\"sets\": [{\"name\", \"pred\", \"db\"}, ...]}".into()))?;
    let base = manifest.parent().unwrap_or(std::path::Path::new("."));
    let mut out = Vec::with_capacity(sets.len());
    for (i, set) in sets.iter().enumerate() {
        let field = |key: &str| {
            set[key]
                .as_str()
                .map(|p| base.join(p))
                .ok_or_else(|| bad(format!("set {i}: \"{key}\" must be a path")))
        };
        let pred = field("pred")?;
        let db: Vec<PathBuf> = set["db"]
            .as_array()
            .filter(|d| !d.is_empty())
            .and_then(|d| d.iter().map(|p| p.as_str().map(|p| base.join(p))).collect())
            .ok_or_else(|| bad(format!("set {i}: \"db\" must be a non-empty list of paths")))?;
        let name = set["name"]
            .as_str()
            .map_or_else(|| format!("set {i}"), str::to_string);
        let forecasts = positions4(&pred)?;
        let mut database = Vec::new();
        for path in &db {
            database.extend(positions4(path)?.outer_iter().map(|s| s.to_owned()));
        }
        out.push(NdmsSet {
            name,
            database,
            forecasts,
        });
    }
    Ok(out)
}

/// Positions `N x T x J x 3` from a .npy of that shape or `T x J x 3` (one sequence).
fn positions4(path: &std::path::Path) -> anyhow::Result<Array4<f64>> {
    let array = motion_core::formats::npy::read_npy_dyn(path)?;
    let shape = array.shape().to_vec();
    let array = if array.ndim() == 3 {
        array.insert_axis(Axis(0))
    } else {
        array
    };
    match array.into_dimensionality::<ndarray::Ix4>() {
        Ok(a) if a.dim().3 == 3 => Ok(a),
        _ => Err(UsageError(format!(
            "{}: expected positions T x J x 3 or N x T x J x 3, found shape {shape:?}",
            path.display()
        ))
        .into()),
    }
}

/// f_sim of one set: database words and index built, every forecast word scored.
fn ndms_set(set: &NdmsSet, config: &NdmsConfig) -> anyhow::Result<(f64, usize)> {
    let database: Vec<ArrayView3<'_, f64>> = set.database.iter().map(|d| d.view()).collect();
    let forecasts: Vec<ArrayView3<'_, f64>> = set.forecasts.outer_iter().collect();
    let what = |e| UsageError(format!("NDMS of {}: {e}", set.name));
    let db = NdmsDatabase::from_sequences(config.clone(), &database, NnMethod::default())
        .map_err(what)?;
    let report = db.score_forecasts(&forecasts, None).map_err(what)?;
    Ok((report.mean, db.len()))
}

/// Milliseconds of one sequential pass over every set, by phase: words (database and
/// queries), index build, nearest-neighbour search, similarity.
fn ndms_phases(sets: &[NdmsSet], config: &NdmsConfig) -> [f64; 4] {
    let mut phases = [0.0; 4];
    let mut lap = |phase: usize, start: Instant| {
        phases[phase] += start.elapsed().as_secs_f64() * 1e3;
        Instant::now()
    };
    let len = config.word_len();
    for set in sets {
        let start = Instant::now();
        let mut words = Vec::new();
        for sequence in &set.database {
            word::append_all_words(sequence.view(), config, &mut words);
        }
        let mut queries = Vec::new();
        for forecast in set.forecasts.outer_iter() {
            word::append_all_words(forecast, config, &mut queries);
        }
        let start = lap(0, start);
        let index = NearestIndex::build_frames(NnMethod::default(), words, len, config.kappa);
        let start = lap(1, start);
        let neighbours = index.nearest_batch(&queries);
        let start = lap(2, start);
        let total: f64 = queries
            .chunks_exact(len)
            .zip(&neighbours)
            .map(|(q, n)| {
                let w = &index.words()[n.index * len..(n.index + 1) * len];
                similarity::ndms(w, q, config.kappa)
            })
            .sum();
        std::hint::black_box(total);
        lap(3, start);
    }
    phases
}

/// `--ndms MANIFEST`: median seconds of `reps` whole NDMS evaluations over the manifest's sets.
fn run_ndms(manifest: &std::path::Path, reps: usize, json: bool) -> anyhow::Result<()> {
    if reps == 0 {
        return Err(UsageError("--reps must be at least 1".into()).into());
    }
    let start = Instant::now();
    let sets = read_ndms_sets(manifest)?;
    let read_ms = start.elapsed().as_secs_f64() * 1e3;
    let config = NdmsConfig::h36m();
    let mut times = Vec::with_capacity(reps);
    let mut results = Vec::new();
    for _ in 0..reps {
        let start = Instant::now();
        results = sets
            .par_iter()
            .map(|set| ndms_set(set, &config))
            .collect::<anyhow::Result<Vec<_>>>()?;
        times.push(start.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    let median_ms = times[times.len() / 2];
    let phases = ndms_phases(&sets, &config);
    let query_words = |set: &NdmsSet| {
        let (n, t, _, _) = set.forecasts.dim();
        n * (t + 1).saturating_sub(config.kappa)
    };
    let f_sim = results.iter().map(|r| r.0).sum::<f64>() / results.len() as f64;
    let peak = peak_rss_mb();
    if json {
        let rows: Vec<serde_json::Value> = sets
            .iter()
            .zip(&results)
            .map(|(set, &(mean, words))| {
                serde_json::json!({
                    "name": set.name, "mean": mean, "database_words": words,
                    "query_words": query_words(set),
                })
            })
            .collect();
        let report = serde_json::json!({
            "ndms": {
                "sets": rows, "mean_f_sim": f_sim, "median_ms": median_ms, "min_ms": times[0],
                "reps": reps, "threads": rayon::current_num_threads(), "read_ms": read_ms,
                "phases_ms": {
                    "words": phases[0], "index": phases[1], "search": phases[2],
                    "similarity": phases[3],
                },
                "exact": true, "nearest_neighbour": "pose-bound",
            },
            "peak_rss_mb": peak,
        });
        println!("{report}");
    } else {
        println!(
            "{:<20} {:>10} {:>10} {:>10}",
            "set", "db words", "queries", "f_sim"
        );
        for (set, (mean, words)) in sets.iter().zip(&results) {
            println!(
                "{:<20} {words:>10} {:>10} {mean:>10.6}",
                set.name,
                query_words(set)
            );
        }
        println!(
            "all {} sets: mean f_sim {f_sim:.6}, median {median_ms:.1} ms (min {:.1}) over {reps} reps, {} threads; files read in {read_ms:.1} ms",
            sets.len(),
            times[0],
            rayon::current_num_threads()
        );
        println!(
            "one sequential pass: words {:.1} ms, index {:.1} ms, search {:.1} ms, similarity {:.1} ms",
            phases[0], phases[1], phases[2], phases[3]
        );
    }
    Ok(())
}

/// Peak resident set size of this process in MB (`VmHWM` of /proc/self/status; Linux only).
fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

fn json_report(results: &[Measurement], peak: Option<f64>) -> String {
    let rows: Vec<serde_json::Value> = results
        .iter()
        .map(|m| {
            serde_json::json!({
                "simd": m.simd.name(),
                "arch": m.arch,
                "hidden": m.hidden,
                "batch": m.batch,
                "shards": m.shards,
                "steps": m.steps,
                "us_per_step": m.median_us,
                "mean_us_per_step": m.mean_us,
                "p99_us": m.p99_us,
                "max_us": m.max_us,
                "repeats": m.repeats,
                "steady_median_us": m.steady_median_us,
                "steady_max_us": m.steady_max_us,
                "char_steps_per_s": m.char_steps_per_s(),
            })
        })
        .collect();
    serde_json::json!({ "results": rows, "peak_rss_mb": peak }).to_string()
}

fn text_report(results: &[Measurement], peak: Option<f64>) -> String {
    let mut s = format!(
        "{:<8} {:<8} {:>6} {:>6} {:>6} {:>6} {:>12} {:>12} {:>10} {:>10} {:>16} {:>16}\n",
        "simd",
        "arch",
        "hidden",
        "batch",
        "shards",
        "steps",
        "µs/step",
        "mean µs",
        "p99 µs",
        "max µs",
        "char-steps/s",
        "steady max µs"
    );
    for m in results {
        s.push_str(&format!(
            "{:<8} {:<8} {:>6} {:>6} {:>6} {:>6} {:>12.1} {:>12.1} {:>10.1} {:>10.1} {:>16.0} {:>16}\n",
            m.simd.name(),
            m.arch,
            m.hidden,
            m.batch,
            m.shards,
            m.steps,
            m.median_us,
            m.mean_us,
            m.p99_us,
            m.max_us,
            m.char_steps_per_s(),
            if m.repeats > 1 {
                format!("{:.1}", m.steady_max_us)
            } else {
                "-".to_string()
            }
        ));
    }
    match peak {
        Some(mb) => s.push_str(&format!("peak RSS {mb:.1} MB\n")),
        None => s.push_str("peak RSS unknown (no /proc/self/status)\n"),
    }
    s
}
