//! Portable row tiles for `Y = X Wᵀ` at small batches: plain Rust over 128-bit vectors
//! ([`vec128`]: SSE2 on every x86-64, WebAssembly SIMD128, NEON, an array elsewhere), what WASM
//! and unknown CPUs run. The shared driver ([`super::row_tiles`]) walks them.
//!
//! A tile holds `R` weight rows against `B` batch rows in `R x B` accumulators of [`PL`] lanes
//! (4 x 2 at batch 2 and up, 8 x 1 at batch 1): 8 accumulator vectors plus the weight and input
//! vectors fit the 16 vector registers of SSE2 and SIMD128, so nothing is spilled to the stack in
//! the inner loop (a 4 x 16-lane tile would keep 64 accumulator floats and spill them on SSE2).
//! Each weight vector loaded serves every batch row of the tile.
//!
//! A row's sum does not depend on the tile it falls in: every `(batch row, output)` pair
//! accumulates its lanes in the same order and reduces them in the same tree, so a batch row's
//! result is the same at every batch size.
//!
//! 16-bit rows are widened [`WIDEN_ROWS`] at a time into a stack buffer (a branch-free exact
//! conversion the compiler vectorizes) and tiled from there; without AVX-512 a 16-bit matrix also
//! holds an f32 copy of its rows for the large-batch GEMM (see [`crate::nn::packed`]), which these
//! kernels then read directly.
use super::{row_tiles, Tiles};
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

/// [`super::product_outputs`] on this path: `Y = X Wᵀ` (or `Y += X Wᵀ`) for the output columns
/// `outputs` of the layout `mm` over `w`.
///
/// # Safety
/// As [`super::product_outputs`].
pub(crate) unsafe fn product_outputs(
    mm: &MatMul,
    x: *const f32,
    w: &PackedMatrix,
    y: *mut f32,
    accumulate: bool,
    outputs: std::ops::Range<usize>,
) {
    let part = MatMul {
        outputs: outputs.len(),
        ..*mm
    };
    let rows = outputs.start * mm.inputs..outputs.end * mm.inputs;
    // SAFETY: forwarded from the caller; `part` is the part of `mm` at weight row and output
    // column `outputs.start`.
    unsafe {
        let y = y.add(outputs.start);
        if let Some(f32_rows) = w.f32_rows() {
            drive(
                &part,
                x,
                f32_rows[rows].as_ptr(),
                part.outputs,
                y,
                accumulate,
            );
            return;
        }
        match w.rows() {
            Rows::F32(w) => drive(&part, x, w[rows].as_ptr(), part.outputs, y, accumulate),
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
}

/// The `n` f32 weight rows at `w` (outputs `0..n` of `y`) in this path's tile shapes: at batch 1
/// 8 x 1 tiles, then 4 x 2 (or 4 x 1), then single rows.
///
/// # Safety
/// As [`super::row_tiles`].
#[inline(always)]
unsafe fn drive(mm: &MatMul, x: *const f32, w: *const f32, n: usize, y: *mut f32, acc: bool) {
    // SAFETY: forwarded from the caller; the last call takes every row left.
    unsafe {
        let mut o = 0;
        if mm.batch == 1 {
            o = row_tiles::<Tile, 8, 1>(mm, x, w, y, n, o, acc);
        }
        o = row_tiles::<Tile, 4, 2>(mm, x, w, y, n, o, acc);
        row_tiles::<Tile, 1, 2>(mm, x, w, y, n, o, acc);
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
///
/// # Safety
/// As [`super::product_outputs`] for the whole layout `mm`, `w` its `[mm.outputs, mm.inputs]`
/// rows.
#[inline(always)]
unsafe fn widened(
    mm: &MatMul,
    x: *const f32,
    w: &[u16],
    widen: impl Fn(u16) -> f32 + Copy,
    y: *mut f32,
    accumulate: bool,
) {
    let k = mm.inputs;
    let group_rows = (WIDEN_BUFFER / k).min(WIDEN_ROWS);
    if group_rows == 0 {
        // SAFETY: forwarded from the caller.
        unsafe { wide_rows(mm, x, w, widen, y, accumulate) };
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
        // SAFETY: `group` holds `n` rows; outputs `o..o + n` lie inside the caller's layout.
        unsafe { drive(mm, x, group.as_ptr(), n, y.add(o), accumulate) };
        o += n;
    }
}

/// Rows longer than the widening buffer: one dot product per output, widened on the fly, in the
/// same lane order and reduction as the tiles.
///
/// # Safety
/// As [`widened`].
#[cold]
unsafe fn wide_rows(
    mm: &MatMul,
    x: *const f32,
    w: &[u16],
    widen: impl Fn(u16) -> f32 + Copy,
    y: *mut f32,
    accumulate: bool,
) {
    let k = mm.inputs;
    let full = k / PL * PL;
    for b in 0..mm.batch {
        // SAFETY: batch row `b` of `x` holds `k` inputs (the caller's contract).
        let xb = unsafe { std::slice::from_raw_parts(x.add(b * mm.x_stride), k) };
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
            // SAFETY: output `o` of batch row `b` lies inside the caller's layout.
            unsafe {
                let out = y.add(b * mm.y_stride + o);
                *out = if accumulate { *out + d } else { d };
            }
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

/// The tiles over f32 weight rows.
struct Tile;

impl Tiles for Tile {
    type T = f32;
    /// Only the first batch group prefetches the next tile's rows.
    const FIRST_APART: bool = true;

    /// `FIRST` (in tiles of more than one row): ask for the next `R` weight rows (one line of 16
    /// f32s per row every 16 inputs) as this tile streams its own, so that the batch groups after
    /// the first find them in L1.
    #[inline(always)]
    unsafe fn tile<const R: usize, const B: usize, const FIRST: bool>(
        x: *const f32,
        xs: usize,
        w: *const f32,
        k: usize,
        y: *mut f32,
        ys: usize,
        accumulate: bool,
    ) {
        let full = k / PL * PL;
        let mut acc = [[F4::zero(); R]; B];
        // SAFETY: every read is of row `r < R` of `w` or row `b < B` of `x`, at an element
        // `< k`, every write of element `r < R` of row `b < B` of `y` (the caller's contract).
        unsafe {
            let mut i = 0;
            while i < full {
                let mut wv = [F4::zero(); R];
                for (r, v) in wv.iter_mut().enumerate() {
                    *v = F4::load(w.add(r * k + i));
                }
                if FIRST && R > 1 && i % 16 == 0 {
                    for r in 0..R {
                        prefetch(w.wrapping_add((R + r) * k + i));
                    }
                }
                for (b, row) in acc.iter_mut().enumerate() {
                    let xv = F4::load(x.add(b * xs + i));
                    for (a, v) in row.iter_mut().zip(&wv) {
                        *a = a.add(v.mul(xv));
                    }
                }
                i += PL;
            }
            for (b, row) in acc.iter().enumerate() {
                let xb = x.add(b * xs);
                for (r, a) in row.iter().enumerate() {
                    let wr = w.add(r * k);
                    let mut d = reduce(a.array());
                    for j in full..k {
                        d = madd(*wr.add(j), *xb.add(j), d);
                    }
                    let out = y.add(b * ys + r);
                    *out = if accumulate { *out + d } else { d };
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn f16_widening_is_exact_for_every_bit_pattern() {
        for h in 0..=u16::MAX {
            let want = half::f16::from_bits(h).to_f32();
            let got = super::f16_to_f32(h);
            if want.is_nan() {
                assert!(got.is_nan(), "{h:#06x}");
                assert_eq!(got.to_bits() & 0x8000_0000, want.to_bits() & 0x8000_0000);
            } else {
                assert_eq!(got.to_bits(), want.to_bits(), "{h:#06x}");
            }
        }
    }
}
