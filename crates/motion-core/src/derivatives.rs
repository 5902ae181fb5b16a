//! Motion-derivative features (Gopalakrishnan et al. 2019, section 3.3, equation 5): backward differences with
//! `h = 1`, `∇ⁿ x_t = Σ_{i=0..n} (-1)^i C(n, i) x_{t-i}`, appended to the frame:
//! `[x, ∇¹x, ..., ∇^order x]` (width `D * (order + 1)`).
//!
//! ## Padding: `repeat-first`
//! Frames before the first are copies of the first, so the first frame's derivatives are 0 (∇³
//! up to the rounding of `3 · x`, exactly as in PyTorch with the same summation order). This
//! is fixed by `weights/README.md` and the PyTorch training code (`training/features.py`).
//!
//! ## Bit-exact agreement
//! Both the batch [`derivative_features`] and the incremental [`DerivativeBuffer`] sum
//! `acc = x_t; acc = acc + c_i * x_{t-i}` for `i = 1..=n`, left to right, like the PyTorch code,
//! so they give identical bits (and match PyTorch up to its own vectorisation).
use std::ops::{Add, Mul};

use ndarray::{Array2, ArrayView2};

/// A float type the derivative features can be computed in (`f32` or `f64`).
pub trait DerivativeScalar: Copy + Add<Output = Self> + Mul<Output = Self> + 'static {
    /// Zero.
    const ZERO: Self;
    /// A small integer coefficient, exactly.
    fn from_coefficient(c: i64) -> Self;
}

impl DerivativeScalar for f32 {
    const ZERO: Self = 0.0;
    fn from_coefficient(c: i64) -> Self {
        c as f32
    }
}

impl DerivativeScalar for f64 {
    const ZERO: Self = 0.0;
    fn from_coefficient(c: i64) -> Self {
        c as f64
    }
}

/// The signed binomial coefficients `(-1)^i C(n, i)` for `i = 0..=n`, written into `out[..=n]`.
fn signed_binomials(n: usize, out: &mut [i64]) {
    let mut c: i64 = 1;
    for (i, slot) in out.iter_mut().enumerate().take(n + 1) {
        *slot = if i % 2 == 0 { c } else { -c };
        c = c * (n - i) as i64 / (i + 1) as i64;
    }
}

/// Highest supported derivative order (coefficients stay exact in f32 far beyond this).
pub const MAX_DERIVATIVE_ORDER: usize = 8;

/// Writes `[x_t, ∇¹, ..., ∇^order]` for `history = [x_t, x_{t-1}, ..., x_{t-order}]` (each given
/// by an accessor) into `out` (width `D * (order + 1)`).
#[inline]
fn write_features<'a, T: DerivativeScalar>(
    order: usize,
    width: usize,
    frame_at: impl Fn(usize) -> &'a [T],
    out: &mut [T],
) {
    let mut coef = [0i64; MAX_DERIVATIVE_ORDER + 1];
    let x0 = frame_at(0);
    out[..width].copy_from_slice(x0);
    for n in 1..=order {
        signed_binomials(n, &mut coef);
        let dst = &mut out[n * width..(n + 1) * width];
        dst.copy_from_slice(x0);
        for (i, &c) in coef.iter().enumerate().take(n + 1).skip(1) {
            let ci = T::from_coefficient(c);
            let xi = frame_at(i);
            for (d, &x) in dst.iter_mut().zip(xi) {
                *d = *d + ci * x;
            }
        }
    }
}

/// Batch derivative features: `frames` (`T x D`) -> `T x D * (order + 1)` with repeat-first
/// padding. `order` 0 returns a copy of the frames.
///
/// # Panics
/// If `order > MAX_DERIVATIVE_ORDER`.
pub fn derivative_features<T: DerivativeScalar>(frames: ArrayView2<T>, order: usize) -> Array2<T> {
    assert!(
        order <= MAX_DERIVATIVE_ORDER,
        "derivative order {order} too high"
    );
    let (steps, width) = frames.dim();
    let contiguous = frames.as_standard_layout();
    let data = contiguous
        .as_slice()
        .expect("standard layout is contiguous");
    let mut out = Array2::from_elem((steps, width * (order + 1)), T::ZERO);
    for (t, mut row) in out.rows_mut().into_iter().enumerate() {
        let row = row.as_slice_mut().expect("fresh array is contiguous");
        let frame_at = |i: usize| {
            let src = t.saturating_sub(i); // repeat-first padding
            &data[src * width..(src + 1) * width]
        };
        write_features(order, width, frame_at, row);
    }
    out
}

/// Incremental derivative features: a ring buffer of the last `order` frames; `push` writes the
/// features of the new frame with no allocation. The first push after `new`/`reset` fills the
/// history with copies of that frame (repeat-first).
#[derive(Debug, Clone)]
pub struct DerivativeBuffer<T> {
    order: usize,
    width: usize,
    /// `order + 1` frames; slot `(head + i) % (order + 1)` holds `x_{t-i}` after a push.
    ring: Vec<T>,
    head: usize,
    started: bool,
}

impl<T: DerivativeScalar> DerivativeBuffer<T> {
    /// A buffer for frames of `width` values and derivatives up to `order`.
    ///
    /// # Panics
    /// If `order > MAX_DERIVATIVE_ORDER`.
    pub fn new(width: usize, order: usize) -> DerivativeBuffer<T> {
        assert!(
            order <= MAX_DERIVATIVE_ORDER,
            "derivative order {order} too high"
        );
        DerivativeBuffer {
            order,
            width,
            ring: vec![T::ZERO; width * (order + 1)],
            head: 0,
            started: false,
        }
    }

    /// Frame width `D`.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Derivative order.
    pub fn order(&self) -> usize {
        self.order
    }

    /// Output width `D * (order + 1)`.
    pub fn output_width(&self) -> usize {
        self.width * (self.order + 1)
    }

    /// Forgets the history: the next push is a first frame.
    pub fn reset(&mut self) {
        self.started = false;
        self.head = 0;
    }

    /// Appends `frame` (`D` values) and writes its features (`D * (order + 1)` values) to `out`.
    ///
    /// # Panics
    /// If `frame.len() != width()` or `out.len() != output_width()`.
    pub fn push(&mut self, frame: &[T], out: &mut [T]) {
        assert_eq!(frame.len(), self.width, "frame width");
        assert_eq!(out.len(), self.output_width(), "output width");
        let slots = self.order + 1;
        let w = self.width;
        if self.started {
            self.head = (self.head + slots - 1) % slots;
            self.ring[self.head * w..(self.head + 1) * w].copy_from_slice(frame);
        } else {
            for s in 0..slots {
                self.ring[s * w..(s + 1) * w].copy_from_slice(frame);
            }
            self.head = 0;
            self.started = true;
        }
        let ring = &self.ring;
        let head = self.head;
        let frame_at = |i: usize| {
            let s = (head + i) % slots;
            &ring[s * w..(s + 1) * w]
        };
        write_features(self.order, w, frame_at, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array2;

    fn frames<T: DerivativeScalar>(steps: usize, width: usize, f: impl Fn(f64) -> T) -> Array2<T> {
        Array2::from_shape_fn((steps, width), |(t, k)| {
            f((t as f64 * 0.3 + k as f64).sin() * 10.0 + t as f64)
        })
    }

    fn incremental<T: DerivativeScalar + std::fmt::Debug>(
        x: &Array2<T>,
        order: usize,
    ) -> Array2<T> {
        let (steps, width) = x.dim();
        let mut buf = DerivativeBuffer::new(width, order);
        let mut out = Array2::from_elem((steps, width * (order + 1)), T::ZERO);
        for t in 0..steps {
            let frame = x.row(t).to_vec();
            buf.push(&frame, out.row_mut(t).as_slice_mut().unwrap());
        }
        out
    }

    #[test]
    fn batch_and_incremental_are_bit_identical_f32_and_f64() {
        for order in 0..=4 {
            let x64 = frames(37, 5, |v| v);
            let a = derivative_features(x64.view(), order);
            let b = incremental(&x64, order);
            assert!(a
                .iter()
                .zip(b.iter())
                .all(|(p, q)| p.to_bits() == q.to_bits()));
            let x32 = frames(37, 5, |v| v as f32);
            let a = derivative_features(x32.view(), order);
            let b = incremental(&x32, order);
            assert!(a
                .iter()
                .zip(b.iter())
                .all(|(p, q)| p.to_bits() == q.to_bits()));
        }
    }

    #[test]
    fn layout_padding_and_values() {
        // x_t = t³ in one channel: ∇¹ = t³ - (t-1)³, ∇² ..., ∇³ = 6 once past the padding.
        let x = Array2::from_shape_fn((8, 1), |(t, _)| (t as f64).powi(3));
        let f = derivative_features(x.view(), 3);
        assert_eq!(f.dim(), (8, 4));
        assert_eq!(f.row(0).to_vec(), vec![0.0, 0.0, 0.0, 0.0]);
        // t = 1: history [1, 0, 0, 0] -> ∇¹ = 1, ∇² = 1, ∇³ = 1.
        assert_eq!(f.row(1).to_vec(), vec![1.0, 1.0, 1.0, 1.0]);
        for t in 3..8 {
            let tf = t as f64;
            assert_eq!(f[[t, 0]], tf.powi(3));
            assert_eq!(f[[t, 1]], tf.powi(3) - (tf - 1.0).powi(3));
            assert_eq!(f[[t, 3]], 6.0);
        }
        // First frame's derivatives are zero for any data (repeat-first), up to the rounding
        // of `3 · x` in ∇³ (the same bits PyTorch computes).
        let y = frames(3, 4, |v| v);
        let g = derivative_features(y.view(), 3);
        assert!(g.row(0).iter().skip(4).all(|&v| v.abs() < 1e-13));
        assert!(g.row(0).iter().skip(4).take(8).all(|&v| v == 0.0));
        assert_eq!(
            g.row(0).iter().take(4).copied().collect::<Vec<_>>(),
            y.row(0).to_vec()
        );
    }

    /// `training/features.py::derivative_features` (PyTorch, f32) of the frames below, as bits.
    const PYTORCH_BITS: [u32; 48] = [
        0x00000000, 0x3fedb6db, 0x00000000, 0x00000000, 0x00000000, 0x00000000, 0x00000000,
        0x34000000, 0x3f8ccccd, 0x403d41d4, 0x3f8ccccd, 0x3f8ccccd, 0x3f8ccccd, 0x3f8ccccd,
        0x3f8ccccd, 0x3f8ccccd, 0x400ccccd, 0x4081d41d, 0x3f8ccccd, 0x3f8ccccc, 0x00000000,
        0xb4000000, 0xbf8cccce, 0xbf8ccccf, 0x40533333, 0x40a50751, 0x3f8ccccc, 0x3f8cccd0,
        0xb4000000, 0x35000000, 0xb4800000, 0x34000000, 0x408ccccd, 0x40c83a84, 0x3f8cccce,
        0x3f8ccccc, 0x34800000, 0xb5000000, 0x35600000, 0xb5800000, 0x40b00000, 0x40eb6db7,
        0x3f8ccccc, 0x3f8ccccc, 0xb4800000, 0x00000000, 0xb5a00000, 0x35c00000,
    ];

    #[test]
    fn bit_identical_to_the_pytorch_training_code() {
        // x[t][k] = ((7t + 13k) mod 101) / 7 + 0.1 t, all in f32 as in the Python snippet.
        let x = Array2::from_shape_fn((6, 2), |(t, k)| {
            ((t * 7 + k * 13) % 101) as f32 / 7.0f32 + t as f32 * 0.1f32
        });
        let batch = derivative_features(x.view(), 3);
        let streamed = incremental(&x, 3);
        for (i, want) in PYTORCH_BITS.iter().enumerate() {
            assert_eq!(batch.as_slice().unwrap()[i].to_bits(), *want, "value {i}");
            assert_eq!(
                streamed.as_slice().unwrap()[i].to_bits(),
                *want,
                "value {i}"
            );
        }
    }

    #[test]
    fn reset_starts_over() {
        let x = frames(6, 3, |v| v);
        let mut buf = DerivativeBuffer::<f64>::new(3, 3);
        let mut out = vec![0.0; 12];
        for t in 0..6 {
            buf.push(x.row(t).as_slice().unwrap(), &mut out);
        }
        buf.reset();
        buf.push(x.row(4).as_slice().unwrap(), &mut out);
        assert_eq!(&out[..3], x.row(4).as_slice().unwrap());
        assert!(out[3..9].iter().all(|&v| v == 0.0));
        assert!(out[9..].iter().all(|&v| v.abs() < 1e-13));
        assert_eq!(buf.output_width(), 12);
    }

    #[test]
    fn signed_binomials_are_right() {
        let mut c = [0i64; MAX_DERIVATIVE_ORDER + 1];
        signed_binomials(3, &mut c);
        assert_eq!(&c[..4], &[1, -3, 3, -1]);
        signed_binomials(8, &mut c);
        assert_eq!(c, [1, -8, 28, -56, 70, -56, 28, -8, 1]);
    }

    #[test]
    fn non_contiguous_views_work() {
        let x = frames(10, 6, |v| v);
        let strided = x.slice(ndarray::s![..;2, 1..4]);
        let a = derivative_features(strided, 2);
        let b = derivative_features(strided.to_owned().view(), 2);
        assert_eq!(a, b);
    }
}
