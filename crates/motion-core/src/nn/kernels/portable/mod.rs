//! Portable row kernels for `Y = X Wᵀ` at small batches: plain Rust that the compiler turns into
//! 128-bit vector code on any target (SSE2 on every x86-64, WebAssembly SIMD128, NEON), what WASM
//! and unknown CPUs run.
//!
//! A tile holds `R` weight rows against `B` batch rows in `R x B` accumulators of [`PL`] lanes
//! (4 x 2 at batch 2 and up, 8 x 1 at batch 1): 8 accumulator vectors plus the weight and input
//! vectors fit the 16 vector registers of SSE2 and SIMD128, so nothing is spilled to the stack in
//! the inner loop (the previous 4 x 16-lane layout kept 64 accumulator floats and spilled every
//! one of them on SSE2). Each weight vector loaded serves every batch row of the tile, and weight
//! rows are the outer loop, so every weight comes from memory once per product whatever the batch.
//!
//! A row's sum does not depend on the tile it falls in: every `(batch row, output)` pair
//! accumulates its lanes in the same order and reduces them in the same tree, so a batch row's
//! result is the same at every batch size.
//!
//! 16-bit rows are widened [`WIDEN_ROWS`] at a time into a stack buffer (a branch-free exact
//! conversion the compiler vectorizes) and tiled from there; without AVX-512 a 16-bit matrix also
//! holds an f32 copy of its rows for the large-batch GEMM (see [`crate::nn::packed`]), which these
//! kernels then read directly.
use crate::nn::layout::MatMul;
use crate::nn::packed::{PackedMatrix, Rows};
use vec128::{prefetch, F4};

pub(crate) mod vec128;

/// f32 lanes per accumulator: one 128-bit vector.
const PL: usize = 4;
/// Rows widened together by the 16-bit kernel (a multiple of the widest tile).
const WIDEN_ROWS: usize = 8;
/// f32 elements of the widening buffer (32 KiB on the stack): [`WIDEN_ROWS`] rows of up to 1,024
/// inputs; wider rows are widened fewer at a time, one at a time up to this many inputs.
const WIDEN_BUFFER: usize = 8192;

/// `Y = X Wᵀ` (or `Y += X Wᵀ`) for the layout `mm` (operands checked by the caller, `inputs > 0`).
#[inline(always)]
pub(crate) fn product(mm: &MatMul, x: &[f32], w: &PackedMatrix, y: &mut [f32], accumulate: bool) {
    product_outputs(mm, x, w, y, accumulate, 0..mm.outputs);
}

/// [`product`] for the outputs `outputs` only (weight rows `outputs`), written to `y` from its
/// first element on: `y[b * mm.y_stride + j]` is output `outputs.start + j` of batch row `b`. At
/// batch 1 disjoint ranges write disjoint slices, so they may run on different threads.
pub(crate) fn product_outputs(
    mm: &MatMul,
    x: &[f32],
    w: &PackedMatrix,
    y: &mut [f32],
    accumulate: bool,
    outputs: std::ops::Range<usize>,
) {
    let part = MatMul {
        outputs: outputs.len(),
        ..*mm
    };
    let rows = outputs.start * mm.inputs..outputs.end * mm.inputs;
    if let Some(f32_rows) = w.f32_rows() {
        tiles(&part, x, &f32_rows[rows], 0, y, accumulate);
        return;
    }
    match w.rows() {
        Rows::F32(w) => tiles(&part, x, &w[rows], 0, y, accumulate),
        Rows::F16(w) => widened(&part, x, &w[rows], f16_to_f32, y, accumulate),
        // bf16 is the upper half of an f32.
        Rows::Bf16(w) => widened(
            &part,
            x,
            &w[rows],
            |v| f32::from_bits(u32::from(v) << 16),
            y,
            accumulate,
        ),
    }
}

/// f16 bits to f32, exact, branch-free: the exponent and mantissa shifted into f32 position and
/// scaled by 2^112 (right for normal and subnormal values alike), infinities and NaNs patched.
#[inline(always)]
pub(crate) fn f16_to_f32(h: u16) -> f32 {
    let h = u32::from(h);
    let sign = (h & 0x8000) << 16;
    let magnitude = h & 0x7fff;
    let scaled = (f32::from_bits(magnitude << 13) * f32::from_bits(0x7780_0000)).to_bits();
    let bits = if magnitude >= 0x7c00 {
        (magnitude << 13) | 0x7f80_0000
    } else {
        scaled
    };
    f32::from_bits(bits | sign)
}

/// 16-bit rows widened by `widen` a group at a time, each group tiled like f32 rows.
#[inline(always)]
fn widened(
    mm: &MatMul,
    x: &[f32],
    w: &[u16],
    widen: impl Fn(u16) -> f32 + Copy,
    y: &mut [f32],
    accumulate: bool,
) {
    let k = mm.inputs;
    let group_rows = (WIDEN_BUFFER / k).min(WIDEN_ROWS);
    if group_rows == 0 {
        wide_rows(mm, x, w, widen, y, accumulate);
        return;
    }
    let mut buf = [0.0f32; WIDEN_BUFFER];
    let mut o = 0;
    while o < mm.outputs {
        let n = group_rows.min(mm.outputs - o);
        let group = &mut buf[..n * k];
        for (dst, src) in group.iter_mut().zip(&w[o * k..(o + n) * k]) {
            *dst = widen(*src);
        }
        tiles(mm, x, group, o, y, accumulate);
        o += n;
    }
}

/// Rows longer than the widening buffer: one dot product per output, widened on the fly, in the
/// same lane order and reduction as the tiles.
#[cold]
fn wide_rows(
    mm: &MatMul,
    x: &[f32],
    w: &[u16],
    widen: impl Fn(u16) -> f32 + Copy,
    y: &mut [f32],
    accumulate: bool,
) {
    let k = mm.inputs;
    let full = k / PL * PL;
    for b in 0..mm.batch {
        let xb = &x[b * mm.x_stride..b * mm.x_stride + k];
        for o in 0..mm.outputs {
            let row = &w[o * k..(o + 1) * k];
            let mut acc = [0.0f32; PL];
            for (xc, wc) in xb[..full].chunks_exact(PL).zip(row.chunks_exact(PL)) {
                for l in 0..PL {
                    acc[l] = madd(widen(wc[l]), xc[l], acc[l]);
                }
            }
            let mut d = reduce(acc);
            for (a, b) in row[full..].iter().zip(&xb[full..]) {
                d = madd(widen(*a), *b, d);
            }
            let out = &mut y[b * mm.y_stride + o];
            *out = if accumulate { *out + d } else { d };
        }
    }
}

/// `a * b + acc`, unfused (the portable targets have no fused multiply-add to rely on).
#[inline(always)]
fn madd(a: f32, b: f32, acc: f32) -> f32 {
    acc + a * b
}

/// The lane sum in a fixed tree (deterministic).
#[inline(always)]
fn reduce(a: [f32; PL]) -> f32 {
    (a[0] + a[2]) + (a[1] + a[3])
}

/// Every batch row against the f32 weight rows `rows` (`rows.len() / inputs` of them), which are
/// outputs `o0..` of the product.
#[inline(always)]
fn tiles(mm: &MatMul, x: &[f32], rows: &[f32], o0: usize, y: &mut [f32], accumulate: bool) {
    let k = mm.inputs;
    let n = rows.len() / k;
    // The bounds every tile relies on (see `tile`).
    assert!(x.len() >= (mm.batch - 1) * mm.x_stride + k);
    assert!(y.len() >= (mm.batch - 1) * mm.y_stride + o0 + n);
    let mut r = 0;
    if mm.batch == 1 {
        while r + 8 <= n {
            // SAFETY: rows `r..r + 8` exist; batch row 0 and outputs `o0 + r..o0 + r + 8` are
            // inside `x` and `y` (asserted above).
            unsafe { tile::<8, 1, true>(mm, x, 0, rows, r, o0, y, accumulate) };
            r += 8;
        }
    }
    while r + 4 <= n {
        let mut b = 0;
        while b + 2 <= mm.batch {
            // SAFETY: as above, batch rows `b..b + 2`. The first pair prefetches the next rows.
            unsafe {
                if b == 0 {
                    tile::<4, 2, true>(mm, x, b, rows, r, o0, y, accumulate)
                } else {
                    tile::<4, 2, false>(mm, x, b, rows, r, o0, y, accumulate)
                }
            };
            b += 2;
        }
        if b < mm.batch {
            // SAFETY: as above, batch row `b`.
            unsafe { tile::<4, 1, true>(mm, x, b, rows, r, o0, y, accumulate) };
        }
        r += 4;
    }
    while r < n {
        for b in 0..mm.batch {
            // SAFETY: as above, weight row `r`, batch row `b`.
            unsafe { tile::<1, 1, false>(mm, x, b, rows, r, o0, y, accumulate) };
        }
        r += 1;
    }
}

/// `Y[b0 + b, o0 + r0 + r] (+)= Σ_i X[b0 + b, i] W[r0 + r, i]` for `r < R`, `b < B`;
/// `PREFETCH`: ask for the next `R` weight rows (one line of 16 f32s per row every 16 inputs) as
/// this tile streams its own, so that the batch groups after the first find them in L1.
///
/// # Safety
/// `rows` holds rows `r0..r0 + R` of `mm.inputs` elements; rows `b0..b0 + B` of `x` and
/// elements `o0 + r0..o0 + r0 + R` of rows `b0..b0 + B` of `y` are inside the slices (with the
/// strides of `mm`).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn tile<const R: usize, const B: usize, const PREFETCH: bool>(
    mm: &MatMul,
    x: &[f32],
    b0: usize,
    rows: &[f32],
    r0: usize,
    o0: usize,
    y: &mut [f32],
    accumulate: bool,
) {
    let k = mm.inputs;
    let full = k / PL * PL;
    let w = rows.as_ptr();
    let xp = x.as_ptr();
    let mut acc = [[F4::zero(); R]; B];
    // SAFETY: every read is of row `r0 + r < r0 + R` of `rows` or row `b0 + b` of `x`, at an
    // element `< k` (the caller's contract).
    unsafe {
        let mut i = 0;
        while i < full {
            let mut wv = [F4::zero(); R];
            for (r, v) in wv.iter_mut().enumerate() {
                *v = F4::load(w.add((r0 + r) * k + i));
            }
            if PREFETCH && i % 16 == 0 {
                for r in 0..R {
                    prefetch(w.wrapping_add((r0 + R + r) * k + i));
                }
            }
            for (b, row) in acc.iter_mut().enumerate() {
                let xv = F4::load(xp.add((b0 + b) * mm.x_stride + i));
                for (a, v) in row.iter_mut().zip(&wv) {
                    *a = a.add(v.mul(xv));
                }
            }
            i += PL;
        }
        for (b, row) in acc.iter().enumerate() {
            let xb = xp.add((b0 + b) * mm.x_stride);
            for (r, a) in row.iter().enumerate() {
                let wr = w.add((r0 + r) * k);
                let mut d = reduce(a.array());
                for j in full..k {
                    d = madd(*wr.add(j), *xb.add(j), d);
                }
                let out = &mut y[(b0 + b) * mm.y_stride + o0 + r0 + r];
                *out = if accumulate { *out + d } else { d };
            }
        }
    }
}
