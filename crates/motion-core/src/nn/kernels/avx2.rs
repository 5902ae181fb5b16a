//! AVX2 + FMA + F16C row tiles for `Y = X Wᵀ` at small batches: the 256-bit counterpart of
//! [`super::avx512`], for the CPUs without AVX-512 (most gaming PCs). The shared driver
//! ([`super::row_tiles`]) walks them.
//!
//! Weight rows stay in their stored dtype and are widened in registers: `vcvtph2ps` for f16, a
//! 16-bit shift for bf16 (both exact). A tile holds `R` weight rows against `B` batch rows in
//! `R x B` independent 8-lane accumulators: each weight vector loaded serves `B` batch rows and
//! each input vector `R` weight rows. Two tile shapes, by batch:
//! - batch 1-3: 4 weight rows x 2 (or 1) batch rows: a batch-1 step streams weights, and 4
//!   accumulators per batch row hide the FMA latency;
//! - batch >= 4: 3 weight rows x 4 batch rows (12 accumulators + 3 weight + 1 input vector = the
//!   16 registers): 12 FMAs per 7 loads and 3 widenings, against 8 per 6 and 4 with 4 x 2 (on a
//!   Zen 4 core, 8-14 % faster at batch 8-32 on `[1536, 512]`, f16 and f32).
//!
//! The first batch group over a tile's weight rows prefetches the next tile's rows; the later
//! groups find the tile's rows in L1.
//!
//! A row's last `inputs % 8` elements are read as the row's last 8 with the lanes before them
//! cleared (rows shorter than 8 are copied into a zeroed buffer), so no element outside a row is
//! read. Every (batch row, output) gets the same arithmetic in any tile (one accumulator per
//! pair, the same lane-sum tree), so a character's numbers do not depend on the batch it runs in.
use super::{padded, row_tiles, RowKernels, Tiles};
use crate::nn::layout::MatMul;
use crate::nn::packed::Rows;
use std::arch::x86_64::*;
use std::marker::PhantomData;

/// A stored weight type and how 8 of them become one f32 vector.
trait Elem {
    type T: Copy + Default;
    /// Widens `p[0..8]`.
    unsafe fn load(p: *const Self::T) -> __m256;
}

struct F32;
struct F16;
struct Bf16;

impl Elem for F32 {
    type T = f32;
    #[inline(always)]
    unsafe fn load(p: *const f32) -> __m256 {
        unsafe { _mm256_loadu_ps(p) }
    }
}

impl Elem for F16 {
    type T = u16;
    #[inline(always)]
    unsafe fn load(p: *const u16) -> __m256 {
        unsafe { _mm256_cvtph_ps(_mm_loadu_si128(p.cast())) }
    }
}

impl Elem for Bf16 {
    type T = u16;
    #[inline(always)]
    unsafe fn load(p: *const u16) -> __m256 {
        unsafe {
            let wide = _mm256_cvtepu16_epi32(_mm_loadu_si128(p.cast()));
            _mm256_castsi256_ps(_mm256_slli_epi32::<16>(wide))
        }
    }
}

/// [`super::product_outputs`] on this path: `Y = X Wᵀ` (or `Y += X Wᵀ`) for the output columns
/// `outputs` of the layout `mm` over `rows` `[mm.outputs, mm.inputs]`.
///
/// # Safety
/// The CPU must run [`SimdPath::Avx2`](crate::nn::simd::SimdPath::Avx2) (AVX2, FMA, F16C); the
/// rest as [`super::product_outputs`].
#[target_feature(enable = "avx2,fma,f16c")]
pub(crate) unsafe fn product_outputs(
    mm: &MatMul,
    x: *const f32,
    rows: &Rows,
    y: *mut f32,
    accumulate: bool,
    outputs: std::ops::Range<usize>,
) {
    // SAFETY: forwarded from the caller.
    unsafe { super::rows_product::<Avx2>(mm, x, rows, y, accumulate, outputs) }
}

/// f32 lanes per vector.
const L: usize = 8;
/// Smallest batch for the 3 x 4 tiles.
const WIDE_BATCH: usize = 4;

/// This path's row kernels.
struct Avx2;

impl RowKernels for Avx2 {
    type F32 = Tile<F32>;
    type F16 = Tile<F16>;
    type Bf16 = Tile<Bf16>;

    #[inline(always)]
    unsafe fn drive<K: Tiles>(mm: &MatMul, x: *const f32, w: *const K::T, y: *mut f32, acc: bool) {
        let n = mm.outputs;
        // SAFETY: forwarded from the caller; the last call takes every row left.
        unsafe {
            if mm.batch >= WIDE_BATCH {
                let o = row_tiles::<K, 3, 4>(mm, x, w, y, n, 0, acc);
                row_tiles::<K, 1, 4>(mm, x, w, y, n, o, acc);
            } else {
                let o = row_tiles::<K, 4, 2>(mm, x, w, y, n, 0, acc);
                row_tiles::<K, 1, 2>(mm, x, w, y, n, o, acc);
            }
        }
    }
}

/// The tiles over weights of type `E`.
struct Tile<E>(PhantomData<E>);

impl<E: Elem> Tiles for Tile<E> {
    type T = E::T;
    /// Only the first batch group prefetches the next tile's rows.
    const FIRST_APART: bool = true;

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
        unsafe { tile::<E, R, B, FIRST>(x, xs, w, k, y, ys, accumulate) }
    }
}

/// [`Tiles::tile`]; `FIRST`: fetch the next `R` weight rows into L1 as this tile streams its own
/// (the later batch groups find this tile's rows in L1).
#[inline(always)]
unsafe fn tile<E: Elem, const R: usize, const B: usize, const FIRST: bool>(
    x: *const f32,
    xs: usize,
    w: *const E::T,
    k: usize,
    y: *mut f32,
    ys: usize,
    accumulate: bool,
) {
    // SAFETY: the caller's contract (`Tiles::tile`); the tail reads only the row's last
    // `k - full` elements.
    unsafe {
        let mut acc = [[_mm256_setzero_ps(); R]; B];
        let full = k / L * L;
        let mut i = 0;
        while i < full {
            let mut wv = [_mm256_setzero_ps(); R];
            for (r, v) in wv.iter_mut().enumerate() {
                *v = E::load(w.add(r * k + i));
            }
            if FIRST && R > 1 && i % 32 == 0 {
                // Fetch the next tile's rows one tile ahead (as the AVX-512 tiles), one prefetch per
                // row and 32 inputs (a cache line of f16 weights).
                for r in 0..R {
                    _mm_prefetch::<_MM_HINT_T0>(w.wrapping_add((R + r) * k + i).cast());
                }
            }
            for (b, row) in acc.iter_mut().enumerate() {
                let xv = _mm256_loadu_ps(x.add(b * xs + i));
                for (a, v) in row.iter_mut().zip(&wv) {
                    *a = _mm256_fmadd_ps(*v, xv, *a);
                }
            }
            i += L;
        }
        if i < k && full > 0 {
            // The row's last 8 elements (all inside the row) with the lanes before `i` cleared:
            // the tail's `k - i` elements sit in the top lanes. No copies: a `memcpy` per row
            // and tile cost the 162-input projection half its time.
            let first = _mm256_set1_epi32((L - (k - i)) as i32 - 1);
            let keep = _mm256_castsi256_ps(_mm256_cmpgt_epi32(
                _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
                first,
            ));
            let mut wv = [_mm256_setzero_ps(); R];
            for (r, v) in wv.iter_mut().enumerate() {
                *v = _mm256_and_ps(E::load(w.add(r * k + k - L)), keep);
            }
            for (b, row) in acc.iter_mut().enumerate() {
                let xv = _mm256_and_ps(_mm256_loadu_ps(x.add(b * xs + k - L)), keep);
                for (a, v) in row.iter_mut().zip(&wv) {
                    *a = _mm256_fmadd_ps(*v, xv, *a);
                }
            }
        } else if i < k {
            // Rows shorter than one vector: copied into zeroed buffers.
            let rest = k - i;
            let mut wv = [_mm256_setzero_ps(); R];
            for (r, v) in wv.iter_mut().enumerate() {
                let buf = padded::<E::T, L>(w.add(r * k + i), rest);
                *v = E::load(buf.as_ptr());
            }
            for (b, row) in acc.iter_mut().enumerate() {
                let buf = padded::<f32, L>(x.add(b * xs + i), rest);
                let xv = _mm256_loadu_ps(buf.as_ptr());
                for (a, v) in row.iter_mut().zip(&wv) {
                    *a = _mm256_fmadd_ps(*v, xv, *a);
                }
            }
        }
        let zero = _mm256_setzero_ps();
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
            if r < R {
                // The last 1-3 rows in one `reduce4`, zeros in the unused lanes: a lane's sum is
                // the same addition tree in any position, so a row's result does not depend on
                // the tile it falls in.
                let lane = |q: usize| if r + q < R { row[r + q] } else { zero };
                let mut sums = [0.0f32; 4];
                _mm_storeu_ps(
                    sums.as_mut_ptr(),
                    reduce4(lane(0), lane(1), lane(2), lane(3)),
                );
                for (q, &s) in sums.iter().enumerate().take(R - r) {
                    let out = yb.add(r + q);
                    *out = if accumulate { *out + s } else { s };
                }
            }
        }
    }
}

/// The lane sums of four vectors, `[Σa, Σb, Σc, Σd]`, in a fixed addition tree.
#[inline(always)]
unsafe fn reduce4(a: __m256, b: __m256, c: __m256, d: __m256) -> __m128 {
    // SAFETY: register-only operations of the enabled features.
    unsafe {
        let ab = _mm256_hadd_ps(a, b);
        let cd = _mm256_hadd_ps(c, d);
        let abcd = _mm256_hadd_ps(ab, cd);
        _mm_add_ps(
            _mm256_castps256_ps128(abcd),
            _mm256_extractf128_ps::<1>(abcd),
        )
    }
}
