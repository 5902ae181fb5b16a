//! VGRU-d, the VTLN-RNN with motion-derivative inputs: a plan GRU running backwards in time over
//! the whole sequence produces guide vectors for a body GRU (eqs. 1-4), whose hidden state a
//! linear decoder turns into the next frame.
//!
//! Citation: Gopalakrishnan, Mali, Kifer, Giles, Ororbia, "A Neural Temporal Model for Human
//! Motion Prediction", CVPR 2019 — Gopalakrishnan et al. 2019, sections 3.2 (architecture) and 3.3 (derivative
//! features). Tensors `plan.*` and `body.*` as in `training/models.py`.
//!
//! ## Plan
//! The plan GRU is fed the action one-hot at every step from the initial state
//! `mu + sqrt(softplus(sigma)) ⊙ eps`, for `S + T` steps (`S` seed frames, `T` the plan horizon).
//! Its outputs are reversed in time: body step `t` reads plan output `S + T - 1 - t`.
//!
//! ## Streaming beyond the planned horizon (a choice of this engine; training never goes there)
//! When body step `t` reaches `S + T`, a new block is planned: a fresh initial state (the next
//! `eps` of the row's noise source) and `T` plan steps; body step `t` of block `k >= 1` reads the
//! output that step `t - k T` would read in a plan of `S + T` steps, i.e. output `S + T - 1 -
//! (t - k T)` in `0..T`. Each block thus replays the training-time situation "the seed is over,
//! `T` frames are ahead", so guides stay in the distribution the body saw in training. The
//! switch between blocks is not smoothed; the body's own state carries the motion across it.
//!
//! The next block's plan is computed ahead, one plan step per body step over the `T` steps after
//! the seed of the current block, into a second guide buffer that becomes the current one when
//! the block starts: no step pays for a whole block (a stall of `T` plan steps), and the guides
//! are bit-identical to planning the block at once.
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::arch::{gru_shapes, ArchFields};
use super::config::{limits, ModelConfig};
use super::generate_error::GenerateError;
use super::net::{own, Begin, Net, NetState, NoiseSource};
use super::weights::{WeightStore, WeightsError};
use crate::nn::activation::softplus;
use crate::nn::{BodyGruCell, BodyGruConfig, GruCell, GruConfig, GruConvention, GruScratch};

/// The config fields only `vgru-d` has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct VgruDFields {
    /// Plan GRU units `P`.
    pub plan_hidden: usize,
}

impl ArchFields for VgruDFields {
    const STOCHASTIC: bool = true;

    /// Gopalakrishnan et al. 2019, section 4: derivative order 3, a body GRU of 512 units
    /// and a plan GRU of 512 in the paper's candidate convention, the 15 H3.6M actions.
    fn paper() -> ModelConfig {
        ModelConfig {
            gru_convention: GruConvention::Paper,
            derivative_order: 3,
            actions: ModelConfig::h36m_actions(),
            ..ModelConfig::h36m(VgruDFields { plan_hidden: 512 }.into(), 512, 1)
        }
    }

    /// A plan, actions to feed it and a horizon to plan over.
    fn validate(&self, config: &ModelConfig) -> Result<(), String> {
        if self.plan_hidden == 0 {
            return Err("vgru-d needs plan_hidden > 0".into());
        }
        if self.plan_hidden > limits::UNITS {
            return Err(format!(
                "plan_hidden {} is over the limit of {}",
                self.plan_hidden,
                limits::UNITS
            ));
        }
        if config.actions.is_empty() {
            return Err("vgru-d needs at least one action label".into());
        }
        if config.horizon == 0 {
            return Err("vgru-d needs horizon > 0".into());
        }
        Ok(())
    }

    /// `motion-cli info`'s lines: what the architecture is, then its sizes (last).
    fn describe(&self, config: &ModelConfig) -> Vec<(&'static str, String)> {
        vec![
            (
                "architecture",
                "vgru-d (VTLN-RNN: plan GRU + body GRU + linear decoder, Gopalakrishnan et al. 2019)"
                    .into(),
            ),
            (
                "sizes",
                format!(
                    "body GRU {} units, plan GRU {} units",
                    config.hidden, self.plan_hidden
                ),
            ),
        ]
    }

    fn tensor_shapes(&self, config: &ModelConfig, shapes: &mut Vec<(String, Vec<usize>)>) {
        let (p, h) = (self.plan_hidden, config.hidden);
        gru_shapes(shapes, "plan.cell", config.actions.len(), p);
        gru_shapes(shapes, "body", config.input_dims(), h);
        shapes.push(("plan.mu".into(), vec![p]));
        shapes.push(("plan.sigma".into(), vec![p]));
        shapes.push(("body.weight_ph".into(), vec![3 * h, p]));
    }

    fn random_values(&self, _config: &ModelConfig, name: &str, n: usize) -> Option<Vec<f32>> {
        matches!(name, "plan.mu" | "plan.sigma").then(|| vec![0.0; n])
    }

    fn load(
        &self,
        store: &WeightStore,
        config: &ModelConfig,
    ) -> Result<Arc<dyn Net>, WeightsError> {
        Ok(Arc::new(VgruD::load(store, config, self)?))
    }
}

/// VGRU-d recurrent weights (immutable, shareable).
#[derive(Debug, Clone)]
pub struct VgruD {
    plan: GruCell,
    mu: Vec<f32>,
    /// `sqrt(softplus(sigma))`, precomputed.
    scale: Vec<f32>,
    body: BodyGruCell,
    actions: usize,
}

/// Per-batch recurrent state of [`VgruD`]: the planned guides, the body hidden state and buffers.
#[derive(Debug)]
pub struct VgruState {
    capacity: usize,
    seed_len: usize,
    horizon: usize,
    /// Steps one row's guide buffer holds (`>= seed_len + horizon`).
    plan_capacity: usize,
    /// Plan outputs in forward order: row `b`, output `j` at `(b * plan_capacity + j) * P`.
    guides: Vec<f32>,
    /// The next block's plan outputs, same layout, filled ahead (see the module doc).
    next_guides: Vec<f32>,
    /// Plan steps of the next block done so far (`0..=horizon`).
    next_done: usize,
    plan_gi: Vec<f32>,
    /// Plan input projections of actions set mid-stream, applied when a next block's plan
    /// starts (see [`VgruD::set_action`]); `pending[b]` marks the rows that have one.
    pending_gi: Vec<f32>,
    pending: Vec<bool>,
    /// The next block's plan was restarted by `set_action`: its initial state is set.
    restarted: bool,
    plan_h: Vec<f32>,
    plan_scratch: GruScratch,
    eps: Vec<f32>,
    noise: Vec<NoiseSource>,
    hidden: Vec<f32>,
    body_scratch: GruScratch,
}

impl VgruD {
    /// Reads `plan.cell.*`, `plan.mu`, `plan.sigma` and `body.*`.
    pub fn load(
        store: &WeightStore,
        config: &ModelConfig,
        fields: &VgruDFields,
    ) -> Result<Self, WeightsError> {
        let p = fields.plan_hidden;
        let actions = config.actions.len();
        let plan = GruCell::load(
            store,
            "plan.cell",
            GruConfig {
                inputs: actions,
                hidden: p,
                convention: config.gru_convention,
            },
        )?;
        let mu = store.tensor("plan.mu", &[p])?;
        let sigma = store.tensor("plan.sigma", &[p])?;
        let scale = sigma.iter().map(|&s| softplus(s).sqrt()).collect();
        let body = BodyGruCell::load(
            store,
            "body",
            BodyGruConfig {
                gru: GruConfig {
                    inputs: config.input_dims(),
                    hidden: config.hidden,
                    convention: config.gru_convention,
                },
                guide: p,
            },
        )?;
        Ok(Self {
            plan,
            mu,
            scale,
            body,
            actions,
        })
    }

    /// Number of trainable parameters (plan GRU, mu, sigma, body GRU).
    pub fn parameter_count(&self) -> usize {
        self.plan.parameter_count() + 2 * self.mu.len() + self.body.parameter_count()
    }

    /// Plan units `P`.
    pub fn plan_hidden(&self) -> usize {
        self.mu.len()
    }

    /// Body units `H`.
    pub fn hidden(&self) -> usize {
        self.body.config().gru.hidden
    }

    /// State for up to `capacity` rows whose guide buffers hold `plan_steps` steps.
    pub fn new_state(&self, capacity: usize, plan_steps: usize) -> VgruState {
        let (p, h) = (self.plan_hidden(), self.hidden());
        VgruState {
            capacity,
            seed_len: 0,
            horizon: 0,
            plan_capacity: plan_steps,
            guides: vec![0.0; capacity * plan_steps * p],
            next_guides: vec![0.0; capacity * plan_steps * p],
            next_done: 0,
            plan_gi: vec![0.0; capacity * 3 * p],
            pending_gi: vec![0.0; capacity * 3 * p],
            pending: vec![false; capacity],
            restarted: false,
            plan_h: vec![0.0; capacity * p],
            plan_scratch: GruScratch::new(p, capacity),
            eps: vec![0.0; capacity * p],
            noise: Vec::with_capacity(capacity),
            hidden: vec![0.0; capacity * h],
            body_scratch: GruScratch::new(h, capacity),
        }
    }

    /// Starts `actions.len()` rows: zero body state, plan `seed_len + horizon` steps per row for
    /// its action index (one-hot order) and noise. Grows the guide buffers if needed (this is the
    /// only place that may allocate, once per sequence).
    pub fn begin(
        &self,
        state: &mut VgruState,
        actions: &[usize],
        noise: Vec<NoiseSource>,
        seed_len: usize,
        horizon: usize,
    ) {
        let batch = actions.len();
        assert!(batch <= state.capacity && noise.len() == batch);
        let p = self.plan_hidden();
        let steps = seed_len + horizon;
        if steps > state.plan_capacity {
            state.plan_capacity = steps;
            state.guides = vec![0.0; state.capacity * steps * p];
            state.next_guides = vec![0.0; state.capacity * steps * p];
        }
        state.next_done = 0;
        state.pending.fill(false);
        state.restarted = false;
        state.seed_len = seed_len;
        state.horizon = horizon;
        state.noise = noise;
        let g = 3 * p;
        for (b, &a) in actions.iter().enumerate() {
            debug_assert!(a < self.actions);
            self.plan
                .project_one_hot(Some(a), &mut state.plan_gi[b * g..(b + 1) * g]);
        }
        state.hidden[..batch * self.hidden()].fill(0.0);
        self.plan_block(state, batch, steps);
    }

    /// Runs `steps` plan steps for `batch` rows from fresh initial states, storing outputs `0..steps`.
    fn plan_block(&self, state: &mut VgruState, batch: usize, steps: usize) {
        self.plan_start(state, batch, true);
        for j in 0..steps {
            self.plan_step(state, batch, j, false);
        }
    }

    /// A fresh plan initial state `mu + scale ⊙ eps` per row: with `draw`, the next `eps` of its
    /// source; without, the `eps` drawn last (a restarted plan of the same block).
    fn plan_start(&self, state: &mut VgruState, batch: usize, draw: bool) {
        let p = self.plan_hidden();
        for b in 0..batch {
            let eps = &mut state.eps[b * p..(b + 1) * p];
            if draw {
                state.noise[b].fill(eps);
            }
            let h0 = &mut state.plan_h[b * p..(b + 1) * p];
            for (((h, m), s), e) in h0.iter_mut().zip(&self.mu).zip(&self.scale).zip(eps.iter()) {
                *h = m + s * e;
            }
        }
    }

    /// Copies the pending action projections of the first `batch` rows into the plan input.
    fn apply_pending(&self, state: &mut VgruState, batch: usize) {
        let g = 3 * self.plan_hidden();
        for b in 0..batch {
            if std::mem::take(&mut state.pending[b]) {
                state.plan_gi[b * g..(b + 1) * g]
                    .copy_from_slice(&state.pending_gi[b * g..(b + 1) * g]);
            }
        }
    }

    /// The body step at which the block running at body step `t` ends (the next swap).
    fn block_end(state: &VgruState, t: usize) -> usize {
        let (s, h) = (state.seed_len, state.horizon);
        s + (t.saturating_sub(s) / h + 1) * h
    }

    /// Conditions row `row` on `action` (one-hot index) from now on, without re-seeding: the plan
    /// of the next block reads it. When the next block's plan (computed ahead, one step per body
    /// step) can be redone before its block starts at no more than two plan steps per body step,
    /// it is redone now from the same noise, so the new action shows from the next block on;
    /// otherwise the block after it is the first one planned with the new action. No step pays
    /// for a whole block. `t` is the body step the next [`step`](Self::step) will run.
    pub fn set_action(
        &self,
        state: &mut VgruState,
        batch: usize,
        row: usize,
        action: usize,
        t: usize,
    ) {
        debug_assert!(action < self.actions && row < batch);
        let g = 3 * self.plan_hidden();
        self.plan
            .project_one_hot(Some(action), &mut state.pending_gi[row * g..(row + 1) * g]);
        state.pending[row] = true;
        if t < state.seed_len {
            return;
        }
        let calls_left = Self::block_end(state, t) - t;
        if state.next_done == 0 {
            // The next block's plan has not started: it starts with the new action.
        } else if 2 * calls_left >= state.horizon {
            self.apply_pending(state, batch);
            self.plan_start(state, batch, false);
            state.next_done = 0;
            state.restarted = true;
        }
    }

    /// Plan step `j`: output `j` into the current guides or (`next`) the next block's.
    fn plan_step(&self, state: &mut VgruState, batch: usize, j: usize, next: bool) {
        let p = self.plan_hidden();
        self.plan.step_with_projection(
            &state.plan_gi,
            &mut state.plan_h,
            batch,
            &mut state.plan_scratch,
        );
        let guides = if next {
            &mut state.next_guides
        } else {
            &mut state.guides
        };
        for b in 0..batch {
            let at = (b * state.plan_capacity + j) * p;
            guides[at..at + p].copy_from_slice(&state.plan_h[b * p..(b + 1) * p]);
        }
    }

    /// Plan steps of the next block (started on its first step) for body step `t`: as many as
    /// finish it by the time its block starts — one in lockstep, two at most after a
    /// [`set_action`](Self::set_action) restart.
    fn plan_ahead(&self, state: &mut VgruState, batch: usize, t: usize) {
        let h = state.horizon;
        if state.next_done >= h {
            return;
        }
        let calls_left = (Self::block_end(state, t) - t).max(1);
        for _ in 0..(h - state.next_done).div_ceil(calls_left) {
            if state.next_done == 0 && !std::mem::take(&mut state.restarted) {
                self.apply_pending(state, batch);
                self.plan_start(state, batch, true);
            }
            self.plan_step(state, batch, state.next_done, true);
            state.next_done += 1;
        }
    }

    /// The plan output read by body step `t` (see the module doc): switches to the block planned
    /// ahead when a new block starts, and advances the next block's plan by one step.
    fn guide_index(&self, state: &mut VgruState, batch: usize, t: usize) -> usize {
        let (s, h) = (state.seed_len, state.horizon);
        if t < s {
            return s + h - 1 - t;
        }
        let block = (t - s) / h;
        let local = t - block * h;
        if block >= 1 && local == s {
            while state.next_done < h {
                self.plan_ahead(state, batch, t); // only if steps were skipped: never in lockstep use
            }
            std::mem::swap(&mut state.guides, &mut state.next_guides);
            state.next_done = 0;
        }
        self.plan_ahead(state, batch, t);
        s + h - 1 - local
    }

    /// Body step `t` for `batch` rows of features `x [batch, I]`; returns the body hidden `[batch, H]`.
    pub fn step<'s>(
        &self,
        state: &'s mut VgruState,
        x: &[f32],
        batch: usize,
        t: usize,
    ) -> &'s [f32] {
        let p = self.plan_hidden();
        let j = self.guide_index(state, batch, t);
        let stride = state.plan_capacity * p;
        let guides = &state.guides[j * p..];
        self.body.step(
            x,
            guides,
            stride,
            &mut state.hidden,
            batch,
            &mut state.body_scratch,
        );
        &state.hidden[..batch * self.hidden()]
    }
}

impl Net for VgruD {
    fn parameter_count(&self) -> usize {
        VgruD::parameter_count(self)
    }
    fn noise_dims(&self) -> usize {
        self.plan_hidden()
    }
    fn needs_action(&self) -> bool {
        true
    }
    fn new_state(&self, rows: usize, config: &ModelConfig) -> Box<dyn NetState> {
        Box::new(self.new_state(rows, config.seed_frames + config.horizon))
    }
    fn begin(&self, state: &mut dyn NetState, begin: Begin<'_>) {
        VgruD::begin(
            self,
            own::<VgruState>(state),
            &begin.actions[..begin.rows],
            begin.noise,
            begin.seed_len,
            begin.plan_horizon,
        );
    }
    fn step<'s>(
        &self,
        state: &'s mut dyn NetState,
        features: &[f32],
        rows: usize,
        body_step: usize,
    ) -> Option<&'s [f32]> {
        Some(VgruD::step(
            self,
            own::<VgruState>(state),
            features,
            rows,
            body_step,
        ))
    }
    fn set_action(
        &self,
        state: &mut dyn NetState,
        rows: usize,
        row: usize,
        action: usize,
        _crossfade: usize,
        body_step: usize,
    ) -> Result<(), GenerateError> {
        VgruD::set_action(self, own::<VgruState>(state), rows, row, action, body_step);
        Ok(())
    }
}
