//! The one matrix product every layer uses: `Y = X Wᵀ` for a weight `W [out, in]` (the PyTorch
//! layout) held as a [`PackedMatrix`] and a batch of input rows `X [batch, in]`.
//!
//! Two paths, chosen by batch size:
//! - **Row kernels** (batch 1 up to [`row_kernel_max_batch`]): weight rows are the outer loop and each
//!   is read once for all batch rows, in its stored dtype (f32, f16 or bf16, widened in
//!   registers). A batch-1 step is bound by how fast weights stream from cache, so reading each
//!   once, and half-size when the file is half-size, is what matters. The kernels of the
//!   selected [`super::simd::SimdPath`], from `nn::kernels`: `avx512` (AVX-512), `avx2` (AVX2 +
//!   FMA + F16C), `neon` (aarch64), or `portable`. No heap memory. With AVX-512 or AVX2
//!   (portable: at batch 1) and a matrix of at least 256 KiB, a product called from a rayon pool
//!   thread splits its output rows over the pool (`rayon::join`, no allocation): one core
//!   streams weights from L3 at about 25 GB/s on the 2-core Intel Xeon we measure on, two cores
//!   together at about 32-43 GB/s. Called from elsewhere it stays on the calling thread (see
//!   [`crate::model::BatchGenerator::set_row_split`]), unless the caller asked for the crew
//!   ([`super::parallel::crew_products`]): then a product of at least 256 KiB of weights is
//!   split in two output ranges, one on the calling thread and one on the crew's spinning helper,
//!   the same halves every call (each core keeps its half of the weights in its own cache). The
//!   panel GEMM splits the same way, by whole panels.
//! - **GEMM** (larger batches): with AVX-512 or AVX2, [`sgemm_panels::gemm_panels`] over the weights
//!   packed into column panels at load; otherwise `matrixmultiply::sgemm` over the f32 rows (its
//!   packing buffers are its own business), split over rayon threads by rows of `X` when the
//!   product is big enough to pay for the fork.
//!
//! For a given machine and path every result is deterministic.
use super::kernels;
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

/// `Y`'s base pointer, shared by threads that write disjoint column ranges of it.
#[derive(Clone, Copy)]
struct Columns(*mut f32);
// SAFETY: each thread writes only its own column range (the splits of `rows_split`,
// `panels_on_crew` and the crew split of `rows_on`).
unsafe impl Send for Columns {}
unsafe impl Sync for Columns {}

impl Columns {
    fn get(self) -> *mut f32 {
        self.0
    }
}

/// `X`'s base pointer, read by both parts of a crew split.
#[cfg(feature = "parallel")]
#[derive(Clone, Copy)]
struct Inputs(*const f32);
// SAFETY: `X` is only read while the split runs (the caller holds it borrowed).
#[cfg(feature = "parallel")]
unsafe impl Send for Inputs {}
#[cfg(feature = "parallel")]
unsafe impl Sync for Inputs {}

#[cfg(feature = "parallel")]
impl Inputs {
    fn get(self) -> *const f32 {
        self.0
    }
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
            if let Wide::Panels(panels) = w.wide() {
                let init = sgemm_panels::Init::from_accumulate(accumulate);
                if self.check(x, w, y) && self.panels_on_crew(x, panels, y, init) {
                    return;
                }
            }
            self.run_gemm(x, w, y, accumulate);
        }
    }

    /// The panel GEMM split by output panels between the calling thread and the crew
    /// ([`super::parallel::crew_products`]); `false` (nothing done) when the split does not
    /// apply. The caller checked the operands.
    fn panels_on_crew(
        &self,
        x: &[f32],
        panels: &sgemm_panels::PanelMatrix,
        y: &mut [f32],
        init: sgemm_panels::Init,
    ) -> bool {
        #[cfg(feature = "parallel")]
        {
            let count = self.outputs.div_ceil(sgemm_panels::PANEL_WIDTH);
            if !self.crew_split_applies(panels.size_bytes()) || count < 2 {
                return false;
            }
            let at = count / 2;
            let y = Columns(y.as_mut_ptr());
            let (b, xs, ys) = (self.batch, self.x_stride, self.y_stride);
            let path = super::simd::active();
            super::parallel::crew::run(2, &|k| {
                let range = if k == 0 { 0..at } else { at..count };
                // SAFETY: the caller checked that `x` and `y` hold every addressed row; the two
                // parts write disjoint panels' columns.
                unsafe {
                    sgemm_panels::serial_panels(path, b, x, xs, panels, y.get(), ys, init, range)
                };
            })
        }
        #[cfg(not(feature = "parallel"))]
        {
            let _ = (x, panels, y, init);
            false
        }
    }

    /// Whether a product over `bytes` of weights splits over the crew (see
    /// [`super::parallel::crew_products`]): large enough to pay for the hand-off.
    #[cfg(feature = "parallel")]
    fn crew_split_applies(&self, bytes: usize) -> bool {
        super::parallel::crew_products_enabled()
            && bytes >= ROW_SPLIT_MIN_BYTES
            && self.outputs >= 2 * ROW_SPLIT_MIN_OUTPUTS
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
                if self.panels_on_crew(x, panels, y, init) {
                    return;
                }
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

    /// The row kernels of `path` (the caller checked the operands, that `inputs > 0` and that the
    /// CPU runs `path`), over threads when [`MatMul::row_split_parts`] says so: with AVX-512 or
    /// AVX2 at any batch, on the portable path at batch 1.
    fn rows_on(
        &self,
        path: SimdPath,
        x: &[f32],
        w: &PackedMatrix,
        y: &mut [f32],
        accumulate: bool,
    ) {
        let parts = match path {
            SimdPath::Avx512 | SimdPath::Avx2 => self.row_split_parts(w),
            SimdPath::Portable if self.batch == 1 => self.row_split_parts(w),
            _ => 1,
        };
        if parts > 1 {
            self.rows_split(path, x, w, y, accumulate, parts);
            return;
        }
        #[cfg(feature = "parallel")]
        if self.crew_split_applies(self.outputs * self.inputs * w.dtype().size()) {
            let (_, at) = split_point(&(0..self.outputs), 2);
            let out = Columns(y.as_mut_ptr());
            let x_ptr = Inputs(x.as_ptr());
            let outputs = self.outputs;
            let done = super::parallel::crew::run(2, &|k| {
                let range = if k == 0 { 0..at } else { at..outputs };
                // SAFETY: as below; the two parts write disjoint output columns.
                unsafe {
                    kernels::product_outputs(
                        path,
                        self,
                        x_ptr.get(),
                        w,
                        out.get(),
                        accumulate,
                        range,
                    )
                };
            });
            if done {
                return;
            }
        }
        // SAFETY: the CPU runs `path`, `inputs > 0` and `check` asserted the slice lengths; `y`
        // is exclusively borrowed.
        unsafe {
            kernels::product_outputs(
                path,
                self,
                x.as_ptr(),
                w,
                y.as_mut_ptr(),
                accumulate,
                0..self.outputs,
            )
        };
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

    /// The row kernels over `parts` output ranges run by rayon (recursive halving at multiples of
    /// 16 outputs; the caller's thread takes the first half of every split).
    fn rows_split(
        &self,
        path: SimdPath,
        x: &[f32],
        w: &PackedMatrix,
        y: &mut [f32],
        accumulate: bool,
        parts: usize,
    ) {
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
                    kernels::product_outputs(path, mm, x.as_ptr(), w, y.get(), accumulate, outputs)
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
    use crate::nn::kernels::tests::{assert_product, data, matrices, SHAPES};

    /// A product under a name.
    type Path = (
        String,
        Box<dyn Fn(&MatMul, &[f32], &PackedMatrix, &mut [f32], bool)>,
    );

    /// The products of the selected SIMD path: the dispatch, the row kernels, the GEMMs. (The
    /// kernels of every path are tested in `nn::kernels`.)
    fn paths() -> Vec<Path> {
        vec![
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
        ]
    }

    #[test]
    fn run_rows_on_refuses_a_path_the_cpu_lacks() {
        let lacking = SimdPath::ALL.into_iter().find(|p| !p.supported()).unwrap();
        let w = PackedMatrix::from_f32(vec![1.0; 4], 2, 2);
        let mut y = [0.0; 2];
        assert!(MatMul::dense(1, 2, 2)
            .run_rows_on(lacking, &[1.0, 2.0], &w, &mut y, false)
            .is_err());
    }

    #[test]
    fn every_product_and_dtype_matches_f64_reference() {
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

    /// A row-kernel product called from a pool thread splits its outputs over the pool (AVX-512
    /// and AVX2 at any batch, portable at batch 1): the same bits as on one thread, for every
    /// path this CPU runs.
    #[cfg(feature = "parallel")]
    #[test]
    fn row_split_over_threads_gives_the_same_bits() {
        let (inputs, outputs) = (512, 300); // 600 KiB of f32 weights, 300 KiB of f16
        let values = data(outputs * inputs, 21);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .expect("thread pool");
        for path in SimdPath::available() {
            for w in matrices(&values, outputs, inputs) {
                for batch in [1, 3, 8] {
                    let mm = MatMul::dense(batch, inputs, outputs);
                    assert_eq!(pool.install(|| mm.row_split_parts(&w)), 2);
                    let x = data(batch * inputs, 22);
                    let init = data(batch * outputs, 23);
                    for accumulate in [false, true] {
                        let mut one = init.clone();
                        mm.run_rows_on(path, &x, &w, &mut one, accumulate).unwrap();
                        let mut split = init.clone();
                        pool.install(|| mm.run_rows_on(path, &x, &w, &mut split, accumulate))
                            .unwrap();
                        assert_eq!(one, split, "{path} {:?} batch {batch}", w.dtype());
                        let what = format!("split rows {path}");
                        assert_product(&what, &mm, &x, &w, &init, &split, accumulate);
                    }
                }
            }
        }
    }
}
