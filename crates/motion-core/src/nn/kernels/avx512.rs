//! AVX-512 row kernels for `Y = X Wᵀ` at small batches (see [`crate::nn::gemm::row_kernel_max_batch`]),
//! over weight rows stored as f32, f16 or bf16 (widened to f32 in registers: `vcvtph2ps` for f16,
//! a 16-bit shift for bf16, both exact).
//!
//! A tile holds `RW` weight rows against `RB` batch rows in `RW x RB` independent 16-lane
//! accumulators: each weight vector loaded (and widened) serves `RB` batch rows, each input vector
//! `RW` weight rows. Weight rows are the outer loop, so every weight is read from cache once per
//! product whatever the batch (the inputs, at most 16 rows, stay in L1/L2). Ragged input widths
//! use masked loads, so no element outside a row is read (prefetch hints may name lines past
//! the matrix; they never fault).
use crate::nn::layout::MatMul;
use crate::nn::packed::Rows;
use std::arch::x86_64::*;

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

/// `Y = X Wᵀ` (or `Y += X Wᵀ`) for the layout `mm` over `rows` `[mm.outputs, mm.inputs]`.
///
/// # Safety
/// The CPU must run [`crate::nn::simd::SimdPath::Avx512`], `mm.inputs > 0`, and the slices must be long enough for the
/// layout (as `MatMul::run` asserts).
#[target_feature(enable = "avx512f,avx512bw,avx512vl,f16c")]
pub(crate) unsafe fn product(mm: &MatMul, x: &[f32], rows: &Rows, y: &mut [f32], accumulate: bool) {
    // SAFETY: forwarded from the caller.
    unsafe {
        product_outputs(
            mm,
            x.as_ptr(),
            rows,
            y.as_mut_ptr(),
            accumulate,
            0..mm.outputs,
        )
    }
}

/// [`product`] for the output columns `outputs` only (weight rows `outputs`, columns `outputs`
/// of every row of `Y`): disjoint ranges may run on different threads at once.
///
/// # Safety
/// As [`product`], with `x` and `y` pointing at slices long enough for the whole layout `mm`,
/// `outputs` inside `0..mm.outputs`, and no other thread writing those columns of `Y`.
#[target_feature(enable = "avx512f,avx512bw,avx512vl,f16c")]
pub(crate) unsafe fn product_outputs(
    mm: &MatMul,
    x: *const f32,
    rows: &Rows,
    y: *mut f32,
    accumulate: bool,
    outputs: std::ops::Range<usize>,
) {
    let part = MatMul {
        outputs: outputs.len(),
        ..*mm
    };
    let (first, k) = (outputs.start, mm.inputs);
    // SAFETY: forwarded from the caller; `drive` reads and writes only inside the layout `part`,
    // which is the part of `mm` at weight row `first` and output column `first`.
    unsafe {
        let y = y.add(first);
        match rows {
            Rows::F32(w) => drive::<F32>(&part, x, w.as_ptr().add(first * k), y, accumulate),
            Rows::F16(w) => drive::<F16>(&part, x, w.as_ptr().add(first * k), y, accumulate),
            Rows::Bf16(w) => drive::<Bf16>(&part, x, w.as_ptr().add(first * k), y, accumulate),
        }
    }
}

/// Weight rows per tile: 4 rows x 4 batch rows = 16 accumulators + 4 weight vectors + 1 input
/// vector, inside the 32 vector registers. At batch 1, 4 rows (4 streams, with the prefetch
/// below) measured faster than 8 on Zen 5.
const RW: usize = 4;
/// Batch rows per tile.
const RB: usize = 4;

#[inline(always)]
unsafe fn drive<E: Elem>(mm: &MatMul, x: *const f32, w: *const E::T, y: *mut f32, acc: bool) {
    let (n, k, batch) = (mm.outputs, mm.inputs, mm.batch);
    let (xs, ys) = (mm.x_stride, mm.y_stride);
    // SAFETY: every tile reads rows `o..o + rw` of `w`, rows `b..b + rb` of `x` (first `k`
    // elements) and writes columns `o..o + rw` of rows `b..b + rb` of `y`, all inside the layout.
    unsafe {
        let mut o = 0;
        while o + RW <= n {
            batch_tiles::<E, RW>(x, xs, w.add(o * k), k, y.add(o), ys, batch, acc);
            o += RW;
        }
        while o < n {
            batch_tiles::<E, 1>(x, xs, w.add(o * k), k, y.add(o), ys, batch, acc);
            o += 1;
        }
    }
}

/// All batch rows against weight rows `w[0..R]`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn batch_tiles<E: Elem, const R: usize>(
    x: *const f32,
    xs: usize,
    w: *const E::T,
    k: usize,
    y: *mut f32,
    ys: usize,
    batch: usize,
    acc: bool,
) {
    // SAFETY: see `drive`.
    unsafe {
        let mut b = 0;
        while b + RB <= batch {
            tile::<E, R, RB>(x.add(b * xs), xs, w, k, y.add(b * ys), ys, acc);
            b += RB;
        }
        match batch - b {
            1 => tile::<E, R, 1>(x.add(b * xs), xs, w, k, y.add(b * ys), ys, acc),
            2 => tile::<E, R, 2>(x.add(b * xs), xs, w, k, y.add(b * ys), ys, acc),
            3 => tile::<E, R, 3>(x.add(b * xs), xs, w, k, y.add(b * ys), ys, acc),
            _ => {}
        }
    }
}

/// `Y[b, r] (+)= Σ_i X[b, i] W[r, i]` for `r < R`, `b < B`.
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
    // SAFETY: see `drive`; the tail uses masked loads limited to the row's last elements.
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
