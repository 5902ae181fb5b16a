//! Stacked recurrent layers, the `rnn.{k}` of the PyTorch modules (`torch.nn.GRU`/`LSTM` with
//! `num_layers > 1` unrolled into cells): layer 0 reads the step's input, layer `k > 0` reads the
//! new hidden state of layer `k - 1`, and the step's output is the top layer's hidden state. The
//! one stacking loop of GRU-d, the intention model's pose RNN, the DAE-LSTM and the action
//! classifier.
use std::fmt::Debug;

use super::gru::{GruCell, GruConfig, GruConvention, GruScratch};
use super::lstm::{LstmCell, LstmConfig, LstmScratch};
use crate::weights::{WeightStore, WeightsError};

/// A recurrent cell a [`Stack`] can hold.
pub trait Recurrent {
    /// Per-step work buffers for up to a given number of rows.
    type Scratch: Debug + Clone;
    /// Whether the cell keeps a memory beside its hidden state (the LSTM's cell state).
    const MEMORY: bool;
    /// Input width.
    fn inputs(&self) -> usize;
    /// Hidden units.
    fn hidden(&self) -> usize;
    /// Number of trainable parameters.
    fn parameter_count(&self) -> usize;
    /// Work buffers for up to `capacity` rows.
    fn scratch(&self, capacity: usize) -> Self::Scratch;
    /// One step for `batch` rows: `x [batch, inputs]`, hidden `h` and memory (`[batch, hidden]`,
    /// empty when the cell has none) updated in place.
    fn step(
        &self,
        x: &[f32],
        h: &mut [f32],
        memory: &mut [f32],
        batch: usize,
        scratch: &mut Self::Scratch,
    );
}

impl Recurrent for GruCell {
    type Scratch = GruScratch;
    const MEMORY: bool = false;
    fn inputs(&self) -> usize {
        self.config().inputs
    }
    fn hidden(&self) -> usize {
        self.config().hidden
    }
    fn parameter_count(&self) -> usize {
        GruCell::parameter_count(self)
    }
    fn scratch(&self, capacity: usize) -> GruScratch {
        GruScratch::new(self.config().hidden, capacity)
    }
    fn step(&self, x: &[f32], h: &mut [f32], _: &mut [f32], batch: usize, s: &mut GruScratch) {
        GruCell::step(self, x, h, batch, s);
    }
}

impl Recurrent for LstmCell {
    type Scratch = LstmScratch;
    const MEMORY: bool = true;
    fn inputs(&self) -> usize {
        self.config().inputs
    }
    fn hidden(&self) -> usize {
        self.config().hidden
    }
    fn parameter_count(&self) -> usize {
        LstmCell::parameter_count(self)
    }
    fn scratch(&self, capacity: usize) -> LstmScratch {
        LstmScratch::new(self.config().hidden, capacity)
    }
    fn step(&self, x: &[f32], h: &mut [f32], c: &mut [f32], batch: usize, s: &mut LstmScratch) {
        LstmCell::step(self, x, h, c, batch, s);
    }
}

/// Layers of one cell type and one hidden width (immutable, shareable).
#[derive(Debug, Clone)]
pub struct Stack<C> {
    layers: Vec<C>,
}

/// The recurrent state of a [`Stack`] for up to a fixed number of rows, sized once.
#[derive(Debug, Clone)]
pub struct StackState<S> {
    hidden: Vec<Vec<f32>>,
    memory: Vec<Vec<f32>>,
    scratch: Vec<S>,
}

impl<C: Recurrent> Stack<C> {
    /// Builds `layers` (at least 1) layers of `hidden` units over `inputs` input features:
    /// `layer(k, width)` loads layer `k` reading `width` features (`inputs` for layer 0, `hidden`
    /// above it).
    pub fn load<E>(
        layers: usize,
        inputs: usize,
        hidden: usize,
        mut layer: impl FnMut(usize, usize) -> Result<C, E>,
    ) -> Result<Self, E> {
        let layers = (0..layers.max(1))
            .map(|k| layer(k, if k == 0 { inputs } else { hidden }))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self { layers })
    }

    /// The layers, bottom first.
    pub fn layers(&self) -> &[C] {
        &self.layers
    }

    /// Hidden units of every layer.
    pub fn hidden(&self) -> usize {
        self.layers[0].hidden()
    }

    /// Number of trainable parameters of all layers.
    pub fn parameter_count(&self) -> usize {
        self.layers.iter().map(C::parameter_count).sum()
    }

    /// Zeroed state for up to `capacity` rows.
    pub fn new_state(&self, capacity: usize) -> StackState<C::Scratch> {
        let width = capacity * self.hidden();
        let memory = if C::MEMORY { width } else { 0 };
        StackState {
            hidden: self.layers.iter().map(|_| vec![0.0; width]).collect(),
            memory: self.layers.iter().map(|_| vec![0.0; memory]).collect(),
            scratch: self.layers.iter().map(|l| l.scratch(capacity)).collect(),
        }
    }

    /// Zeroes the hidden state and memory of the first `batch` rows.
    pub fn reset(&self, state: &mut StackState<C::Scratch>, batch: usize) {
        let n = batch * self.hidden();
        for layer in &mut state.hidden {
            layer[..n].fill(0.0);
        }
        for layer in &mut state.memory {
            let n = n.min(layer.len());
            layer[..n].fill(0.0);
        }
    }

    /// One step of every layer for `batch` rows of `x [batch, inputs]`; returns the top layer's
    /// new hidden state `[batch, hidden]`.
    pub fn step<'s>(
        &self,
        state: &'s mut StackState<C::Scratch>,
        x: &[f32],
        batch: usize,
    ) -> &'s [f32] {
        let n = batch * self.hidden();
        let memory_rows = if C::MEMORY { n } else { 0 };
        for (k, cell) in self.layers.iter().enumerate() {
            let (below, rest) = state.hidden.split_at_mut(k);
            let input: &[f32] = if k == 0 { x } else { &below[k - 1][..n] };
            cell.step(
                input,
                &mut rest[0],
                &mut state.memory[k][..memory_rows],
                batch,
                &mut state.scratch[k],
            );
        }
        Self::top(state, batch, self.hidden())
    }

    fn top(state: &StackState<C::Scratch>, batch: usize, hidden: usize) -> &[f32] {
        let top = state.hidden.last().expect("a stack has at least one layer");
        &top[..batch * hidden]
    }
}

impl Stack<GruCell> {
    /// `layers` GRU layers `{prefix}.{k}` of `hidden` units over `inputs` features.
    pub fn load_gru(
        store: &WeightStore,
        prefix: &str,
        layers: usize,
        inputs: usize,
        hidden: usize,
        convention: GruConvention,
    ) -> Result<Self, WeightsError> {
        Self::load(layers, inputs, hidden, |k, inputs| {
            let config = GruConfig {
                inputs,
                hidden,
                convention,
            };
            GruCell::load(store, &format!("{prefix}.{k}"), config)
        })
    }
}

impl Stack<LstmCell> {
    /// `layers` LSTM layers `{prefix}.{k}` of `hidden` units over `inputs` features.
    pub fn load_lstm(
        store: &WeightStore,
        prefix: &str,
        layers: usize,
        inputs: usize,
        hidden: usize,
    ) -> Result<Self, WeightsError> {
        Self::load(layers, inputs, hidden, |k, inputs| {
            LstmCell::load(
                store,
                &format!("{prefix}.{k}"),
                LstmConfig { inputs, hidden },
            )
        })
    }
}

impl<S> StackState<S> {
    /// Every layer's hidden state `[capacity, hidden]`, bottom first (to set an initial state).
    pub fn hidden_mut(&mut self) -> &mut [Vec<f32>] {
        &mut self.hidden
    }

    /// The top layer's hidden state, every row the state holds.
    pub fn top(&self) -> &[f32] {
        self.hidden.last().expect("a stack has at least one layer")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::weights::serialize_f32;
    use std::collections::BTreeMap;

    /// Weights of the given shapes with values spread over [-0.5, 0.5).
    fn store(shapes: &[(String, Vec<usize>)]) -> WeightStore {
        let values: Vec<Vec<f32>> = shapes
            .iter()
            .enumerate()
            .map(|(t, (_, shape))| {
                let n: usize = shape.iter().product();
                (0..n)
                    .map(|i| ((i * 37 + t * 11) % 101) as f32 / 101.0 - 0.5)
                    .collect()
            })
            .collect();
        let tensors = shapes
            .iter()
            .zip(&values)
            .map(|((name, shape), v)| (name.as_str(), shape.as_slice(), v.as_slice()));
        let bytes = serialize_f32(tensors, &BTreeMap::new());
        WeightStore::from_bytes(&bytes, "stack test").unwrap()
    }

    /// The stack equals the layers run one after another by hand, for GRU and LSTM cells.
    #[test]
    fn a_stack_is_its_layers_in_sequence() {
        let (inputs, hidden, layers, batch) = (5, 4, 3, 2);
        let mut shapes = Vec::new();
        for k in 0..layers {
            let width = if k == 0 { inputs } else { hidden };
            for (gates, kind) in [(3, "gru"), (4, "lstm")] {
                shapes.push((format!("{kind}.{k}.weight_ih"), vec![gates * hidden, width]));
                shapes.push((
                    format!("{kind}.{k}.weight_hh"),
                    vec![gates * hidden, hidden],
                ));
                shapes.push((format!("{kind}.{k}.bias_ih"), vec![gates * hidden]));
                shapes.push((format!("{kind}.{k}.bias_hh"), vec![gates * hidden]));
            }
        }
        let store = store(&shapes);
        let gru = Stack::load_gru(
            &store,
            "gru",
            layers,
            inputs,
            hidden,
            GruConvention::PyTorch,
        )
        .unwrap();
        let lstm = Stack::load_lstm(&store, "lstm", layers, inputs, hidden).unwrap();
        let xs: Vec<Vec<f32>> = (0..3)
            .map(|t| {
                (0..batch * inputs)
                    .map(|i| ((i * 7 + t * 3) % 11) as f32 / 5.0 - 1.0)
                    .collect()
            })
            .collect();
        check(&gru, &xs, batch);
        check(&lstm, &xs, batch);
        assert_eq!(
            gru.parameter_count(),
            gru.layers()
                .iter()
                .map(GruCell::parameter_count)
                .sum::<usize>()
        );
    }

    fn check<C: Recurrent>(stack: &Stack<C>, xs: &[Vec<f32>], batch: usize) {
        let hidden = stack.hidden();
        let mut state = stack.new_state(batch);
        let mut h = vec![vec![0.0f32; batch * hidden]; stack.layers().len()];
        let mut m = vec![vec![0.0f32; batch * hidden]; stack.layers().len()];
        let mut scratch: Vec<_> = stack.layers().iter().map(|l| l.scratch(batch)).collect();
        for x in xs {
            let top = stack.step(&mut state, x, batch).to_vec();
            let mut input = x.clone();
            for (k, layer) in stack.layers().iter().enumerate() {
                let memory = if C::MEMORY {
                    &mut m[k][..]
                } else {
                    &mut [][..]
                };
                layer.step(&input, &mut h[k], memory, batch, &mut scratch[k]);
                input = h[k].clone();
            }
            assert_eq!(top, input);
        }
        stack.reset(&mut state, batch);
        assert!(state.top().iter().all(|&v| v == 0.0));
    }
}
