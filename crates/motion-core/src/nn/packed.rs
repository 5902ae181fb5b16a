//! A layer's weight matrix `W [out, in]` (PyTorch layout) in the layout chosen once at load.
//!
//! A batch-1 step reads every weight once, so it runs at the speed weights stream out of cache:
//! fewer bytes per weight is the one way to make it faster. A [`PackedMatrix`] therefore keeps the
//! rows in the dtype the file stores them in: f32 rows for f32 tensors, **f16 rows for f16
//! tensors** and bf16 rows for bf16 tensors, widened to f32 inside the kernels
//! ([`super::gemm`]). Widening f16/bf16 to f32 is exact, so every product computes with the same
//! numbers as the f32 upcast the file reader would give; only the accumulation order is the
//! kernel's.
//!
//! Large batches are compute-bound and go to a GEMM over f32 weights: with the AVX-512 or AVX2
//! path selected at load ([`super::simd`]) the matrix also holds its weights packed into column
//! panels for [`super::sgemm_panels`] (packed here, at load, so no step re-packs or allocates);
//! on the other paths `matrixmultiply` reads the f32 rows (16-bit rows then keep an f32 copy for
//! it, which the portable row kernel reads too). The second form doubles the weight memory (11 MB
//! more for a paper-size f32 model), the price of fast batches of every size.
use super::sgemm_panels::{self, PanelMatrix};
use crate::weights::{HalfDtype, WeightStore, WeightsError};

/// The element type of a [`PackedMatrix`]'s rows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowDtype {
    /// 4-byte IEEE f32.
    F32,
    /// 2-byte IEEE f16 (binary16).
    F16,
    /// 2-byte bfloat16.
    Bf16,
}

impl RowDtype {
    /// Bytes per stored weight.
    pub fn size(self) -> usize {
        match self {
            RowDtype::F32 => 4,
            RowDtype::F16 | RowDtype::Bf16 => 2,
        }
    }
}

/// The rows of a [`PackedMatrix`] (row-major `[out, in]`), in their stored dtype.
#[derive(Debug, Clone)]
pub(crate) enum Rows {
    /// f32 values.
    F32(Vec<f32>),
    /// f16 bit patterns.
    F16(Vec<u16>),
    /// bf16 bit patterns.
    Bf16(Vec<u16>),
}

/// An immutable weight matrix `[outputs, inputs]` in its load-time layout (see the module doc).
#[derive(Debug, Clone)]
pub struct PackedMatrix {
    outputs: usize,
    inputs: usize,
    rows: Rows,
    /// The form the large-batch GEMM reads.
    wide: Wide,
}

/// The weights in the form the large-batch GEMM reads.
#[derive(Debug, Clone)]
pub(crate) enum Wide {
    /// Column panels for the AVX-512 GEMM.
    Panels(PanelMatrix),
    /// Row-major f32 for `matrixmultiply`: the rows themselves (f32 rows) ...
    Rows,
    /// ... or an f32 copy of 16-bit rows.
    F32(Vec<f32>),
}

impl PackedMatrix {
    /// f32 rows from row-major `values [outputs, inputs]`.
    ///
    /// Panics if `values.len() != outputs * inputs` (a programming error).
    pub fn from_f32(values: Vec<f32>, outputs: usize, inputs: usize) -> Self {
        assert_eq!(values.len(), outputs * inputs, "matrix size");
        let wide = if sgemm_panels::panels_in_use() {
            Wide::Panels(PanelMatrix::pack(&values, outputs, inputs))
        } else {
            Wide::Rows
        };
        Self {
            outputs,
            inputs,
            rows: Rows::F32(values),
            wide,
        }
    }

    /// 16-bit rows from row-major bit patterns `[outputs, inputs]` of `dtype`.
    ///
    /// Panics if `bits.len() != outputs * inputs` (a programming error).
    pub fn from_half_bits(dtype: HalfDtype, bits: Vec<u16>, outputs: usize, inputs: usize) -> Self {
        assert_eq!(bits.len(), outputs * inputs, "matrix size");
        let rows = match dtype {
            HalfDtype::F16 => Rows::F16(bits),
            HalfDtype::Bf16 => Rows::Bf16(bits),
        };
        let mut matrix = Self {
            outputs,
            inputs,
            rows,
            wide: Wide::Rows,
        };
        let values = matrix.to_f32();
        matrix.wide = if sgemm_panels::panels_in_use() {
            Wide::Panels(PanelMatrix::pack(&values, outputs, inputs))
        } else {
            Wide::F32(values)
        };
        matrix
    }

    /// The same matrix in the layout of the paths without AVX-512 (no panels; 16-bit rows keep
    /// an f32 copy): what loading under `MOTION_SIMD=avx2` or `portable` gives (tests).
    pub fn without_panels(mut self) -> Self {
        self.wide = match self.rows {
            Rows::F32(_) => Wide::Rows,
            _ => Wide::F32(self.to_f32()),
        };
        self
    }

    /// f16 rows holding each of `values` rounded to the nearest f16 (lossy: for benchmarks and
    /// tests that compare the f32 and f16 kernels on one matrix).
    pub fn f16_from_f32(values: &[f32], outputs: usize, inputs: usize) -> Self {
        let bits = values
            .iter()
            .map(|&v| half::f16::from_f32(v).to_bits())
            .collect();
        Self::from_half_bits(HalfDtype::F16, bits, outputs, inputs)
    }

    /// Reads tensor `name [outputs, inputs]` from `store`, keeping f16/bf16 tensors in their
    /// stored dtype and f32 tensors as f32 (checks as [`WeightStore::tensor`]).
    pub fn load(
        store: &WeightStore,
        name: &str,
        outputs: usize,
        inputs: usize,
    ) -> Result<Self, WeightsError> {
        let shape = [outputs, inputs];
        Ok(match store.tensor_half_bits(name, &shape)? {
            Some((dtype, bits)) => Self::from_half_bits(dtype, bits, outputs, inputs),
            None => Self::from_f32(store.tensor(name, &shape)?, outputs, inputs),
        })
    }

    /// Rows of `W` (outputs of the product).
    pub fn outputs(&self) -> usize {
        self.outputs
    }

    /// Columns of `W` (inputs of the product).
    pub fn inputs(&self) -> usize {
        self.inputs
    }

    /// Number of weights (`outputs * inputs`).
    pub fn len(&self) -> usize {
        self.outputs * self.inputs
    }

    /// True for a matrix with no weights.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The element type of the rows the small-batch kernels read.
    pub fn dtype(&self) -> RowDtype {
        match self.rows {
            Rows::F32(_) => RowDtype::F32,
            Rows::F16(_) => RowDtype::F16,
            Rows::Bf16(_) => RowDtype::Bf16,
        }
    }

    /// Bytes of weights one small-batch product reads (`len() * dtype().size()`).
    pub fn row_bytes(&self) -> usize {
        self.len() * self.dtype().size()
    }

    /// Weight `(row, col)` as f32 (exact for every dtype).
    ///
    /// Panics if the index is out of range.
    pub fn get(&self, row: usize, col: usize) -> f32 {
        assert!(
            row < self.outputs && col < self.inputs,
            "index out of range"
        );
        let k = row * self.inputs + col;
        match &self.rows {
            Rows::F32(v) => v[k],
            Rows::F16(v) => half::f16::from_bits(v[k]).to_f32(),
            Rows::Bf16(v) => half::bf16::from_bits(v[k]).to_f32(),
        }
    }

    /// All weights as row-major f32 (exact widening of 16-bit rows).
    pub fn to_f32(&self) -> Vec<f32> {
        match &self.rows {
            Rows::F32(v) => v.clone(),
            Rows::F16(v) => v
                .iter()
                .map(|&b| half::f16::from_bits(b).to_f32())
                .collect(),
            Rows::Bf16(v) => v
                .iter()
                .map(|&b| half::bf16::from_bits(b).to_f32())
                .collect(),
        }
    }

    /// Splits the rows at `at`: `(W[..at], W[at..])`, each in the same dtype.
    ///
    /// Panics if `at > outputs()`.
    pub fn split_rows(self, at: usize) -> (Self, Self) {
        assert!(at <= self.outputs, "split beyond the last row");
        let cut = at * self.inputs;
        let (outputs, inputs) = (self.outputs, self.inputs);
        let half = |dtype, mut bits: Vec<u16>| {
            let tail = bits.split_off(cut);
            (
                Self::from_half_bits(dtype, bits, at, inputs),
                Self::from_half_bits(dtype, tail, outputs - at, inputs),
            )
        };
        match self.rows {
            Rows::F32(mut v) => {
                let tail = v.split_off(cut);
                (
                    Self::from_f32(v, at, inputs),
                    Self::from_f32(tail, outputs - at, inputs),
                )
            }
            Rows::F16(bits) => half(HalfDtype::F16, bits),
            Rows::Bf16(bits) => half(HalfDtype::Bf16, bits),
        }
    }

    /// The rows in their stored dtype (what the small-batch kernels read).
    pub(crate) fn rows(&self) -> &Rows {
        &self.rows
    }

    /// The weights in the form the large-batch GEMM reads.
    pub(crate) fn wide(&self) -> &Wide {
        &self.wide
    }

    /// The weights as row-major f32 when that is the large-batch form (no AVX-512).
    pub(crate) fn f32_rows(&self) -> Option<&[f32]> {
        match (&self.rows, &self.wide) {
            (Rows::F32(v), Wide::Rows) => Some(v),
            (_, Wide::F32(v)) => Some(v),
            _ => None,
        }
    }

    /// Bytes held by the large-batch form beyond the rows (0 when it is the rows themselves).
    pub fn wide_bytes(&self) -> usize {
        match &self.wide {
            Wide::Panels(p) => p.size_bytes(),
            Wide::Rows => 0,
            Wide::F32(v) => v.len() * 4,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dtypes_widen_exactly_and_split() {
        let values: Vec<f32> = (0..12).map(|k| k as f32 * 0.25 - 1.0).collect();
        let f32m = PackedMatrix::from_f32(values.clone(), 3, 4);
        let f16m = PackedMatrix::f16_from_f32(&values, 3, 4);
        let bits = values
            .iter()
            .map(|&v| half::bf16::from_f32(v).to_bits())
            .collect();
        let bf16m = PackedMatrix::from_half_bits(HalfDtype::Bf16, bits, 3, 4);
        for m in [&f32m, &f16m, &bf16m] {
            // Quarter steps in [-1, 2] are exact in all three formats.
            assert_eq!(m.to_f32(), values);
            if let Some(rows) = m.f32_rows() {
                assert_eq!(rows, &values[..]);
            }
            assert_eq!(m.get(2, 1), values[9]);
            let (a, b) = m.clone().split_rows(1);
            assert_eq!((a.outputs(), b.outputs(), a.dtype()), (1, 2, m.dtype()));
            assert_eq!(a.to_f32(), values[..4]);
            assert_eq!(b.to_f32(), values[4..]);
            if let Some(rows) = b.f32_rows() {
                assert_eq!(rows, &values[4..]);
            }
        }
        assert_eq!((f32m.row_bytes(), f16m.row_bytes()), (48, 24));
        assert_eq!(bf16m.dtype(), RowDtype::Bf16);
    }
}
