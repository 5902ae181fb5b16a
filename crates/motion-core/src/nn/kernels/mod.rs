//! The row kernels of `Y = X Wᵀ` at small batches, one module per [`SimdPath`], and the driver
//! they share.
//!
//! - [`portable`]: plain Rust over 128-bit vectors ([`portable::vec128`]: SSE2, WebAssembly
//!   SIMD128, NEON or an array), every target;
//! - `avx2`: AVX2 + FMA + F16C, x86-64 only;
//! - `avx512`: AVX-512 F/BW/VL + F16C, x86-64 only;
//! - `neon`: aarch64 NEON, aarch64 only.
//!
//! Each path supplies its register tiles ([`Tiles`]: `R` weight rows against `B` batch rows, the
//! stored dtype widened in registers, ragged input widths handled without reading outside a row)
//! and picks its tile shapes (they follow from its register file, so they differ by path). The
//! rest lives here once:
//! - [`row_tiles`] and its batch loop walk a product in a path's tiles: weight rows are the outer
//!   loop, so every weight is read from memory once per product whatever the batch; on the paths
//!   whose tiles ask for it ([`Tiles::FIRST_APART`]) the first batch group over a tile's rows is
//!   told so (`FIRST`), the group that prefetches the next tile's rows;
//! - [`RowKernels`] and [`rows_product`] map the stored dtype ([`Rows`]) to a path's tiles and
//!   restrict a product to a range of outputs (for the thread split in [`super::gemm`]);
//! - `padded` copies a row shorter than one vector into a zeroed buffer (AVX2, NEON);
//! - [`product_outputs`] runs the kernels of a given path.
//!
//! The shared driver is generic and `#[inline(always)]`: it is compiled into each path's
//! `#[target_feature]` entry point with that path's features, and the tiles it calls are inlined
//! into it, so it costs nothing against a per-path copy. What stays per path, besides the tiles
//! themselves: the vector types and their loads (an `Elem` trait per path), the lane reductions,
//! and the tail handling of a ragged row (masked loads on AVX-512, the row's last vector with its
//! leading lanes cleared on AVX2 and NEON, scalar on the portable path), all of them intrinsics of
//! one instruction set.
//!
//! Every `(batch row, output)` pair gets the same arithmetic in any tile (one accumulator, the
//! same lane-sum tree), so a row's result does not depend on the batch it runs in or the tile its
//! output falls in.
//!
//! The panel GEMM of large batches keeps its per-path kernels in [`super::sgemm_panels`] and the
//! gate non-linearities theirs in [`super::gates`]; the tests of this module cover all three
//! families on every path.
use super::layout::MatMul;
use super::packed::PackedMatrix;
use super::simd::SimdPath;

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2;
#[cfg(target_arch = "x86_64")]
pub(crate) mod avx512;
#[cfg(target_arch = "aarch64")]
pub(crate) mod neon;
pub(crate) mod portable;
#[cfg(test)]
pub(crate) mod tests;

/// `Y = X Wᵀ` (or `Y += X Wᵀ`) for the outputs `outputs` of the layout `mm` (weight rows
/// `outputs`, columns `outputs` of every row of `Y`) on the row kernels of `path`.
///
/// # Safety
/// The CPU runs `path`; `mm.inputs > 0`; `x` and `y` point at slices long enough for the whole
/// layout `mm` (as `MatMul::run` asserts); `outputs` lies inside `0..mm.outputs`; no other thread
/// reads or writes those columns of `Y` meanwhile (disjoint ranges may run at once).
pub(crate) unsafe fn product_outputs(
    path: SimdPath,
    mm: &MatMul,
    x: *const f32,
    w: &PackedMatrix,
    y: *mut f32,
    accumulate: bool,
    outputs: std::ops::Range<usize>,
) {
    // SAFETY: forwarded from the caller (the path's features included).
    unsafe {
        match path {
            #[cfg(target_arch = "x86_64")]
            SimdPath::Avx512 => avx512::product_outputs(mm, x, w.rows(), y, accumulate, outputs),
            #[cfg(target_arch = "x86_64")]
            SimdPath::Avx2 => avx2::product_outputs(mm, x, w.rows(), y, accumulate, outputs),
            #[cfg(target_arch = "aarch64")]
            SimdPath::Neon => neon::product_outputs(mm, x, w.rows(), y, accumulate, outputs),
            // The portable path, and the paths this target cannot have (never selected).
            _ => portable::product_outputs(mm, x, w, y, accumulate, outputs),
        }
    }
}

/// The register tiles of one path over one stored weight type.
pub(crate) trait Tiles {
    /// The stored element: `f32`, or the bits of an f16 or bf16.
    type T;

    /// Whether the tiles tell the first batch group over their weight rows from the others
    /// (`FIRST`). When false the driver runs every group with `FIRST = false`, so each tile shape
    /// is compiled once.
    const FIRST_APART: bool;

    /// `Y[b, r] (+)= Σ_i X[b, i] W[r, i]` for `r < R`, `b < B` over `k` inputs, `X` and `Y` with
    /// row strides `xs` and `ys`, `W` with row stride `k`. `FIRST` (only with
    /// [`Tiles::FIRST_APART`]): the first batch group over these weight rows, the one that
    /// prefetches the next `R` rows.
    ///
    /// # Safety
    /// The CPU has the path's features; rows `0..R` of `w`, the first `k` elements of rows
    /// `0..B` of `x` and elements `0..R` of rows `0..B` of `y` are valid (and `y`'s exclusively
    /// this call's); `k > 0`.
    #[allow(clippy::too_many_arguments)]
    unsafe fn tile<const R: usize, const B: usize, const FIRST: bool>(
        x: *const f32,
        xs: usize,
        w: *const Self::T,
        k: usize,
        y: *mut f32,
        ys: usize,
        accumulate: bool,
    );
}

/// Weight rows `start..` of `w` (outputs `start..` of `y`) in tiles of `R` rows against every
/// batch row of `mm` in groups of `B`, for as many whole tiles as fit below `n` rows; returns the
/// first row not done. A path chains calls with shrinking `R` (ending at 1) to cover all `n` rows.
///
/// # Safety
/// The CPU has `K`'s features; `w` holds `n` rows of `mm.inputs > 0` elements; `x` holds the
/// batch rows of `mm` and `y` its output rows, `n` columns wide from `y` (exclusively this
/// call's).
#[inline(always)]
pub(crate) unsafe fn row_tiles<K: Tiles, const R: usize, const B: usize>(
    mm: &MatMul,
    x: *const f32,
    w: *const K::T,
    y: *mut f32,
    n: usize,
    start: usize,
    accumulate: bool,
) -> usize {
    let k = mm.inputs;
    let mut o = start;
    // SAFETY: rows `o..o + R` of `w` and columns `o..o + R` of `y` lie inside the caller's `n`.
    unsafe {
        while o + R <= n {
            batch_groups::<K, R, B>(mm, x, w.add(o * k), y.add(o), accumulate);
            o += R;
        }
    }
    o
}

/// Every batch row of `mm` against weight rows `w[0..R]`: groups of `B` (the first one `FIRST`
/// if [`Tiles::FIRST_APART`]), then the last `batch % B` rows in one smaller tile.
#[inline(always)]
unsafe fn batch_groups<K: Tiles, const R: usize, const B: usize>(
    mm: &MatMul,
    x: *const f32,
    w: *const K::T,
    y: *mut f32,
    accumulate: bool,
) {
    let (k, batch, xs, ys) = (mm.inputs, mm.batch, mm.x_stride, mm.y_stride);
    // SAFETY: every tile reads rows `b..b + B` of `x` (first `k` elements) and writes columns
    // `0..R` of rows `b..b + B` of `y`, with `b + B <= batch`: inside the caller's layout.
    unsafe {
        let mut b = 0;
        if K::FIRST_APART && B <= batch {
            K::tile::<R, B, true>(x, xs, w, k, y, ys, accumulate);
            b = B;
        }
        while b + B <= batch {
            K::tile::<R, B, false>(x.add(b * xs), xs, w, k, y.add(b * ys), ys, accumulate);
            b += B;
        }
        let (x, y) = (x.add(b * xs), y.add(b * ys));
        macro_rules! rest {
            ($($n:literal)*) => {
                match batch - b {
                    $($n if $n < B => {
                        if K::FIRST_APART && batch < B {
                            K::tile::<R, $n, true>(x, xs, w, k, y, ys, accumulate)
                        } else {
                            K::tile::<R, $n, false>(x, xs, w, k, y, ys, accumulate)
                        }
                    })*
                    _ => {}
                }
            };
        }
        rest!(1 2 3);
    }
}

/// A path's row kernels: its tiles for each stored dtype and the tile shapes it walks them in
/// (the vector paths; the portable path widens 16-bit rows into a buffer of f32 instead).
#[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
pub(crate) trait RowKernels {
    /// Tiles over f32 rows.
    type F32: Tiles<T = f32>;
    /// Tiles over f16 rows (bit patterns).
    type F16: Tiles<T = u16>;
    /// Tiles over bf16 rows (bit patterns).
    type Bf16: Tiles<T = u16>;

    /// The whole product `mm` (weight rows from `w`, output columns from `y`) in this path's
    /// tile shapes, by way of [`row_tiles`].
    ///
    /// # Safety
    /// As [`row_tiles`] with `n = mm.outputs`.
    unsafe fn drive<K: Tiles>(
        mm: &MatMul,
        x: *const f32,
        w: *const K::T,
        y: *mut f32,
        accumulate: bool,
    );
}

/// The outputs `outputs` of the product `mm` over `rows` on the kernels `P` (see
/// [`product_outputs`]): the dtype picks the tiles, the range offsets the weight rows and output
/// columns. `#[inline(always)]`: each path's `#[target_feature]` entry point compiles it.
///
/// # Safety
/// As [`product_outputs`] for `P`'s path, with `rows` `[mm.outputs, mm.inputs]`.
#[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
#[inline(always)]
pub(crate) unsafe fn rows_product<P: RowKernels>(
    mm: &MatMul,
    x: *const f32,
    rows: &super::packed::Rows,
    y: *mut f32,
    accumulate: bool,
    outputs: std::ops::Range<usize>,
) {
    use super::packed::Rows;
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
            Rows::F32(w) => P::drive::<P::F32>(&part, x, w.as_ptr().add(first * k), y, accumulate),
            Rows::F16(w) => P::drive::<P::F16>(&part, x, w.as_ptr().add(first * k), y, accumulate),
            Rows::Bf16(w) => {
                P::drive::<P::Bf16>(&part, x, w.as_ptr().add(first * k), y, accumulate)
            }
        }
    }
}

/// `src[0..n]` followed by zeros (`n < N`): a full-vector load of the buffer reads nothing past
/// the row.
///
/// # Safety
/// `src[0..n]` is readable and `n <= N`.
#[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
#[inline(always)]
pub(crate) unsafe fn padded<T: Copy + Default, const N: usize>(src: *const T, n: usize) -> [T; N] {
    let mut buf = [T::default(); N];
    // SAFETY: the caller's contract.
    unsafe { std::ptr::copy_nonoverlapping(src, buf.as_mut_ptr(), n) };
    buf
}
