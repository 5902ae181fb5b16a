//! AVX-512 row tiles for `Y = X Wᵀ` at small batches (see
//! [`crate::nn::gemm::row_kernel_max_batch`]), over weight rows stored as f32, f16 or bf16
//! (widened to f32 in registers: `vcvtph2ps` for f16, a 16-bit shift for bf16, both exact). The
//! shared driver ([`super::row_tiles`]) walks them.
//!
//! A tile holds `RW` weight rows against `RB` batch rows in `RW x RB` independent 16-lane
//! accumulators: each weight vector loaded (and widened) serves `RB` batch rows, each input vector
//! `RW` weight rows. Weight rows are the outer loop, so every weight is read from cache once per
//! product whatever the batch (the inputs, at most 16 rows, stay in L1/L2). Ragged input widths
//! use masked loads, so no element outside a row is read (prefetch hints may name lines past
//! the matrix; they never fault).
use super::{row_tiles, RowKernels, Tiles};
use crate::nn::layout::MatMul;
use crate::nn::packed::Rows;
use std::arch::x86_64::*;
use std::marker::PhantomData;

/// A stored weight type and how 16 of them become one f32 vector.
trait Elem {
    type T;
    /// Widens `p[0..16]`.
    unsafe fn load(p: *const Self::T) -> __m512;
    /// Widens the elements of `p[0..16]` selected by `mask`, zero elsewhere (nothing else read).
    unsafe fn load_masked(p: *const Self::T, mask: __mmask16) -> __m512;
}

struct F32;
struct F16;
struct Bf16;

impl Elem for F32 {
    type T = f32;
    #[inline(always)]
    unsafe fn load(p: *const f32) -> __m512 {
        unsafe { _mm512_loadu_ps(p) }
    }
    #[inline(always)]
    unsafe fn load_masked(p: *const f32, mask: __mmask16) -> __m512 {
        unsafe { _mm512_maskz_loadu_ps(mask, p) }
    }
}

impl Elem for F16 {
    type T = u16;
    #[inline(always)]
    unsafe fn load(p: *const u16) -> __m512 {
        unsafe { _mm512_cvtph_ps(_mm256_loadu_si256(p.cast())) }
    }
    #[inline(always)]
    unsafe fn load_masked(p: *const u16, mask: __mmask16) -> __m512 {
        unsafe { _mm512_cvtph_ps(_mm256_maskz_loadu_epi16(mask, p.cast())) }
    }
}

impl Elem for Bf16 {
    type T = u16;
    #[inline(always)]
    unsafe fn load(p: *const u16) -> __m512 {
        unsafe {
            let wide = _mm512_cvtepu16_epi32(_mm256_loadu_si256(p.cast()));
            _mm512_castsi512_ps(_mm512_slli_epi32::<16>(wide))
        }
    }
    #[inline(always)]
    unsafe fn load_masked(p: *const u16, mask: __mmask16) -> __m512 {
        unsafe {
            let wide = _mm512_cvtepu16_epi32(_mm256_maskz_loadu_epi16(mask, p.cast()));
            _mm512_castsi512_ps(_mm512_slli_epi32::<16>(wide))
        }
    }
}

/// [`super::product_outputs`] on this path: `Y = X Wᵀ` (or `Y += X Wᵀ`) for the output columns
/// `outputs` of the layout `mm` over `rows` `[mm.outputs, mm.inputs]`.
///
/// # Safety
/// The CPU must run [`SimdPath::Avx512`](crate::nn::simd::SimdPath::Avx512); the rest as
/// [`super::product_outputs`].
#[target_feature(enable = "avx512f,avx512bw,avx512vl,f16c")]
pub(crate) unsafe fn product_outputs(
    mm: &MatMul,
    x: *const f32,
    rows: &Rows,
    y: *mut f32,
    accumulate: bool,
    outputs: std::ops::Range<usize>,
) {
    // SAFETY: forwarded from the caller.
    unsafe { super::rows_product::<Avx512>(mm, x, rows, y, accumulate, outputs) }
}

/// Weight rows per tile: 4 rows x 4 batch rows = 16 accumulators + 4 weight vectors + 1 input
/// vector, inside the 32 vector registers. At batch 1, 4 rows (4 streams, with the prefetch
/// below) measured faster than 8 on Zen 5.
const RW: usize = 4;
/// Batch rows per tile.
const RB: usize = 4;

/// This path's row kernels.
struct Avx512;

impl RowKernels for Avx512 {
    type F32 = Tile<F32>;
    type F16 = Tile<F16>;
    type Bf16 = Tile<Bf16>;

    #[inline(always)]
    unsafe fn drive<K: Tiles>(mm: &MatMul, x: *const f32, w: *const K::T, y: *mut f32, acc: bool) {
        let n = mm.outputs;
        // SAFETY: forwarded from the caller; the last call takes every row left.
        unsafe {
            let o = row_tiles::<K, RW, RB>(mm, x, w, y, n, 0, acc);
            row_tiles::<K, 1, RB>(mm, x, w, y, n, o, acc);
        }
    }
}

/// The tiles over weights of type `E`.
struct Tile<E>(PhantomData<E>);

impl<E: Elem> Tiles for Tile<E> {
    type T = E::T;
    /// Every batch group prefetches the next tile's rows.
    const FIRST_APART: bool = false;

    #[inline(always)]
    unsafe fn tile<const R: usize, const B: usize, const FIRST: bool>(
        x: *const f32,
        xs: usize,
        w: *const E::T,
        k: usize,
        y: *mut f32,
        ys: usize,
        accumulate: bool,
    ) {
        // SAFETY: forwarded from the caller.
        unsafe { tile::<E, R, B>(x, xs, w, k, y, ys, accumulate) }
    }
}

/// [`Tiles::tile`], prefetching the next `R` weight rows in every batch group.
#[inline(always)]
unsafe fn tile<E: Elem, const R: usize, const B: usize>(
    x: *const f32,
    xs: usize,
    w: *const E::T,
    k: usize,
    y: *mut f32,
    ys: usize,
    accumulate: bool,
) {
    // SAFETY: the caller's contract (`Tiles::tile`); the tail uses masked loads limited to the
    // row's last elements.
    unsafe {
        let mut acc = [[_mm512_setzero_ps(); R]; B];
        let full = k / 16 * 16;
        let mut i = 0;
        while i < full {
            let mut wv = [_mm512_setzero_ps(); R];
            for (r, v) in wv.iter_mut().enumerate() {
                *v = E::load(w.add(r * k + i));
            }
            // Rows are short streams (2 KB at 512 f32 inputs) that the hardware prefetcher
            // barely learns before they end: fetch the next tile's rows one tile ahead.
            if R > 1 {
                for r in 0..R {
                    _mm_prefetch::<_MM_HINT_T0>(w.wrapping_add((R + r) * k + i).cast());
                }
            }
            for (b, row) in acc.iter_mut().enumerate() {
                let xv = _mm512_loadu_ps(x.add(b * xs + i));
                for (a, v) in row.iter_mut().zip(&wv) {
                    *a = _mm512_fmadd_ps(*v, xv, *a);
                }
            }
            i += 16;
        }
        if i < k {
            let mask = ((1u32 << (k - i)) - 1) as __mmask16;
            let mut wv = [_mm512_setzero_ps(); R];
            for (r, v) in wv.iter_mut().enumerate() {
                *v = E::load_masked(w.add(r * k + i), mask);
            }
            for (b, row) in acc.iter_mut().enumerate() {
                let xv = _mm512_maskz_loadu_ps(mask, x.add(b * xs + i));
                for (a, v) in row.iter_mut().zip(&wv) {
                    *a = _mm512_fmadd_ps(*v, xv, *a);
                }
            }
        }
        for (b, row) in acc.iter().enumerate() {
            let yb = y.add(b * ys);
            let mut r = 0;
            while r + 4 <= R {
                let mut s = reduce4(row[r], row[r + 1], row[r + 2], row[r + 3]);
                if accumulate {
                    s = _mm_add_ps(_mm_loadu_ps(yb.add(r)), s);
                }
                _mm_storeu_ps(yb.add(r), s);
                r += 4;
            }
            while r < R {
                let zero = _mm512_setzero_ps();
                // Same addition tree as a lane of `reduce4`, so a row's sum does not depend on
                // whether it falls in a 4-row tile or the tail.
                let s = _mm_cvtss_f32(reduce4(row[r], zero, zero, zero));
                let out = yb.add(r);
                *out = if accumulate { *out + s } else { s };
                r += 1;
            }
        }
    }
}

/// The lane sums of four vectors, `[Σa, Σb, Σc, Σd]`, in a fixed addition tree.
#[inline(always)]
unsafe fn reduce4(a: __m512, b: __m512, c: __m512, d: __m512) -> __m128 {
    // SAFETY: register-only operations of the enabled features.
    unsafe {
        let ab = _mm256_hadd_ps(fold(a), fold(b));
        let cd = _mm256_hadd_ps(fold(c), fold(d));
        let abcd = _mm256_hadd_ps(ab, cd);
        _mm_add_ps(
            _mm256_castps256_ps128(abcd),
            _mm256_extractf128_ps::<1>(abcd),
        )
    }
}

/// Low half plus high half.
#[inline(always)]
unsafe fn fold(v: __m512) -> __m256 {
    // SAFETY: register-only operations of the enabled features.
    unsafe {
        _mm256_add_ps(
            _mm512_castps512_ps256(v),
            _mm256_castpd_ps(_mm512_extractf64x4_pd::<1>(_mm512_castps_pd(v))),
        )
    }
}
