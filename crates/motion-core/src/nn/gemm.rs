//! The one matrix product every layer uses: `Y = X Wᵀ` for a weight `W [out, in]` (the PyTorch
//! layout) held as a [`PackedMatrix`] and a batch of input rows `X [batch, in]`.
//!
//! Two paths, chosen by batch size:
//! - **Row kernels** (batch 1 up to [`row_kernel_max_batch`]): weight rows are the outer loop and each
//!   is read once for all batch rows, in its stored dtype (f32, f16 or bf16, widened in
//!   registers). A batch-1 step is bound by how fast weights stream from cache, so reading each
//!   once, and half-size when the file is half-size, is what matters. The kernels of the
//!   selected [`super::simd::SimdPath`]: `kernels::avx512` (AVX-512), `kernels::avx2` (AVX2 + FMA +
//!   F16C), `kernels::neon` (aarch64), or the portable loop. No heap memory. With
//!   AVX-512 or AVX2 (portable: at batch 1) and a matrix of at least 256 KiB, a product called from a rayon pool thread splits
//!   its output rows over the pool (`rayon::join`, no allocation): one core streams weights from
//!   L3 at about 25 GB/s on the 2-core Intel Xeon we measure on, two cores together at about
//!   32-43 GB/s. Called from elsewhere it stays on the calling thread (see
//!   [`crate::model::BatchGenerator::set_row_split`]).
//! - **GEMM** (larger batches): with AVX-512 or AVX2, [`sgemm_panels::gemm_panels`] over the weights
//!   packed into column panels at load; otherwise `matrixmultiply::sgemm` over the f32 rows (its
//!   packing buffers are its own business), split over rayon threads by rows of `X` when the
//!   product is big enough to pay for the fork.
//!
//! For a given machine and path every result is deterministic.
use super::packed::{PackedMatrix, RowDtype, Wide};
use super::sgemm_panels;
use super::simd::SimdPath;

pub use super::layout::MatMul;

/// Largest batch the row kernels take for `w`; larger batches go to the GEMM.
///
/// Chosen by measurement on Zen 5 (`cargo bench --bench motion -- nn/product`, and the same
/// products timed interleaved): against the AVX-512 panel GEMM, f32 rows tie at batch 1 (both
/// read 4 bytes a weight) and lose above; f16/bf16 rows read half the bytes and win up to batch 4
/// on the step's `[1536, 512]` products. `matrixmultiply` re-packs the weight on every call, so
/// without panels the row kernels win up to batch 16 at least; so do the AVX2 row kernels against
/// the AVX2 panel GEMM (the shipped VGRU-d at batch 8: 291 µs with the GEMM from batch 5, on a Zen
/// 4/5 EPYC).
pub fn row_kernel_max_batch(w: &PackedMatrix) -> usize {
    match (super::simd::active(), w.wide(), w.dtype()) {
        (SimdPath::Avx512, Wide::Panels(_), RowDtype::F32) => 1,
        (SimdPath::Avx512, Wide::Panels(_), _) => 4,
        _ => 16,
    }
}

/// Row-kernel products over fewer weight bytes than this stay on one thread (a fork-join costs
/// a few µs; a 256 KiB matrix streams in about 10 µs at one core's L3 bandwidth).
const ROW_SPLIT_MIN_BYTES: usize = 256 << 10;
/// Fewest output rows per thread of a split row-kernel product.
const ROW_SPLIT_MIN_OUTPUTS: usize = 64;

/// Where a row-split product over `parts` threads cuts its output range: the first `left` parts
/// take `outputs.start..at`, cut at a multiple of 16 columns (whole cache lines of f32 outputs per
/// row); returns `(left, at)`.
fn split_point(outputs: &std::ops::Range<usize>, parts: usize) -> (usize, usize) {
    let left = parts / 2;
    let at = (outputs.start + outputs.len() * left / parts).next_multiple_of(16);
    (left, at.min(outputs.end))
}

/// Below this many multiply-adds a product is not split across threads.
const PARALLEL_MIN_WORK: usize = 1 << 21;
/// Minimum rows per thread when splitting.
const PARALLEL_MIN_ROWS: usize = 16;

impl MatMul {
    /// `Y = X Wᵀ` (`accumulate = false`) or `Y += X Wᵀ` (`accumulate = true`), by the path
    /// the batch size picks (see the module doc).
    ///
    /// Panics if `w` is not `[outputs, inputs]` or a slice is too short for the layout (a
    /// programming error, not bad input).
    pub fn run(&self, x: &[f32], w: &PackedMatrix, y: &mut [f32], accumulate: bool) {
        if self.batch <= row_kernel_max_batch(w) {
            self.run_rows(x, w, y, accumulate);
        } else {
            self.run_gemm(x, w, y, accumulate);
        }
    }

    /// `Y = X Wᵀ + bias` (the same `bias [outputs]` added to every row), by the path the batch
    /// size picks. The panel GEMM adds the bias as it stores its sums; the other paths write the
    /// bias into `Y` and accumulate. Panics as [`MatMul::run`] does, and if `bias` is shorter
    /// than `outputs`.
    pub fn run_bias(&self, x: &[f32], w: &PackedMatrix, bias: &[f32], y: &mut [f32]) {
        assert!(bias.len() >= self.outputs, "bias too short");
        if self.batch > row_kernel_max_batch(w) && self.check(x, w, y) {
            if let Wide::Panels(panels) = w.wide() {
                let init = sgemm_panels::Init::Bias(bias);
                let (b, xs, ys) = (self.batch, self.x_stride, self.y_stride);
                sgemm_panels::gemm_panels(b, x, xs, panels, y, ys, init);
                return;
            }
        }
        for b in 0..self.batch {
            let row = &mut y[b * self.y_stride..b * self.y_stride + self.outputs];
            row.copy_from_slice(&bias[..self.outputs]);
        }
        self.run(x, w, y, true);
    }

    /// [`MatMul::run`] through the row kernels whatever the batch (benchmarks compare paths).
    pub fn run_rows(&self, x: &[f32], w: &PackedMatrix, y: &mut [f32], accumulate: bool) {
        if !self.check(x, w, y) {
            return;
        }
        if self.inputs == 0 {
            if !accumulate {
                for b in 0..self.batch {
                    y[b * self.y_stride..b * self.y_stride + self.outputs].fill(0.0);
                }
            }
            return;
        }
        self.rows_on(super::simd::active(), x, w, y, accumulate);
    }

    /// The row kernels of `path` (the caller checked the operands and that the CPU runs `path`).
    fn rows_on(
        &self,
        path: SimdPath,
        x: &[f32],
        w: &PackedMatrix,
        y: &mut [f32],
        accumulate: bool,
    ) {
        match path {
            #[cfg(target_arch = "x86_64")]
            SimdPath::Avx512 | SimdPath::Avx2 => {
                let parts = self.row_split_parts(w);
                if parts > 1 {
                    self.rows_split(path, x, w, y, accumulate, parts);
                    return;
                }
                let product = match path {
                    SimdPath::Avx512 => super::kernels::avx512::product,
                    _ => super::kernels::avx2::product,
                };
                // SAFETY: the path is selected only on a CPU that has its features (AVX-512 F;
                // or AVX2, FMA and F16C), `inputs > 0` and `check` asserted the slice lengths.
                unsafe { product(self, x, w.rows(), y, accumulate) };
            }
            #[cfg(target_arch = "aarch64")]
            SimdPath::Neon => {
                // SAFETY: as above (NEON).
                unsafe { super::kernels::neon::product(self, x, w.rows(), y, accumulate) };
            }
            _ => {
                // Batch 1 splits like the AVX kernels above (its output ranges are disjoint
                // slices of `Y`); the portable kernel then streams weights on every core too.
                let parts = if self.batch == 1 {
                    self.row_split_parts(w)
                } else {
                    1
                };
                if parts > 1 {
                    self.portable_split(x, w, &mut y[..self.outputs], accumulate, parts);
                } else {
                    super::kernels::portable::product(self, x, w, y, accumulate);
                }
            }
        }
    }

    /// The portable row kernel at batch 1 over `parts` output ranges run by rayon (recursive
    /// halving at multiples of 16 outputs, as [`MatMul::rows_split`]); `y` is the one output row.
    fn portable_split(
        &self,
        x: &[f32],
        w: &PackedMatrix,
        y: &mut [f32],
        accumulate: bool,
        parts: usize,
    ) {
        fn split(
            mm: &MatMul,
            x: &[f32],
            w: &PackedMatrix,
            y: &mut [f32],
            accumulate: bool,
            outputs: std::ops::Range<usize>,
            parts: usize,
        ) {
            if parts <= 1 {
                super::kernels::portable::product_outputs(mm, x, w, y, accumulate, outputs);
                return;
            }
            let (left, at) = split_point(&outputs, parts);
            let (first, second) = y.split_at_mut(at - outputs.start);
            super::parallel::pool::join(
                || split(mm, x, w, first, accumulate, outputs.start..at, left),
                || split(mm, x, w, second, accumulate, at..outputs.end, parts - left),
            );
        }
        split(self, x, w, y, accumulate, 0..self.outputs, parts);
    }

    /// [`MatMul::run_rows`] on the kernels of `path` whatever the selected one (tests and
    /// benchmarks compare paths); refuses a path the CPU lacks.
    pub fn run_rows_on(
        &self,
        path: SimdPath,
        x: &[f32],
        w: &PackedMatrix,
        y: &mut [f32],
        accumulate: bool,
    ) -> Result<(), super::simd::SimdError> {
        if !path.supported() {
            return Err(super::simd::SimdError::Unsupported(path));
        }
        if !self.check(x, w, y) {
            return Ok(());
        }
        if self.inputs == 0 {
            if !accumulate {
                for b in 0..self.batch {
                    y[b * self.y_stride..b * self.y_stride + self.outputs].fill(0.0);
                }
            }
            return Ok(());
        }
        self.rows_on(path, x, w, y, accumulate);
        Ok(())
    }

    /// Into how many output ranges the row kernels split this product over threads (see the
    /// module doc): 1 below [`ROW_SPLIT_MIN_BYTES`] of weights, inside [`super::parallel::serial`],
    /// on one thread, or when not called from a rayon pool thread.
    fn row_split_parts(&self, w: &PackedMatrix) -> usize {
        let threads = super::parallel::threads();
        // Off a pool thread a join is a trip through rayon's injection queue (slow, and it
        // allocates a queue block every 63 jobs): only callers already on the pool split.
        if threads < 2
            || super::parallel::pool::current_thread_index().is_none()
            || self.outputs * self.inputs * w.dtype().size() < ROW_SPLIT_MIN_BYTES
        {
            return 1;
        }
        threads.min(self.outputs / ROW_SPLIT_MIN_OUTPUTS).max(1)
    }

    /// The row kernels over `parts` output ranges run by rayon (recursive halving; the caller's
    /// thread takes the first half of every split).
    #[cfg(target_arch = "x86_64")]
    fn rows_split(
        &self,
        path: SimdPath,
        x: &[f32],
        w: &PackedMatrix,
        y: &mut [f32],
        accumulate: bool,
        parts: usize,
    ) {
        /// `Y`'s base pointer, shared by threads that write disjoint column ranges of it.
        #[derive(Clone, Copy)]
        struct Columns(*mut f32);
        // SAFETY: each thread writes only its own column range (see `split`).
        unsafe impl Send for Columns {}
        unsafe impl Sync for Columns {}

        #[allow(clippy::too_many_arguments)]
        fn split(
            path: SimdPath,
            mm: &MatMul,
            x: &[f32],
            w: &PackedMatrix,
            y: Columns,
            accumulate: bool,
            outputs: std::ops::Range<usize>,
            parts: usize,
        ) {
            if parts <= 1 {
                // SAFETY: the caller checked that the CPU runs `path` and the layout; `outputs`
                // ranges of different calls are disjoint, so no two threads write the same
                // element.
                unsafe {
                    let product_outputs = match path {
                        SimdPath::Avx512 => super::kernels::avx512::product_outputs,
                        _ => super::kernels::avx2::product_outputs,
                    };
                    product_outputs(mm, x.as_ptr(), w.rows(), y.0, accumulate, outputs)
                };
                return;
            }
            let (left, at) = split_point(&outputs, parts);
            super::parallel::pool::join(
                || split(path, mm, x, w, y, accumulate, outputs.start..at, left),
                || split(path, mm, x, w, y, accumulate, at..outputs.end, parts - left),
            );
        }
        split(
            path,
            self,
            x,
            w,
            Columns(y.as_mut_ptr()),
            accumulate,
            0..self.outputs,
            parts,
        );
    }

    /// [`MatMul::run`] through the GEMM whatever the batch (benchmarks compare paths).
    pub fn run_gemm(&self, x: &[f32], w: &PackedMatrix, y: &mut [f32], accumulate: bool) {
        if !self.check(x, w, y) {
            return;
        }
        match (w.wide(), w.f32_rows()) {
            (Wide::Panels(panels), _) => sgemm_panels::gemm_panels(
                self.batch,
                x,
                self.x_stride,
                panels,
                y,
                self.y_stride,
                sgemm_panels::Init::from_accumulate(accumulate),
            ),
            (_, Some(rows)) => self.sgemm_threads(x, rows, y, accumulate),
            _ => unreachable!("a matrix without panels has f32 rows"),
        }
    }

    /// `matrixmultiply::sgemm`, split by rows of `X` over rayon threads when big enough.
    fn sgemm_threads(&self, x: &[f32], w: &[f32], y: &mut [f32], accumulate: bool) {
        let work = self.batch * self.inputs * self.outputs;
        let threads = super::parallel::threads();
        if threads > 1 && work >= PARALLEL_MIN_WORK && self.batch >= 2 * PARALLEL_MIN_ROWS {
            let rows = self.batch.div_ceil(threads).max(PARALLEL_MIN_ROWS);
            let this = *self;
            super::parallel::pool::scope(|s| {
                let mut y_rest = &mut y[..];
                let mut start = 0;
                while start < this.batch {
                    let n = rows.min(this.batch - start);
                    let y_len = if start + n == this.batch {
                        y_rest.len()
                    } else {
                        n * this.y_stride
                    };
                    let (y_chunk, rest) = y_rest.split_at_mut(y_len);
                    y_rest = rest;
                    let x_chunk = &x[start * this.x_stride..];
                    let part = MatMul { batch: n, ..this };
                    s.spawn(move |_| part.sgemm(x_chunk, w, y_chunk, accumulate));
                    start += n;
                }
            });
        } else {
            self.sgemm(x, w, y, accumulate);
        }
    }

    /// Asserts the operands fit the layout; false when there is nothing to compute.
    fn check(&self, x: &[f32], w: &PackedMatrix, y: &[f32]) -> bool {
        assert_eq!(
            (w.outputs(), w.inputs()),
            (self.outputs, self.inputs),
            "weight shape"
        );
        if self.batch == 0 || self.outputs == 0 {
            return false;
        }
        assert!(
            self.x_stride >= self.inputs && self.y_stride >= self.outputs,
            "row strides"
        );
        assert!(
            x.len() >= (self.batch - 1) * self.x_stride + self.inputs,
            "input too short"
        );
        assert!(
            y.len() >= (self.batch - 1) * self.y_stride + self.outputs,
            "output too short"
        );
        true
    }

    fn sgemm(&self, x: &[f32], w: &[f32], y: &mut [f32], accumulate: bool) {
        let beta = if accumulate { 1.0 } else { 0.0 };
        // SAFETY: the asserts in `run` (and the chunking there) guarantee that every element the
        // strides address lies inside `x`, `w` and `y`; `y` is exclusively borrowed.
        unsafe {
            matrixmultiply::sgemm(
                self.batch,
                self.inputs,
                self.outputs,
                1.0,
                x.as_ptr(),
                self.x_stride as isize,
                1,
                // Wᵀ as a [in, out] matrix: element (i, o) is w[o * in + i].
                w.as_ptr(),
                1,
                self.inputs as isize,
                beta,
                y.as_mut_ptr(),
                self.y_stride as isize,
                1,
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::weights::HalfDtype;

    /// Deterministic values in [-1, 1) from a fixed-seed xorshift generator.
    fn data(n: usize, seed: u64) -> Vec<f32> {
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

    /// The matrix in each stored dtype (f16/bf16 rounded from `values`).
    fn matrices(values: &[f32], outputs: usize, inputs: usize) -> Vec<PackedMatrix> {
        let bf16 = values
            .iter()
            .map(|&v| half::bf16::from_f32(v).to_bits())
            .collect();
        let loaded = vec![
            PackedMatrix::from_f32(values.to_vec(), outputs, inputs),
            PackedMatrix::f16_from_f32(values, outputs, inputs),
            PackedMatrix::from_half_bits(HalfDtype::Bf16, bf16, outputs, inputs),
        ];
        // Both layouts whatever the path the tests run under (panels or f32 copies).
        let other: Vec<PackedMatrix> = loaded
            .iter()
            .cloned()
            .map(PackedMatrix::without_panels)
            .collect();
        loaded.into_iter().chain(other).collect()
    }

    /// Checks `y` (row stride `ys`) against `init + X Wᵀ` in f64 with the widened weights; the
    /// bound scales with `Σ|x w|` (f32 accumulation of `inputs` terms).
    #[allow(clippy::too_many_arguments)]
    fn assert_product(
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
            // Columns past `outputs` of a strided row are never written.
            for k in b * mm.y_stride + mm.outputs..((b + 1) * mm.y_stride).min(y.len()) {
                assert_eq!(y[k], init[k], "{what}: wrote past the row");
            }
        }
    }

    /// Shapes with ragged input widths (masked tails), row counts off the 4-row tiles and batches
    /// off the 4-row batch tiles.
    const SHAPES: &[(usize, usize)] = &[
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

    /// A product under a name.
    type Path = (
        String,
        Box<dyn Fn(&MatMul, &[f32], &PackedMatrix, &mut [f32], bool)>,
    );

    /// Every product the machine has: the dispatch, the GEMMs, and the row kernels of every
    /// SIMD path this CPU runs (each selected explicitly, whatever `MOTION_SIMD` says).
    fn paths() -> Vec<Path> {
        let mut p: Vec<Path> = vec![
            (
                "dispatch".into(),
                Box::new(|m, x, w, y, a| m.run(x, w, y, a)),
            ),
            (
                "rows".into(),
                Box::new(|m, x, w, y, a| m.run_rows(x, w, y, a)),
            ),
            (
                "gemm".into(),
                Box::new(|m, x, w, y, a| m.run_gemm(x, w, y, a)),
            ),
            (
                "matrixmultiply".into(),
                Box::new(|m, x, w, y, a| m.sgemm_threads(x, &w.to_f32(), y, a)),
            ),
        ];
        for path in SimdPath::available() {
            p.push((
                format!("rows {path}"),
                Box::new(move |m, x, w, y, a| m.run_rows_on(path, x, w, y, a).unwrap()),
            ));
        }
        p
    }

    #[test]
    fn portable_f16_widening_is_exact_for_every_bit_pattern() {
        for h in 0..=u16::MAX {
            let want = half::f16::from_bits(h).to_f32();
            let got = super::super::kernels::portable::f16_to_f32(h);
            if want.is_nan() {
                assert!(got.is_nan(), "{h:#06x}");
                assert_eq!(got.to_bits() & 0x8000_0000, want.to_bits() & 0x8000_0000);
            } else {
                assert_eq!(got.to_bits(), want.to_bits(), "{h:#06x}");
            }
        }
    }

    #[test]
    fn every_available_simd_path_is_tested() {
        let names: Vec<String> = paths().into_iter().map(|(n, _)| n).collect();
        assert!(names.contains(&"rows portable".to_string()));
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("fma")
            && std::arch::is_x86_feature_detected!("f16c")
        {
            assert!(names.contains(&"rows avx2".to_string()));
        }
        #[cfg(target_arch = "aarch64")]
        assert!(names.contains(&"rows neon".to_string()));
        let lacking = SimdPath::ALL.into_iter().find(|p| !p.supported()).unwrap();
        let w = PackedMatrix::from_f32(vec![1.0; 4], 2, 2);
        let mut y = [0.0; 2];
        assert!(MatMul::dense(1, 2, 2)
            .run_rows_on(lacking, &[1.0, 2.0], &w, &mut y, false)
            .is_err());
    }

    #[test]
    fn every_kernel_and_dtype_matches_f64_reference() {
        let paths = paths();
        for (seed, &(inputs, outputs)) in SHAPES.iter().enumerate() {
            let values = data(outputs * inputs, 2 * seed as u64 + 1);
            for w in matrices(&values, outputs, inputs) {
                for batch in [1, 2, 3, 4, 5, 8, 13, 16, 17] {
                    let x = data(batch * inputs, 100 + seed as u64);
                    let mm = MatMul::dense(batch, inputs, outputs);
                    let init = data(batch * outputs, 7);
                    for (name, product) in &paths {
                        let name = name.as_str();
                        for accumulate in [false, true] {
                            let mut y = init.clone();
                            product(&mm, &x, &w, &mut y, accumulate);
                            assert_product(name, &mm, &x, &w, &init, &y, accumulate);
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn run_bias_adds_the_bias_row_on_every_path() {
        // Batches on the row kernels and on the GEMM (panels, or matrixmultiply without them),
        // strided rows whose gaps must stay as they were.
        for (seed, &(inputs, outputs)) in [(37, 11), (512, 54), (100, 300)].iter().enumerate() {
            let values = data(outputs * inputs, 40 + seed as u64);
            let bias = data(outputs, 50 + seed as u64);
            for w in matrices(&values, outputs, inputs) {
                for batch in [1, 5, 17, 64] {
                    let mm = MatMul::dense(batch, inputs, outputs).strided(inputs + 3, outputs + 2);
                    let x = data(batch * (inputs + 3), 60 + seed as u64);
                    let mut init = data(batch * (outputs + 2), 70);
                    let mut y = init.clone();
                    mm.run_bias(&x, &w, &bias, &mut y);
                    for row in init.chunks_exact_mut(outputs + 2) {
                        row[..outputs].copy_from_slice(&bias);
                    }
                    assert_product("run_bias", &mm, &x, &w, &init, &y, true);
                }
            }
        }
    }

    #[test]
    fn strided_rows_leave_the_gaps_alone() {
        let (inputs, outputs) = (37, 7);
        let values = data(outputs * inputs, 3);
        for w in matrices(&values, outputs, inputs) {
            for batch in [1, 3, 6, 20] {
                let mm = MatMul::dense(batch, inputs, outputs).strided(inputs + 5, outputs + 3);
                let x = data(batch * (inputs + 5), 4);
                let init = data(batch * (outputs + 3), 5);
                for (name, product) in paths() {
                    let name = name.as_str();
                    let mut y = init.clone();
                    product(&mm, &x, &w, &mut y, true);
                    assert_product(name, &mm, &x, &w, &init, &y, true);
                }
            }
        }
    }

    #[test]
    fn zero_inputs_clear_or_keep_the_output() {
        let w = PackedMatrix::from_f32(Vec::new(), 4, 0);
        for batch in [1, 40] {
            let mut y = vec![1.0; batch * 4];
            MatMul::dense(batch, 0, 4).run(&[], &w, &mut y, true);
            assert!(y.iter().all(|&v| v == 1.0));
            MatMul::dense(batch, 0, 4).run(&[], &w, &mut y, false);
            assert!(y.iter().all(|&v| v == 0.0));
        }
    }

    #[test]
    fn a_row_sums_the_same_in_any_batch_or_tile() {
        // The row kernels give every (batch row, output) the same arithmetic, so a character's
        // step does not depend on the batch it runs in or the tile its output falls in (13
        // outputs: 8-, 4-, 3- and 1-row tiles; 2, 3, 5 and 11 batch rows: pairs, groups of four
        // and their tails).
        let (inputs, outputs) = (216, 13);
        let values = data(outputs * inputs, 9);
        for path in SimdPath::available() {
            for (w, batch) in matrices(&values, outputs, inputs)
                .into_iter()
                .flat_map(|w| [2, 3, 5, 11].map(|batch| (w.clone(), batch)))
            {
                let x = data(batch * inputs, 10);
                let mut all = vec![0.0; batch * outputs];
                MatMul::dense(batch, inputs, outputs)
                    .run_rows_on(path, &x, &w, &mut all, false)
                    .unwrap();
                for b in 0..batch {
                    let mut one = vec![0.0; outputs];
                    MatMul::dense(1, inputs, outputs)
                        .run_rows_on(path, &x[b * inputs..], &w, &mut one, false)
                        .unwrap();
                    assert_eq!(one, all[b * outputs..(b + 1) * outputs], "{path}");
                }
            }
        }
    }

    #[test]
    fn rows_wider_than_the_widening_buffer_match_f64_reference() {
        // The portable 16-bit kernel widens up to 8,192 inputs at a time; wider rows take the
        // one-row fallback.
        let (inputs, outputs, batch) = (8_203, 3, 2);
        let values = data(outputs * inputs, 11);
        let x = data(batch * inputs, 12);
        let init = data(batch * outputs, 13);
        let mm = MatMul::dense(batch, inputs, outputs);
        for path in SimdPath::available() {
            for w in matrices(&values, outputs, inputs) {
                for accumulate in [false, true] {
                    let mut y = init.clone();
                    mm.run_rows_on(path, &x, &w, &mut y, accumulate).unwrap();
                    assert_product(&format!("rows {path}"), &mm, &x, &w, &init, &y, accumulate);
                }
            }
        }
    }
}
