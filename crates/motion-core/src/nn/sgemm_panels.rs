//! `Y = X Wᵀ` for large batches over a weight packed once at load into column panels, with an
//! AVX-512F register-tile kernel.
//!
//! `W [out, in]` (the PyTorch layout) is repacked by [`PanelMatrix::pack`] into panels of
//! [`PANEL_WIDTH`] output columns; inside a panel the weights are stored input-major
//! (`panel[k * PANEL_WIDTH + j] = W[panel_start + j, k]`, zero-padded past the last output), which
//! is exactly the order the kernel streams them, so a call never re-packs the weight (the cost
//! that makes `matrixmultiply` slow at every batch size > 1).
//!
//! A call ([`gemm_panels`]) runs a `TILE_ROWS x PANEL_WIDTH` tile of accumulators (24 of the 32
//! zmm registers) over every panel, broadcasting `X` straight from its rows: packing `X` into a
//! tile-interleaved buffer first (the usual BLIS step) measured slower at every shape of the
//! step, by up to 40 % for the 54-output decoder where the copy is not amortized over many
//! panels. Loop order (Goto/BLIS): blocks of `MC_MAX` rows; within one, each panel slice is
//! reused by all the block's row tiles while it is hot in L1/L2. A call allocates nothing.
//! Large products are split by rows over the rayon pool.
//!
//! With the AVX2 path selected the same panels feed an AVX2 + FMA kernel (`6 x 16` tiles, each
//! panel in two halves). On other paths [`panels_in_use`] is false and [`gemm_panels`] still
//! computes the right numbers with portable loops over the same layout, only slowly; callers
//! should use their own fallback then.
//!
//! The per-path kernels (the `avx512` and `avx2` submodules, the portable loop) live here, beside
//! the panel layout they read, not in `nn::kernels` with the row kernels: those read
//! [`super::packed`]'s rows, and `packed` holds [`PanelMatrix`]es, so panel kernels among them
//! would make `kernels`, `packed` and this module depend on each other in a cycle. The kernel
//! tests of `nn::kernels` check these kernels on every path.

use super::simd::SimdPath;

/// Output columns per panel: two 16-lane AVX-512 registers.
pub const PANEL_WIDTH: usize = 32;
/// Rows of `X` per register tile (`TILE_ROWS x PANEL_WIDTH` accumulators = 24 of 32 zmm).
pub const TILE_ROWS: usize = 12;
/// Inputs per pass. Measured on Zen 5 (48 KiB L1, 1 MiB L2) at batch 256: depths 128..1024 are
/// within noise of each other for K <= 512, and one pass beats four passes of 256 at K = 1024
/// (the panel slice streams well from L2; fewer passes mean fewer round trips of `Y`).
#[cfg(target_arch = "x86_64")]
const KC_MAX: usize = 1024;
/// Rows of `X` per block (96 x 1024 x 4 B = 384 KiB, inside L2); 48..264 measured alike.
#[cfg(target_arch = "x86_64")]
const MC_MAX: usize = 96;
/// Below this many multiply-adds a product is not split across threads.
const PARALLEL_MIN_WORK: usize = 1 << 21;
/// Minimum rows per thread when splitting.
const PARALLEL_MIN_ROWS: usize = 2 * TILE_ROWS;

/// What one register tile adds its sums to (its first pass of inputs: [`Init`] with the bias
/// already offset to the tile's first column; later passes `Load`).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
enum TileInit {
    Zero,
    Load,
    Bias(*const f32),
}

#[cfg(target_arch = "x86_64")]
impl TileInit {
    /// The tile init of pass `pc` (inputs from `pc` on) for columns from `first`.
    fn of(init: Init, pc: usize, first: usize) -> Self {
        match init {
            _ if pc > 0 => TileInit::Load,
            Init::Zero => TileInit::Zero,
            Init::Accumulate => TileInit::Load,
            // `wrapping_add`: a fully masked-off AVX-512 register may start past the bias.
            Init::Bias(bias) => TileInit::Bias(bias.as_ptr().wrapping_add(first)),
        }
    }
}

/// One cache line of packed weights (keeps every panel row 64-byte aligned for the loads).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Line([f32; 16]);

/// A weight `W [outputs, inputs]` packed into column panels for [`gemm_panels`].
#[derive(Debug, Clone)]
pub struct PanelMatrix {
    outputs: usize,
    inputs: usize,
    lines: Vec<Line>,
}

impl PanelMatrix {
    /// Packs a row-major `W [outputs, inputs]` (PyTorch layout). Panics if `w` is shorter than
    /// `outputs * inputs` (a programming error).
    pub fn pack(w: &[f32], outputs: usize, inputs: usize) -> Self {
        assert!(w.len() >= outputs * inputs, "weight too short");
        let panels = outputs.div_ceil(PANEL_WIDTH);
        let lines_per_panel = inputs * PANEL_WIDTH / 16;
        let mut lines = vec![Line([0.0; 16]); panels * lines_per_panel];
        if inputs > 0 {
            let data = lines_as_floats_mut(&mut lines);
            for (p, panel) in data
                .chunks_exact_mut(inputs * PANEL_WIDTH)
                .enumerate()
                .take(panels)
            {
                let first = p * PANEL_WIDTH;
                let width = PANEL_WIDTH.min(outputs - first);
                for j in 0..width {
                    let row = &w[(first + j) * inputs..(first + j + 1) * inputs];
                    for (k, &v) in row.iter().enumerate() {
                        panel[k * PANEL_WIDTH + j] = v;
                    }
                }
            }
        }
        Self {
            outputs,
            inputs,
            lines,
        }
    }

    /// Columns of `Y` (rows of `W`).
    pub fn outputs(&self) -> usize {
        self.outputs
    }

    /// Columns of `X` (columns of `W`).
    pub fn inputs(&self) -> usize {
        self.inputs
    }

    /// Bytes held by the packed weight (including the zero padding of the last panel).
    pub fn size_bytes(&self) -> usize {
        self.lines.len() * std::mem::size_of::<Line>()
    }

    fn panels(&self) -> usize {
        self.outputs.div_ceil(PANEL_WIDTH)
    }

    fn data(&self) -> &[f32] {
        lines_as_floats(&self.lines)
    }
}

fn lines_as_floats(lines: &[Line]) -> &[f32] {
    // SAFETY: `Line` is `repr(C)` around `[f32; 16]` with no padding (64 bytes = 16 x 4), so the
    // slice is `16 * len` initialized, properly aligned f32 values.
    unsafe { std::slice::from_raw_parts(lines.as_ptr().cast::<f32>(), lines.len() * 16) }
}

fn lines_as_floats_mut(lines: &mut [Line]) -> &mut [f32] {
    // SAFETY: as in `lines_as_floats`; the borrow is exclusive.
    unsafe { std::slice::from_raw_parts_mut(lines.as_mut_ptr().cast::<f32>(), lines.len() * 16) }
}

/// True when the selected SIMD path ([`super::simd::active`]) has a panel kernel (AVX-512 or
/// AVX2): matrices loaded now are packed into panels for [`gemm_panels`].
pub fn panels_in_use() -> bool {
    matches!(super::simd::active(), SimdPath::Avx512 | SimdPath::Avx2)
}

/// What the sums `X Wᵀ` of a product are added to.
#[derive(Debug, Clone, Copy)]
pub enum Init<'a> {
    /// Nothing: `Y = X Wᵀ`.
    Zero,
    /// `Y` itself: `Y += X Wᵀ`.
    Accumulate,
    /// One row `bias [outputs]`, the same for every row of `Y`: `Y = X Wᵀ + bias`, without
    /// writing the bias into `Y` first (at batch 256 those copies and the reads of `Y` they cause
    /// were 3 % of a GRU-d step).
    Bias(&'a [f32]),
}

impl Init<'_> {
    /// `Accumulate` if `accumulate`, else `Zero` (the `accumulate` flag of [`super::gemm::MatMul::run`]).
    pub fn from_accumulate(accumulate: bool) -> Self {
        if accumulate {
            Init::Accumulate
        } else {
            Init::Zero
        }
    }
}

/// `Y = X Wᵀ` plus what `init` says (nothing, `Y` itself, or a bias row) for `batch` rows of
/// `X [batch, w.inputs()]` (row stride `x_stride`) into `Y [batch, w.outputs()]` (row stride
/// `y_stride`). Columns of `Y` past `w.outputs()` are not touched.
///
/// Splits over the current rayon pool's threads when the product is large. Panics if a slice is
/// too short for the layout (a bias shorter than `w.outputs()` included) or if rows of `Y` would
/// overlap (`y_stride < outputs`), all programming errors.
pub fn gemm_panels(
    batch: usize,
    x: &[f32],
    x_stride: usize,
    w: &PanelMatrix,
    y: &mut [f32],
    y_stride: usize,
    init: Init,
) {
    let path = super::simd::active();
    gemm_panels_with(path, batch, x, x_stride, w, y, y_stride, init);
}

/// [`gemm_panels`] on the kernel of `path` whatever the selected one (tests and benchmarks);
/// refuses a path the CPU lacks.
#[allow(clippy::too_many_arguments)]
pub fn gemm_panels_on(
    path: SimdPath,
    batch: usize,
    x: &[f32],
    x_stride: usize,
    w: &PanelMatrix,
    y: &mut [f32],
    y_stride: usize,
    init: Init,
) -> Result<(), super::simd::SimdError> {
    if !path.supported() {
        return Err(super::simd::SimdError::Unsupported(path));
    }
    gemm_panels_with(path, batch, x, x_stride, w, y, y_stride, init);
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn gemm_panels_with(
    path: SimdPath,
    batch: usize,
    x: &[f32],
    x_stride: usize,
    w: &PanelMatrix,
    y: &mut [f32],
    y_stride: usize,
    init: Init,
) {
    let (inputs, outputs) = (w.inputs, w.outputs);
    if batch == 0 || outputs == 0 {
        return;
    }
    if let Init::Bias(bias) = init {
        assert!(bias.len() >= outputs, "bias too short");
    }
    assert!(
        x.len() >= (batch - 1) * x_stride + inputs,
        "input too short"
    );
    assert!(
        y.len() >= (batch - 1) * y_stride + outputs,
        "output too short"
    );
    assert!(batch == 1 || y_stride >= outputs, "output rows overlap");
    let work = batch * inputs * outputs;
    let threads = super::parallel::threads();
    if threads > 1 && work >= PARALLEL_MIN_WORK && batch >= 2 * PARALLEL_MIN_ROWS {
        // Row blocks that are whole tiles (except the last), one per thread.
        let rows = batch
            .div_ceil(threads)
            .next_multiple_of(TILE_ROWS)
            .max(PARALLEL_MIN_ROWS);
        super::parallel::pool::scope(|s| {
            let mut y_rest = &mut y[..];
            let mut start = 0;
            while start < batch {
                let n = rows.min(batch - start);
                let y_len = if start + n == batch {
                    y_rest.len()
                } else {
                    n * y_stride
                };
                let (y_chunk, rest) = y_rest.split_at_mut(y_len);
                y_rest = rest;
                let x_chunk = &x[start * x_stride..];
                s.spawn(move |_| serial(path, n, x_chunk, x_stride, w, y_chunk, y_stride, init));
                start += n;
            }
        });
    } else {
        serial(path, batch, x, x_stride, w, y, y_stride, init);
    }
}

/// Splits `total` into the fewest near-equal parts of at most `max`, each rounded up to `align`.
#[cfg(target_arch = "x86_64")]
fn block_len(total: usize, max: usize, align: usize) -> usize {
    let parts = total.div_ceil(max);
    total.div_ceil(parts).next_multiple_of(align).min(total)
}

/// The product on one thread (slices already checked by the caller).
#[allow(clippy::too_many_arguments)]
fn serial(
    path: SimdPath,
    batch: usize,
    x: &[f32],
    x_stride: usize,
    w: &PanelMatrix,
    y: &mut [f32],
    y_stride: usize,
    init: Init,
) {
    // SAFETY: `y` is exclusively borrowed and the caller checked that it holds every row.
    unsafe {
        serial_panels(
            path,
            batch,
            x,
            x_stride,
            w,
            y.as_mut_ptr(),
            y_stride,
            init,
            0..w.panels(),
        )
    };
}

/// The product on one thread over the output columns of `panels` only (panel `p` holds columns
/// `p * PANEL_WIDTH ..`; the other columns of `y` are not touched), on the kernels of `path`
/// (which the CPU must run): threads may run disjoint panel ranges of one product at once.
///
/// # Safety
/// `y` must address every row the layout reaches (`(batch - 1) * y_stride + outputs` floats),
/// `x` likewise, `y_stride >= outputs` unless `batch == 1`, and no other thread may touch the
/// columns of `panels` while this runs.
#[allow(clippy::too_many_arguments)]
pub(crate) unsafe fn serial_panels(
    path: SimdPath,
    batch: usize,
    x: &[f32],
    x_stride: usize,
    w: &PanelMatrix,
    y: *mut f32,
    y_stride: usize,
    init: Init,
    panels: std::ops::Range<usize>,
) {
    #[cfg(not(target_arch = "x86_64"))]
    let _ = path; // panels are an x86-64 kernel; other targets run the portable product
    let (inputs, outputs) = (w.inputs, w.outputs);
    if inputs == 0 {
        let columns =
            (panels.start * PANEL_WIDTH).min(outputs)..(panels.end * PANEL_WIDTH).min(outputs);
        for b in 0..batch {
            // SAFETY: these columns of row `b` lie inside `y` and are this call's alone.
            let row = unsafe {
                std::slice::from_raw_parts_mut(y.add(b * y_stride + columns.start), columns.len())
            };
            match init {
                Init::Zero => row.fill(0.0),
                Init::Accumulate => {}
                Init::Bias(bias) => row.copy_from_slice(&bias[columns.clone()]),
            }
        }
        return;
    }
    #[cfg(target_arch = "x86_64")]
    {
        let kc = block_len(inputs, KC_MAX, 1);
        match path {
            SimdPath::Avx512 => {
                let mc = block_len(batch, MC_MAX, TILE_ROWS);
                // SAFETY: the path is selected only on a CPU with AVX-512F, and the caller
                // checked that every row of `x` and `y` the layout addresses lies inside the
                // slices (`y` exclusively borrowed).
                unsafe {
                    avx512::blocked(batch, x, x_stride, w, y, y_stride, init, kc, mc, panels)
                };
                return;
            }
            SimdPath::Avx2 => {
                let mc = block_len(batch, avx2::mc_max(kc), avx2::TILE_ROWS);
                // SAFETY: as above, with AVX2 and FMA.
                unsafe { avx2::blocked(batch, x, x_stride, w, y, y_stride, init, kc, mc, panels) };
                return;
            }
            _ => {}
        }
    }
    // SAFETY: as for this function.
    unsafe { portable(batch, x, x_stride, w, y, y_stride, init, panels) };
}

/// Plain loops over the packed layout (machines without AVX-512F; also a layout check in tests).
///
/// # Safety
/// As [`serial_panels`].
#[allow(clippy::too_many_arguments)]
unsafe fn portable(
    batch: usize,
    x: &[f32],
    x_stride: usize,
    w: &PanelMatrix,
    y: *mut f32,
    y_stride: usize,
    init: Init,
    panels: std::ops::Range<usize>,
) {
    let (inputs, outputs) = (w.inputs, w.outputs);
    let data = w.data();
    for b in 0..batch {
        let xr = &x[b * x_stride..b * x_stride + inputs];
        for p in panels.clone() {
            let panel = &data[p * inputs * PANEL_WIDTH..(p + 1) * inputs * PANEL_WIDTH];
            let mut acc = [0.0f32; PANEL_WIDTH];
            for (k, &xv) in xr.iter().enumerate() {
                for (a, &wv) in acc
                    .iter_mut()
                    .zip(&panel[k * PANEL_WIDTH..(k + 1) * PANEL_WIDTH])
                {
                    *a += xv * wv;
                }
            }
            let first = p * PANEL_WIDTH;
            let width = PANEL_WIDTH.min(outputs - first);
            // SAFETY: columns `first ..+ width` of row `b` lie inside `y` and are this call's alone.
            let yr = unsafe { std::slice::from_raw_parts_mut(y.add(b * y_stride + first), width) };
            for (j, (o, a)) in yr.iter_mut().zip(acc).enumerate() {
                *o = match init {
                    Init::Zero => a,
                    Init::Accumulate => *o + a,
                    Init::Bias(bias) => bias[first + j] + a,
                };
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod avx512 {
    use super::{Init, PanelMatrix, TileInit, PANEL_WIDTH, TILE_ROWS};
    use std::arch::x86_64::*;

    /// Registers per panel row.
    const VECS: usize = PANEL_WIDTH / 16;

    /// The blocked product on one thread: `kc` inputs per pass, `mc` rows per block.
    ///
    /// # Safety
    /// AVX-512F must be available; `x`, `y` must hold every addressed row (checked by
    /// `gemm_panels`) and `y_stride >= outputs` unless `batch == 1`.
    #[allow(clippy::too_many_arguments)]
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn blocked(
        batch: usize,
        x: &[f32],
        x_stride: usize,
        w: &PanelMatrix,
        y_ptr: *mut f32,
        y_stride: usize,
        init: Init,
        kc_max: usize,
        mc_max: usize,
        panels: std::ops::Range<usize>,
    ) {
        let (inputs, outputs) = (w.inputs, w.outputs);
        let data = w.data().as_ptr();
        let mut pc = 0;
        while pc < inputs {
            let kc = kc_max.min(inputs - pc);
            let mut ic = 0;
            while ic < batch {
                let mc = mc_max.min(batch - ic);
                let x_block = &x[ic * x_stride..];
                for p in panels.clone() {
                    let first = p * PANEL_WIDTH;
                    let width = PANEL_WIDTH.min(outputs - first);
                    let masks = column_masks(width);
                    // SAFETY: panel `p` holds `inputs * PANEL_WIDTH` floats; we start `pc` rows in.
                    let b = unsafe { data.add((p * inputs + pc) * PANEL_WIDTH) };
                    // Rows spread evenly over the fewest tiles (13 rows = 7 + 6, not 12 + 1): a
                    // tile of fewer than 4 rows has too few independent FMA chains to hide the
                    // FMA latency.
                    let tiles = mc.div_ceil(TILE_ROWS);
                    let mut ir = 0;
                    for t in 0..tiles {
                        let m = mc / tiles + usize::from(t < mc % tiles);
                        // Fetch the tile's lines of `y` now (see the AVX2 kernel): 1-2 % here.
                        for r in 0..m {
                            let row = y_ptr.wrapping_add((ic + ir + r) * y_stride + first);
                            _mm_prefetch::<_MM_HINT_T0>(row.cast());
                            _mm_prefetch::<_MM_HINT_T0>(row.wrapping_add(16).cast());
                        }
                        // SAFETY: tile rows `ic + ir ..+ m` and columns `first ..+ width` lie
                        // inside `y`; rows `ic + ir ..+ m` of `x` hold inputs `pc ..+ kc`.
                        unsafe {
                            let c = y_ptr.add((ic + ir) * y_stride + first);
                            let a = x_block.as_ptr().add(ir * x_stride + pc);
                            let init = TileInit::of(init, pc, first);
                            tile_rows(m, kc, a, x_stride, b, c, y_stride, init, masks);
                        }
                        ir += m;
                    }
                }
                ic += mc;
            }
            pc += kc;
        }
    }

    /// Lane masks of the panel's registers for the first `width` columns.
    #[inline(always)]
    fn column_masks(width: usize) -> [__mmask16; VECS] {
        let mut masks = [0; VECS];
        for (v, m) in masks.iter_mut().enumerate() {
            let lanes = width.saturating_sub(16 * v).min(16);
            *m = ((1u32 << lanes) - 1) as __mmask16;
        }
        masks
    }

    /// Runs the tile kernel for `m` (1..=TILE_ROWS) rows.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    unsafe fn tile_rows(
        m: usize,
        kc: usize,
        a: *const f32,
        lda: usize,
        b: *const f32,
        c: *mut f32,
        ldc: usize,
        init: TileInit,
        masks: [__mmask16; VECS],
    ) {
        macro_rules! by_rows {
            ($($n:literal)*) => {
                match m {
                    $($n => unsafe { tile::<$n>(kc, a, lda, b, c, ldc, init, masks) },)*
                    _ => unreachable!("tile rows out of range"),
                }
            };
        }
        by_rows!(1 2 3 4 5 6 7 8 9 10 11 12);
    }

    /// `C[0..M, cols] (+)= A B` for `M` rows of `X` (`a[r * lda + k]`) and a panel slice
    /// (`b[k * PANEL_WIDTH + j]`) over `kc` inputs; `masks` select the existing columns.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn tile<const M: usize>(
        kc: usize,
        a: *const f32,
        lda: usize,
        b: *const f32,
        c: *mut f32,
        ldc: usize,
        init: TileInit,
        masks: [__mmask16; VECS],
    ) {
        let mut acc = [[_mm512_setzero_ps(); VECS]; M];
        let (mut a, mut b) = (a, b);
        for _ in 0..kc {
            // SAFETY: rows `a + r * lda` (r < M) hold `kc` inputs; `b` holds `kc` panel rows.
            unsafe {
                let mut bv = [_mm512_setzero_ps(); VECS];
                for (v, r) in bv.iter_mut().enumerate() {
                    *r = _mm512_load_ps(b.add(16 * v));
                }
                for (r, row) in acc.iter_mut().enumerate() {
                    let av = _mm512_set1_ps(*a.add(r * lda));
                    for (s, bvv) in row.iter_mut().zip(&bv) {
                        *s = _mm512_fmadd_ps(av, *bvv, *s);
                    }
                }
                a = a.add(1);
                b = b.add(PANEL_WIDTH);
            }
        }
        for (r, row) in acc.iter().enumerate() {
            for (v, &s) in row.iter().enumerate() {
                // SAFETY: row `r` of the tile, columns selected by the mask, lie inside `y`, and
                // a bias holds them (`gemm_panels` asserted its length).
                unsafe {
                    // `wrapping_add`: a fully masked-off register may start past the end of `y`.
                    let p = c.wrapping_add(r * ldc + 16 * v);
                    let out = match init {
                        TileInit::Zero => s,
                        TileInit::Load => _mm512_add_ps(_mm512_maskz_loadu_ps(masks[v], p), s),
                        TileInit::Bias(bias) => {
                            let bias = bias.wrapping_add(16 * v);
                            _mm512_add_ps(_mm512_maskz_loadu_ps(masks[v], bias), s)
                        }
                    };
                    _mm512_mask_storeu_ps(p, masks[v], out);
                }
            }
        }
    }
}

/// The AVX2 + FMA kernel over the same panels: each 32-column panel in two halves of 16 columns
/// (two ymm registers), a `TILE_ROWS x 16` tile of accumulators (12 of the 16 ymm registers, +2
/// weight vectors + 1 broadcast).
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{Init, PanelMatrix, TileInit, PANEL_WIDTH};
    use std::arch::x86_64::*;

    /// Rows of `X` per register tile.
    pub(super) const TILE_ROWS: usize = 6;
    /// Bytes of `X` per block (`mc x kc` f32, kept in L2 while every panel passes over it).
    const X_BLOCK_BYTES: usize = 512 << 10;

    /// Rows of `X` per block for passes of `kc` inputs: as many as fit [`X_BLOCK_BYTES`], at most
    /// 264 and at least 96. Each block streams the whole weight from L3 or memory once, and the
    /// 6-row tiles feel that stream more than the AVX-512 kernel's 12-row ones: the GRU-d 2x512
    /// step's seven products at batch 256, one thread, cold weights, were 3-4 % faster with one
    /// block of 256 rows than with blocks of 96 (`kc` 1024 measured best, 128 and 256 slower).
    pub(super) fn mc_max(kc: usize) -> usize {
        (X_BLOCK_BYTES / (4 * kc.max(1))).clamp(96, 264)
    }
    /// Columns per half panel.
    const HALF: usize = 16;

    /// The blocked product on one thread: `kc` inputs per pass, `mc` rows per block.
    ///
    /// # Safety
    /// AVX2 and FMA must be available; `x`, `y` must hold every addressed row (checked by
    /// `gemm_panels`) and `y_stride >= outputs` unless `batch == 1`.
    #[allow(clippy::too_many_arguments)]
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn blocked(
        batch: usize,
        x: &[f32],
        x_stride: usize,
        w: &PanelMatrix,
        y_ptr: *mut f32,
        y_stride: usize,
        init: Init,
        kc_max: usize,
        mc_max: usize,
        panels: std::ops::Range<usize>,
    ) {
        let (inputs, outputs) = (w.inputs, w.outputs);
        let data = w.data().as_ptr();
        let mut pc = 0;
        while pc < inputs {
            let kc = kc_max.min(inputs - pc);
            let mut ic = 0;
            while ic < batch {
                let mc = mc_max.min(batch - ic);
                let x_block = &x[ic * x_stride..];
                let tiles = mc.div_ceil(TILE_ROWS);
                for p in panels.clone() {
                    // Each row tile runs both halves of the panel back to back: its rows of `x`
                    // are still in L1 for the second half, and the panel's two halves stream
                    // from memory together (measured 3-9 % faster than all tiles on one half,
                    // then all on the other, with cold and with hot weights).
                    let mut ir = 0;
                    for t in 0..tiles {
                        let m = mc / tiles + usize::from(t < mc % tiles);
                        // The tile's lines of `y` (both halves: 128 bytes a row) are read and
                        // written only after the whole `kc` loop: fetch them now, so that their
                        // misses (`y` is larger than L2 at batch 256) overlap the arithmetic
                        // instead of stalling the tile's end; 5-7 % on the GRU-d step's products.
                        for r in 0..m {
                            let row =
                                y_ptr.wrapping_add((ic + ir + r) * y_stride + p * PANEL_WIDTH);
                            _mm_prefetch::<_MM_HINT_T0>(row.cast());
                            _mm_prefetch::<_MM_HINT_T0>(row.wrapping_add(HALF).cast());
                        }
                        for half in 0..PANEL_WIDTH / HALF {
                            let first = p * PANEL_WIDTH + half * HALF;
                            if first >= outputs {
                                break;
                            }
                            let width = HALF.min(outputs - first);
                            // SAFETY: panel `p` holds `inputs * PANEL_WIDTH` floats; we start
                            // `pc` rows in, at the half's first column (32-byte aligned: panel
                            // rows are 64-byte aligned and a half is 64 bytes). Tile rows
                            // `ic + ir ..+ m` and columns `first ..+ width` lie inside `y`;
                            // rows `ic + ir ..+ m` of `x` hold inputs `pc ..+ kc`.
                            unsafe {
                                let b = data.add((p * inputs + pc) * PANEL_WIDTH + half * HALF);
                                let c = y_ptr.add((ic + ir) * y_stride + first);
                                let a = x_block.as_ptr().add(ir * x_stride + pc);
                                let init = TileInit::of(init, pc, first);
                                tile_rows(m, kc, a, x_stride, b, c, y_stride, init, width);
                            }
                        }
                        ir += m;
                    }
                }
                ic += mc;
            }
            pc += kc;
        }
    }

    /// Runs the tile kernel for `m` (1..=TILE_ROWS) rows.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    unsafe fn tile_rows(
        m: usize,
        kc: usize,
        a: *const f32,
        lda: usize,
        b: *const f32,
        c: *mut f32,
        ldc: usize,
        init: TileInit,
        width: usize,
    ) {
        macro_rules! by_rows {
            ($($n:literal)*) => {
                match m {
                    $($n => unsafe { tile::<$n>(kc, a, lda, b, c, ldc, init, width) },)*
                    _ => unreachable!("tile rows out of range"),
                }
            };
        }
        by_rows!(1 2 3 4 5 6);
    }

    /// `C[0..M, 0..width] (+)= A B` for `M` rows of `X` (`a[r * lda + k]`) and a half panel
    /// (`b[k * PANEL_WIDTH + j]`, `j < 16`) over `kc` inputs.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn tile<const M: usize>(
        kc: usize,
        a: *const f32,
        lda: usize,
        b: *const f32,
        c: *mut f32,
        ldc: usize,
        init: TileInit,
        width: usize,
    ) {
        let mut acc = [[_mm256_setzero_ps(); 2]; M];
        let (mut a, mut b) = (a, b);
        // Four inputs per iteration, the row offsets and the unrolled inputs folded into the
        // loads' addresses: one pointer update per four inputs instead of one per input. At 12
        // FMAs per 8 loads a 6 x 16 tile needs about 4 instructions a cycle, so the loop's own
        // bookkeeping decides its speed: 3-5 % faster at the 10th percentile and 7-14 % at the
        // median on a busy host (the AVX-512 kernel, at 24 FMAs per 14 loads, gains nothing).
        for _ in 0..kc / 4 {
            // SAFETY: as below, four inputs at a time.
            unsafe {
                for u in 0..4 {
                    let b0 = _mm256_load_ps(b.add(u * PANEL_WIDTH));
                    let b1 = _mm256_load_ps(b.add(u * PANEL_WIDTH + 8));
                    for (r, row) in acc.iter_mut().enumerate() {
                        let av = _mm256_broadcast_ss(&*a.add(r * lda + u));
                        row[0] = _mm256_fmadd_ps(av, b0, row[0]);
                        row[1] = _mm256_fmadd_ps(av, b1, row[1]);
                    }
                }
                a = a.add(4);
                b = b.add(4 * PANEL_WIDTH);
            }
        }
        for _ in 0..kc % 4 {
            // SAFETY: rows `a + r * lda` (r < M) hold `kc` inputs; `b` holds `kc` panel rows.
            unsafe {
                let b0 = _mm256_load_ps(b);
                let b1 = _mm256_load_ps(b.add(8));
                for (r, row) in acc.iter_mut().enumerate() {
                    let av = _mm256_broadcast_ss(&*a.add(r * lda));
                    row[0] = _mm256_fmadd_ps(av, b0, row[0]);
                    row[1] = _mm256_fmadd_ps(av, b1, row[1]);
                }
                a = a.add(1);
                b = b.add(PANEL_WIDTH);
            }
        }
        for (r, row) in acc.iter().enumerate() {
            // SAFETY: row `r` of the tile, columns `0..width`, lie inside `y`, and a bias holds
            // them (`gemm_panels` asserted its length).
            unsafe {
                let p = c.add(r * ldc);
                if width == HALF {
                    for (v, &s) in row.iter().enumerate() {
                        let q = p.add(8 * v);
                        let out = match init {
                            TileInit::Zero => s,
                            TileInit::Load => _mm256_add_ps(_mm256_loadu_ps(q), s),
                            TileInit::Bias(bias) => {
                                _mm256_add_ps(_mm256_loadu_ps(bias.add(8 * v)), s)
                            }
                        };
                        _mm256_storeu_ps(q, out);
                    }
                } else {
                    let mut buf = [0.0f32; HALF];
                    _mm256_storeu_ps(buf.as_mut_ptr(), row[0]);
                    _mm256_storeu_ps(buf.as_mut_ptr().add(8), row[1]);
                    for (j, &v) in buf.iter().enumerate().take(width) {
                        let q = p.add(j);
                        *q = match init {
                            TileInit::Zero => v,
                            TileInit::Load => *q + v,
                            TileInit::Bias(bias) => *bias.add(j) + v,
                        };
                    }
                }
            }
        }
    }
}

/// The f64 checks of the panel GEMM, run here through [`gemm_panels`] and on every SIMD path by
/// the kernel tests (`nn::kernels`).
#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    #[cfg(feature = "parallel")]
    #[test]
    fn panel_ranges_write_their_columns_only_and_together_give_the_whole_product() {
        for path in SimdPath::available() {
            let (batch, inputs, outputs) = (5, 37, 100); // 4 panels, the last one ragged
            let (x, wv, bias) = (
                data(batch * inputs, 1),
                data(outputs * inputs, 2),
                data(outputs, 3),
            );
            let w = PanelMatrix::pack(&wv, outputs, inputs);
            let y_stride = outputs + 3;
            for init in [Init::Zero, Init::Accumulate, Init::Bias(&bias)] {
                let start = data(batch * y_stride, 4);
                let mut whole = start.clone();
                gemm_panels_on(path, batch, &x, inputs, &w, &mut whole, y_stride, init).unwrap();
                let mut parts = start.clone();
                for range in [0..1, 1..3, 3..4] {
                    let mut one = start.clone();
                    // SAFETY: `one` holds every row; nothing else touches it.
                    unsafe {
                        serial_panels(
                            path,
                            batch,
                            &x,
                            inputs,
                            &w,
                            one.as_mut_ptr(),
                            y_stride,
                            init,
                            range.clone(),
                        )
                    };
                    let cols = range.start * PANEL_WIDTH..(range.end * PANEL_WIDTH).min(outputs);
                    for b in 0..batch {
                        for j in 0..y_stride {
                            let i = b * y_stride + j;
                            if cols.contains(&j) {
                                parts[i] = one[i];
                            } else {
                                assert_eq!(
                                    one[i].to_bits(),
                                    start[i].to_bits(),
                                    "{path}: column {j} touched"
                                );
                            }
                        }
                    }
                }
                assert_eq!(parts, whole, "{path}");
            }
        }
    }

    /// Deterministic values in [-1, 1) from a 64-bit LCG (fixed seed per call site).
    fn data(n: usize, seed: u64) -> Vec<f32> {
        let mut s = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (0..n)
            .map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((s >> 40) as f32) / (1u64 << 23) as f32 - 1.0
            })
            .collect()
    }

    /// The three [`Init`]s as test cases (the bias drawn per case).
    #[derive(Debug, Clone, Copy)]
    enum Mode {
        Zero,
        Accumulate,
        Bias,
    }
    const MODES: [Mode; 3] = [Mode::Zero, Mode::Accumulate, Mode::Bias];

    /// `X Wᵀ` plus `y0` or `bias` (per `mode`) in f64, for the rows/columns the layout addresses;
    /// `y0` elsewhere.
    #[allow(clippy::too_many_arguments)]
    fn reference(
        batch: usize,
        inputs: usize,
        outputs: usize,
        x: &[f32],
        x_stride: usize,
        w: &[f32],
        y0: &[f32],
        y_stride: usize,
        mode: Mode,
        bias: &[f32],
    ) -> Vec<f64> {
        let mut y: Vec<f64> = y0.iter().map(|&v| v as f64).collect();
        for b in 0..batch {
            for o in 0..outputs {
                let d: f64 = (0..inputs)
                    .map(|k| x[b * x_stride + k] as f64 * w[o * inputs + k] as f64)
                    .sum();
                let t = &mut y[b * y_stride + o];
                *t = match mode {
                    Mode::Zero => d,
                    Mode::Accumulate => *t + d,
                    Mode::Bias => bias[o] as f64 + d,
                };
            }
        }
        y
    }

    /// Runs one case on the kernel of `path` (which the CPU runs; `None`: [`gemm_panels`] on the
    /// selected path) and compares with f64.
    fn check(
        path: Option<SimdPath>,
        batch: usize,
        inputs: usize,
        outputs: usize,
        pad: (usize, usize),
        mode: Mode,
    ) {
        let (x_stride, y_stride) = (inputs + pad.0, outputs + pad.1);
        let seed = (batch * 1_000_003 + inputs * 1009 + outputs) as u64;
        let x = data(batch.max(1) * x_stride, seed);
        let w = data(outputs * inputs, seed + 1);
        let y0 = data(batch.max(1) * y_stride, seed + 2);
        let bias = data(outputs, seed + 3);
        let init = match mode {
            Mode::Zero => Init::Zero,
            Mode::Accumulate => Init::Accumulate,
            Mode::Bias => Init::Bias(&bias),
        };
        let packed = PanelMatrix::pack(&w, outputs, inputs);
        assert_eq!((packed.outputs(), packed.inputs()), (outputs, inputs));
        let expect = reference(
            batch, inputs, outputs, &x, x_stride, &w, &y0, y_stride, mode, &bias,
        );
        // Sums of `inputs` products of values in [-1, 1): f32 rounding grows like sqrt(inputs).
        let tol = 2e-6 * (inputs as f64).sqrt().max(1.0) * 4.0;
        let name = path.map_or("dispatch".to_string(), |p| p.to_string());
        let mut y = y0.clone();
        match path {
            None => gemm_panels(batch, &x, x_stride, &packed, &mut y, y_stride, init),
            Some(p) => {
                gemm_panels_on(p, batch, &x, x_stride, &packed, &mut y, y_stride, init).unwrap()
            }
        }
        for (i, (&got, &want)) in y.iter().zip(&expect).enumerate() {
            assert!(
                (got as f64 - want).abs() <= tol * want.abs().max(1.0),
                "{name} batch {batch} in {inputs} out {outputs} pad {pad:?} {mode:?}: \
                 y[{i}] = {got}, expected {want}"
            );
        }
    }

    /// The products of the paper models' layers: batches 1 to 257, inputs 54 to 1024, outputs 54
    /// to 1536, each [`Init`] in turn (see [`check`]).
    pub(crate) fn model_shapes(path: Option<SimdPath>) {
        for &batch in &[1, 2, 13, 256, 257] {
            for &inputs in &[54, 216, 512, 1024] {
                for &outputs in &[54, 1024, 1536] {
                    check(path, batch, inputs, outputs, (0, 0), MODES[batch % 3]);
                }
            }
        }
    }

    /// Ragged shapes (partial tiles, panels and passes of inputs), padded row strides and every
    /// [`Init`] (see [`check`]).
    pub(crate) fn ragged_shapes(path: Option<SimdPath>) {
        for &(batch, inputs, outputs) in &[
            (1, 1, 1),
            (3, 5, 7),
            (12, 16, 32),
            (11, 17, 33),
            (25, 300, 65),
            (49, 257, 31),
            (300, 70, 100),
            // Every remainder of the AVX2 kernel's four-input loop (inputs % 4 = 3 here; two
            // passes of 514 and 513 inputs below).
            (7, 11, 40),
            (6, 3, 16),
            (9, 1027, 20),
        ] {
            for pad in [(0, 0), (3, 5), (16, 0)] {
                for mode in MODES {
                    check(path, batch, inputs, outputs, pad, mode);
                }
            }
        }
    }

    /// The selected path through [`gemm_panels`] (every path's kernel, on these shapes and the
    /// model shapes, is tested by `nn::kernels`).
    #[test]
    fn sgemm_ragged_shapes_strides_and_accumulate() {
        ragged_shapes(None);
    }

    #[cfg(feature = "parallel")]
    #[test]
    fn sgemm_splits_over_threads_like_one_thread() {
        let (batch, inputs, outputs) = (257, 512, 1536);
        let x = data(batch * inputs, 7);
        let w = PanelMatrix::pack(&data(outputs * inputs, 8), outputs, inputs);
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("thread pool");
            let mut y = vec![0.0; batch * outputs];
            pool.install(|| gemm_panels(batch, &x, inputs, &w, &mut y, outputs, Init::Zero));
            y
        };
        // Each row is computed by one thread in the same order either way: identical bits.
        assert_eq!(run(1), run(2));
    }

    #[test]
    fn sgemm_zero_inputs_and_empty_products() {
        let w = PanelMatrix::pack(&[], 5, 0);
        let mut y = vec![1.0; 10];
        gemm_panels(2, &[], 0, &w, &mut y, 5, Init::Accumulate);
        assert_eq!(y, vec![1.0; 10]);
        gemm_panels(2, &[], 0, &w, &mut y, 5, Init::Zero);
        assert_eq!(y, vec![0.0; 10]);
        gemm_panels(
            2,
            &[],
            0,
            &w,
            &mut y,
            5,
            Init::Bias(&[1.0, 2.0, 3.0, 4.0, 5.0]),
        );
        assert_eq!(y, [1.0, 2.0, 3.0, 4.0, 5.0].repeat(2));
        let w = PanelMatrix::pack(&[], 0, 3);
        gemm_panels(2, &[0.0; 6], 3, &w, &mut [], 0, Init::Zero);
        gemm_panels(
            0,
            &[],
            3,
            &PanelMatrix::pack(&[0.0; 6], 2, 3),
            &mut [],
            2,
            Init::Zero,
        );
    }

    #[test]
    fn sgemm_leaves_columns_past_outputs_alone() {
        let (batch, inputs, outputs, y_stride) = (13, 40, 37, 50);
        let x = data(batch * inputs, 11);
        let w = PanelMatrix::pack(&data(outputs * inputs, 12), outputs, inputs);
        let mut y = vec![9.0; batch * y_stride];
        gemm_panels(batch, &x, inputs, &w, &mut y, y_stride, Init::Zero);
        for b in 0..batch {
            assert!(y[b * y_stride + outputs..(b + 1) * y_stride]
                .iter()
                .all(|&v| v == 9.0));
        }
    }
}
