//! aarch64 NEON row tiles for `Y = X Wᵀ` at small batches: the 128-bit counterpart of the AVX2
//! tiles (`RW` weight rows x `RB` batch rows of 4-lane accumulators, walked by the shared driver
//! [`super::row_tiles`]).
//!
//! Weight rows stay in their stored dtype and are widened in registers: `fcvtl` for f16 (through
//! `asm!`, as Rust's f16 NEON intrinsics are not stable), a 16-bit shift (`ushll`) for bf16; both
//! are exact. A row's last `inputs % 4` elements are read as the row's last 4 with the lanes
//! before them cleared (rows shorter than 4 are copied into a zeroed buffer), so no element
//! outside a row is read.
use super::{padded, row_tiles, RowKernels, Tiles};
use crate::nn::layout::MatMul;
use crate::nn::packed::Rows;
use std::arch::aarch64::*;
use std::arch::asm;
use std::marker::PhantomData;

/// A stored weight type and how 4 of them become one f32 vector.
trait Elem {
    type T: Copy + Default;
    /// Widens `p[0..4]`.
    unsafe fn load(p: *const Self::T) -> float32x4_t;
}

struct F32;
struct F16;
struct Bf16;

impl Elem for F32 {
    type T = f32;
    #[inline(always)]
    unsafe fn load(p: *const f32) -> float32x4_t {
        unsafe { vld1q_f32(p) }
    }
}

impl Elem for F16 {
    type T = u16;
    #[inline(always)]
    unsafe fn load(p: *const u16) -> float32x4_t {
        unsafe {
            let h = vld1_u16(p);
            let out: float32x4_t;
            asm!("fcvtl {o:v}.4s, {i:v}.4h", o = lateout(vreg) out, i = in(vreg) h,
                 options(pure, nomem, nostack, preserves_flags));
            out
        }
    }
}

impl Elem for Bf16 {
    type T = u16;
    #[inline(always)]
    unsafe fn load(p: *const u16) -> float32x4_t {
        unsafe { vreinterpretq_f32_u32(vshll_n_u16::<16>(vld1_u16(p))) }
    }
}

/// [`super::product_outputs`] on this path: `Y = X Wᵀ` (or `Y += X Wᵀ`) for the output columns
/// `outputs` of the layout `mm` over `rows` `[mm.outputs, mm.inputs]`.
///
/// # Safety
/// The CPU must have NEON; the rest as [`super::product_outputs`].
#[target_feature(enable = "neon")]
pub(crate) unsafe fn product_outputs(
    mm: &MatMul,
    x: *const f32,
    rows: &Rows,
    y: *mut f32,
    accumulate: bool,
    outputs: std::ops::Range<usize>,
) {
    // SAFETY: forwarded from the caller.
    unsafe { super::rows_product::<Neon>(mm, x, rows, y, accumulate, outputs) }
}

/// Weight rows per tile (16 accumulators + 4 weights + 1 input of the 32 vector registers).
const RW: usize = 4;
/// Batch rows per tile.
const RB: usize = 4;
/// f32 lanes per vector.
const L: usize = 4;

/// This path's row kernels.
struct Neon;

impl RowKernels for Neon {
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
    /// No prefetch: stable Rust has no prefetch instruction for aarch64.
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

/// [`Tiles::tile`].
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
    // SAFETY: the caller's contract (`Tiles::tile`); the tail reads only the row's last
    // `k - full` elements.
    unsafe {
        let mut acc = [[vdupq_n_f32(0.0); R]; B];
        let full = k / L * L;
        let mut i = 0;
        while i < full {
            let mut wv = [vdupq_n_f32(0.0); R];
            for (r, v) in wv.iter_mut().enumerate() {
                *v = E::load(w.add(r * k + i));
            }
            for (b, row) in acc.iter_mut().enumerate() {
                let xv = vld1q_f32(x.add(b * xs + i));
                for (a, v) in row.iter_mut().zip(&wv) {
                    *a = vfmaq_f32(*a, *v, xv);
                }
            }
            i += L;
        }
        if i < k && full > 0 {
            // The row's last 4 elements (all inside the row) with the lanes before `i` cleared,
            // as in the AVX2 tiles: no copy per row and tile.
            let lanes: [u32; L] = [0, 1, 2, 3];
            let keep = vcgtq_u32(
                vld1q_u32(lanes.as_ptr()),
                vdupq_n_u32((L - (k - i)) as u32 - 1),
            );
            let masked =
                |v: float32x4_t| vreinterpretq_f32_u32(vandq_u32(vreinterpretq_u32_f32(v), keep));
            let mut wv = [vdupq_n_f32(0.0); R];
            for (r, v) in wv.iter_mut().enumerate() {
                *v = masked(E::load(w.add(r * k + k - L)));
            }
            for (b, row) in acc.iter_mut().enumerate() {
                let xv = masked(vld1q_f32(x.add(b * xs + k - L)));
                for (a, v) in row.iter_mut().zip(&wv) {
                    *a = vfmaq_f32(*a, *v, xv);
                }
            }
        } else if i < k {
            // Rows shorter than one vector: copied into zeroed buffers.
            let rest = k - i;
            let mut wv = [vdupq_n_f32(0.0); R];
            for (r, v) in wv.iter_mut().enumerate() {
                let buf = padded::<E::T, L>(w.add(r * k + i), rest);
                *v = E::load(buf.as_ptr());
            }
            for (b, row) in acc.iter_mut().enumerate() {
                let buf = padded::<f32, L>(x.add(b * xs + i), rest);
                let xv = vld1q_f32(buf.as_ptr());
                for (a, v) in row.iter_mut().zip(&wv) {
                    *a = vfmaq_f32(*a, *v, xv);
                }
            }
        }
        for (b, row) in acc.iter().enumerate() {
            let yb = y.add(b * ys);
            for (r, v) in row.iter().enumerate() {
                // Fixed tree: (l0 + l1) + (l2 + l3).
                let s = vaddvq_f32(*v);
                let out = yb.add(r);
                *out = if accumulate { *out + s } else { s };
            }
        }
    }
}
