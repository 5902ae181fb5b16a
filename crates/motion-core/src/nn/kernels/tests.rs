//! The kernels of every SIMD path against f64 references: `kernel_tests!(name, path)` expands
//! the same tests for each path (the row kernels here, the panel GEMM of
//! [`crate::nn::sgemm_panels`], the gate updates of [`crate::nn::gates`]), whatever path
//! `MOTION_SIMD` selects. On a CPU without the path each test prints
//! `SKIPPED: <path> not supported by this CPU` and passes.
//!
//! Generated, per path (`portable::rows_match_f64_reference`, `avx2::...`, `avx512::...`,
//! `neon::...`):
//! - `rows_match_f64_reference`: every shape of [`SHAPES`] (ragged input widths, output counts
//!   off the tiles), f32, f16 and bf16 rows in both load layouts, batches 1 to [`MAX_BATCH`],
//!   accumulate off and on;
//! - `rows_leave_strided_gaps_alone`: padded row strides of `X` and `Y`;
//! - `rows_by_output_range_match_the_whole_product`: a product computed in output ranges (as the
//!   thread split runs it) gives the whole product's bits;
//! - `rows_sum_the_same_in_any_batch_or_tile`: a batch row's result does not depend on the batch;
//! - `rows_wider_than_the_widening_buffer_match_f64_reference`: rows of 8,203 inputs;
//! - `panels_match_f64_reference_on_model_shapes` and `..._on_ragged_shapes`: the panel GEMM on
//!   the paper models' products and on ragged shapes, strides and every `Init`;
//! - `gates_match_f64_reference`: the three GRU gate updates, batches 1 to 9 and 70, hidden
//!   sizes off the vector widths.
//!
//! The helpers ([`data`], [`matrices`], [`assert_product`], [`SHAPES`]) also serve the product
//! tests of [`crate::nn::gemm`].
use crate::nn::layout::MatMul;
use crate::nn::packed::PackedMatrix;
use crate::nn::simd::SimdPath;
use crate::nn::{gates, sgemm_panels};
use crate::weights::HalfDtype;

/// Deterministic values in [-1, 1) from a fixed-seed xorshift generator.
pub(crate) fn data(n: usize, seed: u64) -> Vec<f32> {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 23) as f32 - 1.0
        })
        .collect()
}

/// The matrix in each stored dtype (f16/bf16 rounded from `values`), each in both load layouts
/// (with column panels and without, whatever the path the tests run under).
pub(crate) fn matrices(values: &[f32], outputs: usize, inputs: usize) -> Vec<PackedMatrix> {
    let bf16 = values
        .iter()
        .map(|&v| half::bf16::from_f32(v).to_bits())
        .collect();
    let loaded = vec![
        PackedMatrix::from_f32(values.to_vec(), outputs, inputs),
        PackedMatrix::f16_from_f32(values, outputs, inputs),
        PackedMatrix::from_half_bits(HalfDtype::Bf16, bf16, outputs, inputs),
    ];
    let other: Vec<PackedMatrix> = loaded
        .iter()
        .cloned()
        .map(PackedMatrix::without_panels)
        .collect();
    loaded.into_iter().chain(other).collect()
}

/// Checks `y` (row stride `mm.y_stride`) against `init + X Wᵀ` (or `X Wᵀ`) in f64 with the
/// widened weights; the bound scales with `Σ|x w|` (f32 accumulation of `inputs` terms). Columns
/// past `outputs` must still hold `init`.
pub(crate) fn assert_product(
    what: &str,
    mm: &MatMul,
    x: &[f32],
    w: &PackedMatrix,
    init: &[f32],
    y: &[f32],
    accumulate: bool,
) {
    let wf = w.to_f32();
    for b in 0..mm.batch {
        for o in 0..mm.outputs {
            let (mut dot, mut mag) = (0.0f64, 0.0f64);
            for i in 0..mm.inputs {
                let t = f64::from(x[b * mm.x_stride + i]) * f64::from(wf[o * mm.inputs + i]);
                dot += t;
                mag += t.abs();
            }
            let k = b * mm.y_stride + o;
            let expect = if accumulate {
                f64::from(init[k]) + dot
            } else {
                dot
            };
            let got = f64::from(y[k]);
            let bound = 1e-6 * (mag + f64::from(init[k]).abs()) + 1e-7;
            assert!(
                (got - expect).abs() <= bound,
                "{what} {:?} batch {} in {} out {} acc {accumulate}: y[{b},{o}] = {got} vs {expect}",
                w.dtype(),
                mm.batch,
                mm.inputs,
                mm.outputs
            );
        }
        for k in b * mm.y_stride + mm.outputs..((b + 1) * mm.y_stride).min(y.len()) {
            assert_eq!(y[k], init[k], "{what}: wrote past the row");
        }
    }
}

/// `(inputs, outputs)`: ragged input widths (every remainder of the 4-, 8- and 16-lane vectors),
/// output counts off every path's row tiles.
pub(crate) const SHAPES: &[(usize, usize)] = &[
    (1, 1),
    (5, 3),
    (16, 4),
    (17, 9),
    (37, 11),
    (54, 1536),
    (216, 13),
    (512, 54),
    (100, 300),
];

/// Largest batch the row-kernel tests run: one past the largest the products give the row
/// kernels ([`crate::nn::gemm::row_kernel_max_batch`]).
const MAX_BATCH: usize = 17;

/// Whether this CPU runs `path`; says SKIPPED when it does not.
fn runs(path: SimdPath) -> bool {
    let supported = path.supported();
    if !supported {
        println!("SKIPPED: {} not supported by this CPU", path.name());
    }
    supported
}

/// `Y (+)= X Wᵀ` for the outputs `outputs` on the row kernels of `path`, the operands checked
/// here as `MatMul::run` checks them.
fn rows_on(
    path: SimdPath,
    mm: &MatMul,
    x: &[f32],
    w: &PackedMatrix,
    y: &mut [f32],
    accumulate: bool,
    outputs: std::ops::Range<usize>,
) {
    assert!(path.supported());
    assert_eq!((w.outputs(), w.inputs()), (mm.outputs, mm.inputs));
    assert!(mm.batch > 0 && mm.inputs > 0 && outputs.end <= mm.outputs);
    assert!(mm.x_stride >= mm.inputs && mm.y_stride >= mm.outputs);
    assert!(x.len() >= (mm.batch - 1) * mm.x_stride + mm.inputs);
    assert!(y.len() >= (mm.batch - 1) * mm.y_stride + mm.outputs);
    // SAFETY: the CPU runs `path` and the layout fits the slices (asserted above); `y` is
    // exclusively borrowed.
    unsafe { super::product_outputs(path, mm, x.as_ptr(), w, y.as_mut_ptr(), accumulate, outputs) }
}

fn rows_match_f64_reference(path: SimdPath) {
    let what = format!("rows {path}");
    for (seed, &(inputs, outputs)) in SHAPES.iter().enumerate() {
        let values = data(outputs * inputs, 2 * seed as u64 + 1);
        for w in matrices(&values, outputs, inputs) {
            for batch in 1..=MAX_BATCH {
                let x = data(batch * inputs, 100 + seed as u64);
                let mm = MatMul::dense(batch, inputs, outputs);
                let init = data(batch * outputs, 7);
                for accumulate in [false, true] {
                    let mut y = init.clone();
                    rows_on(path, &mm, &x, &w, &mut y, accumulate, 0..outputs);
                    assert_product(&what, &mm, &x, &w, &init, &y, accumulate);
                }
            }
        }
    }
}

fn rows_leave_strided_gaps_alone(path: SimdPath) {
    let what = format!("strided rows {path}");
    for (seed, &(inputs, outputs)) in [(37, 7), (5, 3), (216, 13)].iter().enumerate() {
        let values = data(outputs * inputs, 3 + seed as u64);
        for w in matrices(&values, outputs, inputs) {
            for batch in [1, 2, 3, 5, 6, 17] {
                let mm = MatMul::dense(batch, inputs, outputs).strided(inputs + 5, outputs + 3);
                let x = data(batch * (inputs + 5), 4);
                let init = data(batch * (outputs + 3), 5);
                for accumulate in [false, true] {
                    let mut y = init.clone();
                    rows_on(path, &mm, &x, &w, &mut y, accumulate, 0..outputs);
                    assert_product(&what, &mm, &x, &w, &init, &y, accumulate);
                }
            }
        }
    }
}

fn rows_by_output_range_match_the_whole_product(path: SimdPath) {
    // Ranges that start and end off every tile boundary, on padded rows of `Y`.
    let (inputs, outputs) = (216, 13);
    let values = data(outputs * inputs, 31);
    for w in matrices(&values, outputs, inputs) {
        for batch in [1, 2, 3, 4, 5, 11] {
            let mm = MatMul::dense(batch, inputs, outputs).strided(inputs, outputs + 2);
            let x = data(batch * inputs, 32);
            let init = data(batch * (outputs + 2), 33);
            for accumulate in [false, true] {
                let mut whole = init.clone();
                rows_on(path, &mm, &x, &w, &mut whole, accumulate, 0..outputs);
                let mut parts = init.clone();
                for range in [0..5, 5..6, 6..13] {
                    rows_on(path, &mm, &x, &w, &mut parts, accumulate, range);
                }
                assert_eq!(whole, parts, "{path} {:?} batch {batch}", w.dtype());
            }
        }
    }
}

fn rows_sum_the_same_in_any_batch_or_tile(path: SimdPath) {
    // Every (batch row, output) gets the same arithmetic, so a character's step does not depend
    // on the batch it runs in or the tile its output falls in (13 outputs: 8-, 4-, 3- and 1-row
    // tiles; 2, 3, 5 and 11 batch rows: pairs, groups of four and their tails).
    let (inputs, outputs) = (216, 13);
    let values = data(outputs * inputs, 9);
    for w in matrices(&values, outputs, inputs) {
        for batch in [2, 3, 5, 11] {
            let x = data(batch * inputs, 10);
            let mut all = vec![0.0; batch * outputs];
            let mm = MatMul::dense(batch, inputs, outputs);
            rows_on(path, &mm, &x, &w, &mut all, false, 0..outputs);
            for b in 0..batch {
                let mut one = vec![0.0; outputs];
                let mm = MatMul::dense(1, inputs, outputs);
                rows_on(path, &mm, &x[b * inputs..], &w, &mut one, false, 0..outputs);
                assert_eq!(one, all[b * outputs..(b + 1) * outputs], "{path}");
            }
        }
    }
}

fn rows_wider_than_the_widening_buffer_match_f64_reference(path: SimdPath) {
    // The portable 16-bit kernel widens up to 8,192 inputs at a time; wider rows take the
    // one-row fallback.
    let (inputs, outputs, batch) = (8_203, 3, 2);
    let values = data(outputs * inputs, 11);
    let x = data(batch * inputs, 12);
    let init = data(batch * outputs, 13);
    let mm = MatMul::dense(batch, inputs, outputs);
    for w in matrices(&values, outputs, inputs) {
        for accumulate in [false, true] {
            let mut y = init.clone();
            rows_on(path, &mm, &x, &w, &mut y, accumulate, 0..outputs);
            assert_product(&format!("rows {path}"), &mm, &x, &w, &init, &y, accumulate);
        }
    }
}

fn panels_match_f64_reference_on_model_shapes(path: SimdPath) {
    sgemm_panels::tests::model_shapes(Some(path));
}

fn panels_match_f64_reference_on_ragged_shapes(path: SimdPath) {
    sgemm_panels::tests::ragged_shapes(Some(path));
}

fn gates_match_f64_reference(path: SimdPath) {
    for batch in 1..=9 {
        for hidden in [1, 3, 7, 8, 16, 17, 33, 64] {
            gates::tests::check_updates(Some(path), batch, hidden);
        }
    }
    // Above the parallel threshold: the rows split over the pool.
    gates::tests::check_updates(Some(path), 70, 520);
}

/// `kernel_tests!(name, path)`: a module `name` with one `#[test]` per check above, run on
/// `path` (see the module doc).
macro_rules! kernel_tests {
    (@each $($check:ident)*) => {
        $(
            #[test]
            fn $check() {
                if super::runs(PATH) {
                    super::$check(PATH);
                }
            }
        )*
    };
    ($name:ident, $path:expr) => {
        mod $name {
            use crate::nn::simd::SimdPath;

            /// The path these tests run on.
            pub(super) const PATH: SimdPath = $path;

            kernel_tests!(@each
                rows_match_f64_reference
                rows_leave_strided_gaps_alone
                rows_by_output_range_match_the_whole_product
                rows_sum_the_same_in_any_batch_or_tile
                rows_wider_than_the_widening_buffer_match_f64_reference
                panels_match_f64_reference_on_model_shapes
                panels_match_f64_reference_on_ragged_shapes
                gates_match_f64_reference
            );
        }
    };
}

kernel_tests!(portable, SimdPath::Portable);
kernel_tests!(avx2, SimdPath::Avx2);
kernel_tests!(avx512, SimdPath::Avx512);
kernel_tests!(neon, SimdPath::Neon);

/// A path added to [`SimdPath`] without its `kernel_tests!` line fails to compile here.
#[test]
fn every_path_has_its_tests() {
    for path in SimdPath::ALL {
        let tested = match path {
            SimdPath::Avx512 => avx512::PATH,
            SimdPath::Avx2 => avx2::PATH,
            SimdPath::Neon => neon::PATH,
            SimdPath::Portable => portable::PATH,
        };
        assert_eq!(tested, path);
    }
    assert!(SimdPath::available().contains(&SimdPath::Portable));
}
