//! Closed-loop generation for a batch of characters (or of samples of one character) in lockstep.
//!
//! Every step is the same sequence for all rows: derivative features of the current normalized
//! frame, one recurrent step, the decoder, optional residual, the DAE-LSTM's autoencoder filter,
//! un-normalization. (The intention model's seed frames only feed its encoders: it makes no
//! prediction before the last seed frame, see [`super::intention`].) The per-step work
//! is matrix-matrix products over the batch (see [`crate::nn::gemm`]); all buffers are sized in
//! [`BatchGenerator::new`], so a step allocates nothing of its own. At batch 1 the products are
//! GEMVs and a step touches no heap at all (tested). Below twice [`SHARD_MIN_ROWS`] rows a step
//! is one shard on the calling thread, whose large products it splits by output columns with the
//! crew's helper (`nn::parallel::crew`, [`BatchGenerator::set_crew_products`]); from there on the
//! calling thread advances the first shard and
//! every other shard is handed over each step: called from outside a rayon pool, with no more
//! shards than threads, to the **crew** (`nn::parallel::crew`: helper threads that spin between
//! steps, so a hand-off wakes no one; no allocation, tested); otherwise to the rayon pool (long
//! shards to the crate's shard helpers, a pool of one thread fewer, so that no thread is left over
//! to compete with the shards), where rayon allocates one small job record per handed shard (and
//! `matrixmultiply`, which the portable path uses above batch 16, its packing buffers).
//!
//! Large batches are cut into **shards** of consecutive rows, one per rayon thread, each with its
//! own recurrent state and buffers: a step is then one fork-join for the whole step instead of
//! one per product and gate update, and every thread runs its rows' products on its own
//! ([`crate::nn::parallel::serial`]). Rows never interact, so results do not depend on the split.
//! Small batches (below twice [`SHARD_MIN_ROWS`] rows) stay in one shard: they are bound by
//! reading the weights, which every shard would read again. A sharded step waits for the slowest
//! shard, so its worst case includes waking a parked thread (see the README's stall figures);
//! [`BatchGenerator::with_shards`] with 1 keeps a batch on the calling thread.
//!
//! The fed-back frame is the model's normalized output itself (as in `training/models.py`), not
//! a re-normalized copy of the full frame it returns.
use super::auto_control::AutoControl;
use super::config::ModelConfig;
use super::generate_error::GenerateError;
use super::net::NoiseSource;
use super::net::{Begin, NetState};
use super::predictor::MotionModel;
use crate::derivatives::DerivativeBuffer;
use ndarray::{ArrayView2, ArrayView3};
use std::sync::Arc;

/// Fewest rows per shard: batches smaller than twice this run as one shard, whose large products
/// split by output columns over the crew instead ([`BatchGenerator::set_crew_products`]). On a
/// 2-core Intel Xeon (Firecracker VM, `motion-cli bench --shards 1|2` against `--shards 1` with
/// the crew's product split, three alternating runs, AVX-512): at batch 16 the shipped VGRU-d
/// took 171-210 µs in two shards of 8 rows and 138-205 µs in one split by columns, GRU-d 2x512
/// (f32) 714-791 against 489-639 µs: two shards each read every weight (the VGRU-d's 3.1 MB of
/// f32 panels, more than a core's 2 MB L2) from the shared L3, the column split half of them.
/// (Before the crew, on a 2-core AMD EPYC, two shards of 8 rows took 0.53-0.64x the time of one
/// unsplit shard.)
pub const SHARD_MIN_ROWS: usize = 16;
/// Fewest multiply-adds per shard and step (the shard's rows times the model's parameters) for
/// which a sharded step hands its other shards to the crate's shard helpers, one thread fewer
/// than the pool, instead of the pool itself (see `nn::parallel::pool::shard_scope`). On a
/// 2-vCPU AMD EPYC Zen 5 (`motion-cli bench --steps 1000`, two shards, f16 weights, every SIMD
/// path, alternating runs against the whole pool) the helpers took the 99th percentile step of
/// the GRU-d 2x512 at batch 16 (22 M per shard) from up to 2.06x its median to 1.11-1.40x,
/// medians within the runs' spread, and the shipped VGRU-d at batch 256 (98 M) from 2.03-2.41x
/// to 1.15-1.54x, but made the shipped VGRU-d at batch 16 (6 M, steps of about 70 µs) 5-25 %
/// slower at the median.
const SHARD_HELPERS_MIN_MACS: usize = 1 << 24;
/// Smallest model whose steps run on a pool thread: below, no product is large enough to split.
const POOL_STEP_MIN_PARAMETERS: usize = 1 << 19;

pub use crate::motion::FrameScalar;

/// The noise of one character: VGRU-d's plan noise `eps`, the intention model's `z`
/// (deterministic models ignore it).
#[derive(Debug, Clone, Copy)]
pub enum Noise<'a> {
    /// `N(0, I)` draws from `StdRng::seed_from_u64(seed)`: VGRU-d draws a new `eps` for each plan
    /// block, the intention model its `z` once per start.
    Seed(u64),
    /// This vector: VGRU-d's `eps` (length `plan_hidden`) for every plan block, or the intention
    /// model's `z` (length `noise_dims`).
    Explicit(&'a [f32]),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// Not seeded yet.
    Idle,
    /// The prediction in `out_*` has not been handed out yet.
    Fresh,
    /// The prediction in `out_*` was handed out; the next step feeds it back.
    Running,
}

/// Generator for `batch` characters sharing one model; see the module doc.
#[derive(Debug)]
pub struct BatchGenerator {
    model: Arc<MotionModel>,
    batch: usize,
    plan_horizon: usize,
    /// Rows per shard (the last shard may have fewer).
    shard_rows: usize,
    shards: Vec<Shard>,
    /// Whether a small-batch step of this model could split its products by output rows
    /// (several threads, AVX-512 or AVX2 row kernels at this batch, a paper-size model).
    row_split_possible: bool,
    /// Run each (single-shard) step on a rayon pool thread, where the row kernels split their
    /// products over threads ([`set_row_split`](Self::set_row_split)).
    pool_step: bool,
    /// Split a single-shard step's large products by output columns between the calling thread
    /// and the crew ([`crate::nn::parallel::crew_products`]).
    crew_products: bool,
    /// Hand the shards after the first to the crate's shard helpers rather than the current
    /// pool (long shards, see [`SHARD_HELPERS_MIN_MACS`]).
    shard_helpers: bool,
    frame: Vec<f32>,
    out_full: Vec<f32>,
    body_steps: usize,
    /// The controls of a model that reads one, for rows nobody steers ([`super::auto_control`]).
    auto: Option<AutoControl>,
    phase: Phase,
}

/// Consecutive rows of the batch with their own state and buffers (see the module doc).
#[derive(Debug)]
struct Shard {
    rows: usize,
    derivatives: Vec<DerivativeBuffer<f32>>,
    x_norm: Vec<f32>,
    features: Vec<f32>,
    out_norm: Vec<f32>,
    state: Box<dyn NetState>,
    /// Each row's action index (the pose prior's group).
    actions: Vec<usize>,
    /// The pose prior's scratch values.
    prior_scratch: Vec<f32>,
}

impl Shard {
    fn new(model: &MotionModel, rows: usize) -> Self {
        let cfg = model.config();
        let (o, i) = (cfg.output_dims(), cfg.input_dims());
        let state = model.network().net().new_state(rows, cfg);
        Self {
            rows,
            derivatives: (0..rows)
                .map(|_| DerivativeBuffer::new(o, cfg.derivative_order))
                .collect(),
            x_norm: vec![0.0; rows * o],
            features: vec![0.0; rows * i],
            out_norm: vec![0.0; rows * o],
            state,
            actions: vec![0; rows],
            prior_scratch: vec![0.0; model.prior().map_or(0, |p| p.scratch_len())],
        }
    }

    /// One body step of this shard's rows from `x_norm` to `out_norm` and `out_full`
    /// (`[rows, frame_dims]`, this shard's part of the batch's frames); the intention model's
    /// seed frames before the last leave both untouched (no prediction is made there).
    fn advance(&mut self, model: &MotionModel, body_step: usize, out_full: &mut [f32]) {
        let cfg = model.config();
        let (o, i, f) = (cfg.output_dims(), cfg.input_dims(), cfg.frame_dims);
        let rows = self.rows;
        for (b, d) in self.derivatives.iter_mut().enumerate() {
            d.push(
                &self.x_norm[b * o..(b + 1) * o],
                &mut self.features[b * i..(b + 1) * i],
            );
        }
        let net = model.network().net();
        let Some(hidden) = net.step(self.state.as_mut(), &self.features, rows, body_step) else {
            return;
        };
        model.decoder().forward(hidden, rows, &mut self.out_norm);
        if cfg.residual {
            for (y, x) in self.out_norm.iter_mut().zip(&self.x_norm) {
                *y += x;
            }
        }
        net.filter(self.state.as_mut(), &mut self.out_norm, rows);
        if let Some(prior) = model.prior() {
            for (b, &action) in self.actions.iter().enumerate() {
                prior.apply(
                    action,
                    &mut self.out_norm[b * o..(b + 1) * o],
                    &mut self.prior_scratch,
                );
            }
        }
        let norm = model.normalization();
        for b in 0..rows {
            norm.unnormalize(
                &self.out_norm[b * o..(b + 1) * o],
                &mut out_full[b * f..(b + 1) * f],
            );
        }
    }
}

impl BatchGenerator {
    /// A generator for `batch` characters (at least 1), with buffers for the model's training
    /// seed length and horizon.
    pub fn new(model: Arc<MotionModel>, batch: usize) -> Self {
        let batch = batch.max(1);
        let threads = crate::nn::parallel::pool::current_num_threads().max(1);
        let shards = threads.min(batch / SHARD_MIN_ROWS).max(1);
        Self::with_shards(model, batch, shards)
    }

    /// Like [`new`](Self::new) with the batch cut into `shards` parts (at most `batch`; 1 runs
    /// every step as one piece, whose large products are still split over threads).
    pub fn with_shards(model: Arc<MotionModel>, batch: usize, shards: usize) -> Self {
        let batch = batch.max(1);
        let shard_rows = batch.div_ceil(shards.clamp(1, batch));
        let shards: Vec<Shard> = (0..batch.div_ceil(shard_rows))
            .map(|k| Shard::new(&model, shard_rows.min(batch - k * shard_rows)))
            .collect();
        let cfg = model.config();
        let shards_len = shards.len();
        let row_split_possible = shards.len() == 1
            && batch <= crate::nn::gemm::row_kernel_max_batch(model.decoder().weight())
            && crate::nn::parallel::pool::current_num_threads() > 1
            && model.parameter_count() >= POOL_STEP_MIN_PARAMETERS;
        Self {
            batch,
            plan_horizon: cfg.horizon.max(1),
            shard_rows,
            shards,
            row_split_possible,
            pool_step: false,
            crew_products: shards_len == 1
                && crate::nn::parallel::pool::current_num_threads() > 1
                && model.parameter_count() >= POOL_STEP_MIN_PARAMETERS,
            shard_helpers: shard_rows * model.parameter_count() >= SHARD_HELPERS_MIN_MACS,
            frame: vec![0.0; cfg.frame_dims],
            out_full: vec![0.0; batch * cfg.frame_dims],
            body_steps: 0,
            phase: Phase::Idle,
            auto: AutoControl::for_model(&model, batch),
            model,
        }
    }

    /// Splits each step's products over the rayon pool by output rows at small batches (batch 1
    /// with f32 weights, up to 4 with f16/bf16) of large models, for lower latency per step (on
    /// a 2-core Intel Xeon: GRU-d 2x512 with f16 weights 242 → 171 µs, VGRU-d 512 158 → 90 µs).
    /// Off by default because the step then runs on a pool thread: handing it there goes through
    /// rayon's injection queue, which allocates a queue block every 63 steps, and a real-time
    /// caller may prefer a step that touches no heap and no other thread. Returns whether the
    /// split applies to this generator (several threads, batch and model size).
    pub fn set_row_split(&mut self, enabled: bool) -> bool {
        self.pool_step = enabled && self.row_split_possible;
        self.pool_step
    }

    /// Splits a single-shard step's large products by output columns between the calling
    /// thread and the crew's spinning helper threads (`nn::parallel::crew`): on by default for
    /// one-shard batches of models of at least 2^19 parameters when rayon has several threads
    /// and the crew runs (`MOTION_CREW=off` stops it for the whole process: one thread per
    /// step, nothing spinning). Applies when stepped from a thread outside any rayon pool; no
    /// allocation. Returns whether it is on for this generator.
    pub fn set_crew_products(&mut self, enabled: bool) -> bool {
        self.crew_products = enabled
            && self.shards.len() == 1
            && crate::nn::parallel::pool::current_num_threads() > 1;
        self.crew_products
    }

    /// Number of shards the batch is cut into (see the module doc).
    pub fn shards(&self) -> usize {
        self.shards.len()
    }

    /// The shared model.
    pub fn model(&self) -> &Arc<MotionModel> {
        &self.model
    }

    /// Number of characters generated in lockstep.
    pub fn batch(&self) -> usize {
        self.batch
    }

    /// Predicted frames per VGRU plan block (default: the model's training `horizon`).
    pub fn plan_horizon(&self) -> usize {
        self.plan_horizon
    }

    /// Sets the VGRU plan horizon `T` used by the next [`start`](Self::start): the first plan
    /// covers `seed + T` steps, later blocks `T` steps each.
    pub fn set_plan_horizon(&mut self, horizon: usize) -> Result<(), GenerateError> {
        if horizon == 0 {
            return Err(GenerateError::ZeroHorizon);
        }
        self.plan_horizon = horizon;
        Ok(())
    }

    /// Body steps run since the last start (seed frames included).
    pub fn body_steps(&self) -> usize {
        self.body_steps
    }

    /// Seeds every character: `seeds [batch, S, frame_dims]` full frames, `actions` one label per
    /// character or one for all (ignored by unconditioned models), `noise` one per character
    /// (VGRU-d, intention; may be empty for deterministic models). Afterwards
    /// [`step`](Self::step) yields frame `S` first.
    pub fn start<T: FrameScalar>(
        &mut self,
        seeds: ArrayView3<'_, T>,
        actions: &[&str],
        noise: &[Noise<'_>],
    ) -> Result<(), GenerateError> {
        self.start_with(seeds, actions, noise, |_, _| {})
    }

    /// Like [`start`](Self::start), also handing out each teacher-forced prediction: after seed
    /// frame `t`, `teacher_forced(t, frames [batch, frame_dims])` gets the prediction of frame `t + 1`.
    ///
    /// The intention model makes no teacher-forced predictions (its seed frames feed encoders,
    /// and its first prediction, frame `S`, is what the first [`step`](Self::step) returns):
    /// for it `teacher_forced` is never called.
    pub fn start_with<T: FrameScalar, F: FnMut(usize, ArrayView2<'_, f32>)>(
        &mut self,
        seeds: ArrayView3<'_, T>,
        actions: &[&str],
        noise: &[Noise<'_>],
        mut teacher_forced: F,
    ) -> Result<(), GenerateError> {
        let model = Arc::clone(&self.model);
        let cfg = model.config();
        let (rows, seed_len, width) = seeds.dim();
        self.validate_seeds(cfg, &seeds)?;
        if rows != self.batch {
            return Err(GenerateError::WrongBatch {
                what: "seed sequences",
                expected: self.batch,
                got: rows,
            });
        }
        debug_assert_eq!(width, cfg.frame_dims);
        let action_indices = self.action_indices(cfg, actions)?;
        self.begin_auto_controls(&seeds);
        let net = model.network().net();
        let mut sources = match net.noise_dims() {
            0 => Vec::new(),
            dims => self.noise_sources(dims, noise)?,
        }
        .into_iter();
        let teacher_forcing = net.teacher_forced();
        for (k, shard) in self.shards.iter_mut().enumerate() {
            let rows = k * self.shard_rows..k * self.shard_rows + shard.rows;
            shard.actions.copy_from_slice(&action_indices[rows.clone()]);
            net.begin(
                shard.state.as_mut(),
                Begin {
                    rows: shard.rows,
                    actions: &action_indices[rows],
                    noise: sources.by_ref().take(shard.rows).collect(),
                    seed_len,
                    plan_horizon: self.plan_horizon,
                },
            );
            for d in &mut shard.derivatives {
                d.reset();
            }
        }
        self.body_steps = 0;
        let norm = model.normalization();
        let o = cfg.output_dims();
        for t in 0..seed_len {
            for b in 0..self.batch {
                for (dst, &src) in self
                    .frame
                    .iter_mut()
                    .zip(seeds.slice(ndarray::s![b, t, ..]))
                {
                    *dst = src.to_f32();
                }
                let (shard, row) = (b / self.shard_rows, b % self.shard_rows);
                norm.normalize(
                    &self.frame,
                    &mut self.shards[shard].x_norm[row * o..(row + 1) * o],
                );
            }
            self.advance(&model);
            if teacher_forcing {
                teacher_forced(t, self.frames());
            }
        }
        self.phase = Phase::Fresh;
        Ok(())
    }

    /// The width of the control vector the model reads (0: none; a `goal-gru` model: 3, see
    /// [`goal_gru`](super::goal_gru)).
    pub fn control_dims(&self) -> usize {
        self.model.network().net().control_dims()
    }

    /// Sets character `row`'s control vector, read by every step from the next on (before
    /// [`start`](Self::start): by the seed too; a character starts with zeros). No allocation.
    ///
    /// # Errors
    /// A model that takes no control, a row outside the batch, or a vector of the wrong length
    /// or with a value that is not finite.
    pub fn set_control(&mut self, row: usize, control: &[f32]) -> Result<(), GenerateError> {
        let model = Arc::clone(&self.model);
        let net = model.network().net();
        let expected = net.control_dims();
        if expected == 0 {
            return Err(GenerateError::NotControlled);
        }
        if row >= self.batch {
            return Err(GenerateError::NoSuchRow {
                row,
                batch: self.batch,
            });
        }
        if control.len() != expected || !control.iter().all(|v| v.is_finite()) {
            return Err(GenerateError::BadControl {
                expected,
                got: control.to_vec(),
            });
        }
        let (state, local) = self.row_state(row);
        net.set_control(state, local, control)?;
        if let Some(auto) = &mut self.auto {
            auto.set_manual(row);
        }
        Ok(())
    }

    /// Row `row`'s shard state and its row within it.
    fn row_state(&mut self, row: usize) -> (&mut dyn NetState, usize) {
        let (k, local) = (row / self.shard_rows, row % self.shard_rows);
        (self.shards[k].state.as_mut(), local)
    }

    /// Feeds the seeds to the automatic controls and sets each automatic row's first control.
    fn begin_auto_controls<T: FrameScalar>(&mut self, seeds: &ArrayView3<'_, T>) {
        let Some(auto) = &mut self.auto else { return };
        let net = self.model.network().net();
        for b in 0..self.batch {
            if auto.begin(b).is_none() {
                continue;
            }
            for t in 0..seeds.dim().1 {
                for (dst, &src) in self
                    .frame
                    .iter_mut()
                    .zip(seeds.slice(ndarray::s![b, t, ..]))
                {
                    *dst = src.to_f32();
                }
                auto.observe_seed(b, &self.frame);
            }
            if let Some(control) = auto.seed_control(b) {
                let (k, local) = (b / self.shard_rows, b % self.shard_rows);
                // The width is the net's own (3): this cannot fail.
                let _ = net.set_control(self.shards[k].state.as_mut(), local, &control);
            }
        }
    }

    /// Hands each automatic row's newest frame to its control and sets the next step's.
    fn update_auto_controls(&mut self) {
        let Some(auto) = &mut self.auto else { return };
        let net = self.model.network().net();
        let f = self.model.config().frame_dims;
        for b in 0..self.batch {
            if let Some(control) = auto.frame(b, &self.out_full[b * f..(b + 1) * f]) {
                let (k, local) = (b / self.shard_rows, b % self.shard_rows);
                let _ = net.set_control(self.shards[k].state.as_mut(), local, &control);
            }
        }
    }

    /// Conditions character `row` on `action` from its next step on, without re-seeding (the
    /// motion continues from where it is). How soon the new action shows depends on the model:
    /// - DAE-LSTM reads the action one-hot at every step: from the next step, or blended from the
    ///   previous action over `crossfade` steps;
    /// - VGRU-d reads it through its plan of the next block ([`set_plan_horizon`](Self::set_plan_horizon),
    ///   100 frames by default): from the next block, or the one after when the next one starts
    ///   in less than half a block (the plan is then computed ahead at no more than two plan
    ///   steps per body step: no step stalls); `crossfade` is not used, the body's own state
    ///   carries the motion across the block change.
    ///
    /// # Errors
    /// Before [`start`](Self::start), a row outside the batch, an unknown label, or a model
    /// without actions (GRU-d).
    pub fn set_action(
        &mut self,
        row: usize,
        action: &str,
        crossfade: usize,
    ) -> Result<(), GenerateError> {
        if self.phase == Phase::Idle {
            return Err(GenerateError::NotStarted);
        }
        if row >= self.batch {
            return Err(GenerateError::NoSuchRow {
                row,
                batch: self.batch,
            });
        }
        let model = Arc::clone(&self.model);
        let cfg = model.config();
        if cfg.actions.is_empty() {
            return Err(GenerateError::NotConditioned);
        }
        let index = cfg
            .action_index(action)
            .ok_or_else(|| GenerateError::UnknownAction {
                label: action.to_string(),
                valid: cfg.actions.clone(),
            })?;
        // The next advance runs body step `body_steps` (the first step after start hands out
        // the prediction already made, and the same holds then).
        let t = self.body_steps;
        let shard = &mut self.shards[row / self.shard_rows];
        shard.actions[row % self.shard_rows] = index;
        let rows = shard.rows;
        let (state, local) = self.row_state(row);
        model
            .network()
            .net()
            .set_action(state, rows, local, index, crossfade, t)
    }

    /// The next full frame of every character, `[batch, frame_dims]`: the first call after
    /// [`start`](Self::start) returns the prediction made from the last seed frame, each later
    /// call feeds the previous output back (closed loop).
    pub fn step(&mut self) -> Result<ArrayView2<'_, f32>, GenerateError> {
        match self.phase {
            Phase::Idle => return Err(GenerateError::NotStarted),
            Phase::Fresh => {}
            Phase::Running => {
                for shard in &mut self.shards {
                    std::mem::swap(&mut shard.x_norm, &mut shard.out_norm);
                }
                let model = Arc::clone(&self.model);
                self.advance(&model);
            }
        }
        self.phase = Phase::Running;
        self.update_auto_controls();
        Ok(self.frames())
    }

    /// The current predictions `[batch, frame_dims]`.
    fn frames(&self) -> ArrayView2<'_, f32> {
        let f = self.model.config().frame_dims;
        ArrayView2::from_shape((self.batch, f), &self.out_full).expect("buffer sized in new")
    }

    /// One body step of every shard (in parallel when there are several).
    fn advance(&mut self, model: &MotionModel) {
        let step = self.body_steps;
        if let [shard] = &mut self.shards[..] {
            if self.pool_step {
                // On a pool thread the row kernels' splits are cheap joins (see `pool_step`).
                let out = &mut self.out_full;
                crate::nn::parallel::pool::scope(|_| shard.advance(model, step, out));
            } else if self.crew_products {
                let out = &mut self.out_full;
                crate::nn::parallel::crew_products(|| shard.advance(model, step, out));
            } else {
                shard.advance(model, step, &mut self.out_full);
            }
        } else {
            let chunk = self.shard_rows * model.config().frame_dims;
            // The calling thread advances the first shard itself and hands the others to the
            // pool, or for long shards to the shard helpers (`SHARD_HELPERS_MIN_MACS`): one
            // worker woken per extra shard, none for the caller (on a 2-vCPU VM,
            // `par_iter` from outside the pool, which parks the caller and wakes a worker per
            // shard, measured median 430 µs and p99 3.7 ms at batch 16 (GRU-d 2x512, AVX-512)
            // against 222 µs and p99 3.5 ms this way; the shipped VGRU-d p99 2,947 -> 209 µs).
            if self.advance_on_crew(model, step, chunk) {
                self.body_steps += 1;
                return;
            }
            let helpers = self.shard_helpers;
            let mut outs = self.out_full.chunks_mut(chunk);
            let mut shards = self.shards.iter_mut();
            if let (Some(first), Some(first_out)) = (shards.next(), outs.next()) {
                crate::nn::parallel::pool::shard_scope(helpers, |s| {
                    for (shard, out) in shards.zip(outs) {
                        s.spawn(move |_| {
                            crate::nn::parallel::serial(|| shard.advance(model, step, out))
                        });
                    }
                    crate::nn::parallel::serial(|| first.advance(model, step, first_out));
                });
            }
        }
        self.body_steps += 1;
    }

    /// The shards of one step on the crew (`nn::parallel::crew`: helper threads that spin
    /// between steps, so a hand-off costs no wake-up), from a thread outside any rayon pool;
    /// `false` (nothing run) when the crew cannot take the step.
    #[cfg(feature = "parallel")]
    fn advance_on_crew(&mut self, model: &MotionModel, step: usize, chunk: usize) -> bool {
        use crate::nn::parallel::crew;
        if crate::nn::parallel::pool::current_thread_index().is_some()
            || self.shards.len() > crew::Crew::threads()
        {
            return false;
        }
        /// The shards and their output rows, shared with the crew: part `k` touches only shard
        /// `k` and its chunk of the output.
        struct Parts {
            shards: *mut Shard,
            out: *mut f32,
            out_len: usize,
        }
        // SAFETY: each part dereferences only its own shard and output chunk (disjoint), and
        // `crew::run` returns after every part is done.
        unsafe impl Sync for Parts {}
        let parts = Parts {
            shards: self.shards.as_mut_ptr(),
            out: self.out_full.as_mut_ptr(),
            out_len: self.out_full.len(),
        };
        let count = self.shards.len();
        crew::run(count, &|k| {
            let parts = &parts;
            let start = (k * chunk).min(parts.out_len);
            let end = ((k + 1) * chunk).min(parts.out_len);
            // SAFETY: `k < count` (the crew runs parts 0..count once each); shard `k` and output
            // rows `start..end` are touched by part `k` alone (see `Parts`).
            let (shard, out) = unsafe {
                (
                    &mut *parts.shards.add(k),
                    std::slice::from_raw_parts_mut(parts.out.add(start), end - start),
                )
            };
            crate::nn::parallel::serial(|| shard.advance(model, step, out));
        })
    }

    #[cfg(not(feature = "parallel"))]
    fn advance_on_crew(&mut self, _: &MotionModel, _: usize, _: usize) -> bool {
        false
    }

    fn validate_seeds<T: FrameScalar>(
        &self,
        cfg: &ModelConfig,
        seeds: &ArrayView3<'_, T>,
    ) -> Result<(), GenerateError> {
        let (_, seed_len, width) = seeds.dim();
        if width != cfg.frame_dims {
            return Err(GenerateError::WrongWidth {
                expected: cfg.frame_dims,
                got: width,
            });
        }
        if seed_len < 1 {
            return Err(GenerateError::TooFewSeedFrames {
                needed: 1,
                got: seed_len,
            });
        }
        for ((character, frame, dim), v) in seeds.indexed_iter() {
            let value = v.to_f64();
            if !value.is_finite() || !v.to_f32().is_finite() {
                return Err(GenerateError::NonFiniteSeed {
                    character,
                    frame,
                    dim,
                    value,
                });
            }
        }
        Ok(())
    }

    fn action_indices(
        &self,
        cfg: &ModelConfig,
        actions: &[&str],
    ) -> Result<Vec<usize>, GenerateError> {
        if cfg.actions.is_empty() {
            return Ok(vec![0; self.batch]);
        }
        let resolve = |label: &str| {
            cfg.action_index(label)
                .ok_or_else(|| GenerateError::UnknownAction {
                    label: label.to_string(),
                    valid: cfg.actions.clone(),
                })
        };
        let needed = self.model.network().net().needs_action();
        match actions.len() {
            0 if needed => Err(GenerateError::MissingAction {
                valid: cfg.actions.clone(),
            }),
            0 => Ok(vec![0; self.batch]),
            1 => Ok(vec![resolve(actions[0])?; self.batch]),
            n if n == self.batch => actions.iter().map(|a| resolve(a)).collect(),
            n => Err(GenerateError::WrongBatch {
                what: "actions",
                expected: self.batch,
                got: n,
            }),
        }
    }

    fn noise_sources(
        &self,
        plan: usize,
        noise: &[Noise<'_>],
    ) -> Result<Vec<NoiseSource>, GenerateError> {
        if noise.len() != self.batch {
            return Err(GenerateError::WrongBatch {
                what: "noise sources",
                expected: self.batch,
                got: noise.len(),
            });
        }
        noise
            .iter()
            .map(|n| match *n {
                Noise::Seed(seed) => Ok(NoiseSource::seeded(seed)),
                Noise::Explicit(eps) if eps.len() == plan => Ok(NoiseSource::Fixed(eps.to_vec())),
                Noise::Explicit(eps) => Err(GenerateError::WrongNoiseLength {
                    expected: plan,
                    got: eps.len(),
                }),
            })
            .collect()
    }
}
