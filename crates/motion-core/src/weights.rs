//! Reading tensors out of a safetensors file by their PyTorch state-dict names.
//!
//! [`WeightStore`] is schema-agnostic: it holds every tensor of one file (in its stored dtype) and
//! the file's metadata map, and hands out f32 copies after checking presence, dtype, shape and
//! finiteness. The motion-weights schema (format, version, config) is checked one level up, in
//! [`crate::model::MotionModel`].
use safetensors::{Dtype, SafeTensors};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// An error loading weights: every variant names the file, and the tensor or metadata key at fault.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WeightsError {
    /// The file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The weights file.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The bytes are not a valid safetensors file.
    #[error("{}: not a valid safetensors file: {problem}", path.display())]
    Malformed {
        /// The weights file.
        path: PathBuf,
        /// What the safetensors parser reported.
        problem: String,
    },
    /// A metadata key the schema requires is absent.
    #[error("{}: metadata key `{key}` is missing (is this a motion-weights file?)", path.display())]
    MissingMetadata {
        /// The weights file.
        path: PathBuf,
        /// The missing `__metadata__` key.
        key: String,
    },
    /// The metadata `format` is not `motion-weights`.
    #[error("{}: metadata `format` is `{found}`, expected `motion-weights`", path.display())]
    UnknownFormat {
        /// The weights file.
        path: PathBuf,
        /// The `format` value found.
        found: String,
    },
    /// The metadata `format_version` is not one this loader reads.
    #[error("{}: unsupported format_version `{found}` (this loader reads version {supported})", path.display())]
    UnsupportedVersion {
        /// The weights file.
        path: PathBuf,
        /// The `format_version` value found.
        found: String,
        /// The version this loader reads.
        supported: u32,
    },
    /// The `config` (or `provenance`) metadata is not valid JSON or violates the schema.
    #[error("{}: metadata `{key}`: {problem}", path.display())]
    BadConfig {
        /// The weights file.
        path: PathBuf,
        /// The metadata key (`config` or `provenance`).
        key: String,
        /// What is wrong.
        problem: String,
    },
    /// A tensor the model needs is not in the file.
    #[error("{}: tensor `{tensor}` is missing", path.display())]
    MissingTensor {
        /// The weights file.
        path: PathBuf,
        /// The state-dict name of the tensor.
        tensor: String,
    },
    /// A tensor is stored in a dtype other than f32, f16 or bf16.
    #[error("{}: tensor `{tensor}` has dtype {dtype}, expected F32, F16 or BF16", path.display())]
    UnsupportedDtype {
        /// The weights file.
        path: PathBuf,
        /// The state-dict name of the tensor.
        tensor: String,
        /// The stored dtype.
        dtype: String,
    },
    /// A tensor's shape differs from the one the configuration implies.
    #[error("{}: tensor `{tensor}` has shape {found:?}, expected {expected:?}", path.display())]
    WrongShape {
        /// The weights file.
        path: PathBuf,
        /// The state-dict name of the tensor.
        tensor: String,
        /// The shape the configuration implies.
        expected: Vec<usize>,
        /// The stored shape.
        found: Vec<usize>,
    },
    /// A tensor's values are unusable for the model (e.g. a zero normalization std).
    #[error("{}: tensor `{tensor}`: {problem}", path.display())]
    InvalidTensor {
        /// The weights file.
        path: PathBuf,
        /// The state-dict name of the tensor.
        tensor: String,
        /// What is wrong.
        problem: String,
    },
    /// A tensor holds NaN or an infinity.
    #[error("{}: tensor `{tensor}` holds a non-finite value ({value}) at flat index {index}", path.display())]
    NonFinite {
        /// The weights file.
        path: PathBuf,
        /// The state-dict name of the tensor.
        tensor: String,
        /// Flat (row-major) index of the first non-finite element.
        index: usize,
        /// The value found (NaN, inf or -inf).
        value: f32,
    },
}

/// A 16-bit float format a tensor can be stored in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HalfDtype {
    /// IEEE 754 binary16.
    F16,
    /// bfloat16 (the upper half of an f32).
    Bf16,
}

/// One stored tensor, still in its file dtype.
#[derive(Debug, Clone)]
struct StoredTensor {
    dtype: Dtype,
    shape: Vec<usize>,
    bytes: Vec<u8>,
}

/// All tensors and metadata of one safetensors file, read by state-dict name.
#[derive(Debug, Clone)]
pub struct WeightStore {
    path: PathBuf,
    metadata: BTreeMap<String, String>,
    tensors: BTreeMap<String, StoredTensor>,
}

impl WeightStore {
    /// Reads a safetensors file.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, WeightsError> {
        let path = path.as_ref();
        let bytes = crate::input_file::read_regular(path).map_err(|source| WeightsError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_bytes(&bytes, path)
    }

    /// Parses safetensors bytes; `name` is the file name used in error messages.
    pub fn from_bytes(bytes: &[u8], name: impl Into<PathBuf>) -> Result<Self, WeightsError> {
        let path = name.into();
        let malformed = |e: safetensors::SafeTensorError| WeightsError::Malformed {
            path: path.clone(),
            problem: e.to_string(),
        };
        let (_, header) = SafeTensors::read_metadata(bytes).map_err(malformed)?;
        let metadata = header
            .metadata()
            .as_ref()
            .map(|m| m.iter().map(|(k, v)| (k.clone(), v.clone())).collect())
            .unwrap_or_default();
        let file = SafeTensors::deserialize(bytes).map_err(malformed)?;
        let tensors = file
            .iter()
            .map(|(name, view)| {
                let stored = StoredTensor {
                    dtype: view.dtype(),
                    shape: view.shape().to_vec(),
                    bytes: view.data().to_vec(),
                };
                (name.to_string(), stored)
            })
            .collect();
        Ok(Self {
            path,
            metadata,
            tensors,
        })
    }

    /// The file these weights came from (as given to [`WeightStore::open`]).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// A `__metadata__` value.
    pub fn metadata(&self, key: &str) -> Option<&str> {
        self.metadata.get(key).map(String::as_str)
    }

    /// A `__metadata__` value, or [`WeightsError::MissingMetadata`].
    pub fn require_metadata(&self, key: &str) -> Result<&str, WeightsError> {
        self.metadata(key)
            .ok_or_else(|| WeightsError::MissingMetadata {
                path: self.path.clone(),
                key: key.to_string(),
            })
    }

    /// Names of all stored tensors, sorted.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.tensors.keys().map(String::as_str)
    }

    /// The stored shape of a tensor, if present.
    pub fn shape(&self, name: &str) -> Option<&[usize]> {
        self.tensors.get(name).map(|t| t.shape.as_slice())
    }

    /// The tensor `name` as f32 (row-major), checked to have exactly `expected` shape and finite values.
    pub fn tensor(&self, name: &str, expected: &[usize]) -> Result<Vec<f32>, WeightsError> {
        let stored = self.stored(name)?;
        if stored.shape != expected {
            return Err(WeightsError::WrongShape {
                path: self.path.clone(),
                tensor: name.to_string(),
                expected: expected.to_vec(),
                found: stored.shape.clone(),
            });
        }
        self.convert(name, stored)
    }

    /// The tensor `name` as raw 16-bit floats (little-endian bit patterns) when the file stores it
    /// as f16 or bf16, `None` when it is stored as f32; checked like [`WeightStore::tensor`]
    /// (shape, dtype, finite values). Lets layers keep half-size weights in their stored dtype.
    pub fn tensor_half_bits(
        &self,
        name: &str,
        expected: &[usize],
    ) -> Result<Option<(HalfDtype, Vec<u16>)>, WeightsError> {
        // Shape, dtype and finiteness checks (the f32 copy is dropped).
        self.tensor(name, expected)?;
        let stored = self.stored(name)?;
        let kind = match stored.dtype {
            Dtype::F16 => HalfDtype::F16,
            Dtype::BF16 => HalfDtype::Bf16,
            _ => return Ok(None),
        };
        let bits = stored
            .bytes
            .chunks_exact(2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
            .collect();
        Ok(Some((kind, bits)))
    }

    /// The tensor `name` as f32 with whatever shape it has (for fixtures whose sizes are read from the file).
    pub fn tensor_any_shape(&self, name: &str) -> Result<(Vec<usize>, Vec<f32>), WeightsError> {
        let stored = self.stored(name)?;
        Ok((stored.shape.clone(), self.convert(name, stored)?))
    }

    fn stored(&self, name: &str) -> Result<&StoredTensor, WeightsError> {
        self.tensors
            .get(name)
            .ok_or_else(|| WeightsError::MissingTensor {
                path: self.path.clone(),
                tensor: name.to_string(),
            })
    }

    fn convert(&self, name: &str, stored: &StoredTensor) -> Result<Vec<f32>, WeightsError> {
        let values: Vec<f32> = match stored.dtype {
            Dtype::F32 => stored
                .bytes
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect(),
            Dtype::F16 => stored
                .bytes
                .chunks_exact(2)
                .map(|b| half::f16::from_le_bytes([b[0], b[1]]).to_f32())
                .collect(),
            Dtype::BF16 => stored
                .bytes
                .chunks_exact(2)
                .map(|b| half::bf16::from_le_bytes([b[0], b[1]]).to_f32())
                .collect(),
            other => {
                return Err(WeightsError::UnsupportedDtype {
                    path: self.path.clone(),
                    tensor: name.to_string(),
                    dtype: format!("{other:?}"),
                })
            }
        };
        if let Some(index) = values.iter().position(|v| !v.is_finite()) {
            return Err(WeightsError::NonFinite {
                path: self.path.clone(),
                tensor: name.to_string(),
                index,
                value: values[index],
            });
        }
        Ok(values)
    }

    /// A copy with every tensor except the normalization statistics (`norm.*`) and the intention
    /// model's label tables (`labels.*`) rounded to f16,
    /// the layout `training.export` writes for f16 files: random models with half-size weights
    /// for benchmarks and tests. Tensors already f16 are kept; non-float tensors are left as they
    /// are (loading them fails as usual).
    pub fn with_f16_parameters(&self) -> WeightStore {
        let mut out = self.clone();
        for (name, stored) in out.tensors.iter_mut() {
            if name.starts_with("norm.")
                || name.starts_with("labels.")
                || !matches!(stored.dtype, Dtype::F32 | Dtype::BF16)
            {
                continue;
            }
            let values: Vec<f32> = match stored.dtype {
                Dtype::F32 => stored
                    .bytes
                    .chunks_exact(4)
                    .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                    .collect(),
                _ => stored
                    .bytes
                    .chunks_exact(2)
                    .map(|b| half::bf16::from_le_bytes([b[0], b[1]]).to_f32())
                    .collect(),
            };
            stored.dtype = Dtype::F16;
            stored.bytes = values
                .iter()
                .flat_map(|&v| half::f16::from_f32(v).to_le_bytes())
                .collect();
        }
        out
    }

    /// All `__metadata__` entries.
    pub fn metadata_map(&self) -> &BTreeMap<String, String> {
        &self.metadata
    }

    /// Total number of stored elements over all tensors whose name passes `keep`.
    pub fn element_count(&self, keep: impl Fn(&str) -> bool) -> usize {
        self.tensors
            .iter()
            .filter(|(name, _)| keep(name))
            .map(|(_, t)| t.shape.iter().product::<usize>())
            .sum()
    }

    /// The stored dtype of a tensor (e.g. `F32`, `F16`), if present.
    pub fn dtype_name(&self, name: &str) -> Option<String> {
        self.tensors.get(name).map(|t| format!("{:?}", t.dtype))
    }
}

/// Serializes f32 tensors `(name, shape, values)` and a metadata map to safetensors bytes (for
/// fixtures, tests and random models; training writes real files from PyTorch).
///
/// Panics if a tensor's values do not match its shape (a programming error).
pub fn serialize_f32<'a>(
    tensors: impl IntoIterator<Item = (&'a str, &'a [usize], &'a [f32])>,
    metadata: &BTreeMap<String, String>,
) -> Vec<u8> {
    let owned: Vec<(&str, &[usize], Vec<u8>)> = tensors
        .into_iter()
        .map(|(name, shape, values)| {
            assert_eq!(
                shape.iter().product::<usize>(),
                values.len(),
                "tensor `{name}` size"
            );
            (
                name,
                shape,
                values.iter().flat_map(|v| v.to_le_bytes()).collect(),
            )
        })
        .collect();
    let views = owned.iter().map(|(name, shape, bytes)| {
        let view = safetensors::tensor::TensorView::new(Dtype::F32, shape.to_vec(), bytes)
            .expect("size checked above");
        (name.to_string(), view)
    });
    let metadata = metadata
        .iter()
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    safetensors::serialize(views, Some(metadata)).expect("f32 tensors serialize")
}

#[cfg(test)]
mod tests {
    use super::*;
    use safetensors::tensor::TensorView;
    use std::collections::HashMap;

    fn file(dtype: Dtype, shape: &[usize], bytes: &[u8]) -> Vec<u8> {
        let view = TensorView::new(dtype, shape.to_vec(), bytes).unwrap();
        let meta = HashMap::from([("k".to_string(), "v".to_string())]);
        safetensors::serialize([("a.weight", view)], Some(meta)).unwrap()
    }

    fn f32_bytes(v: &[f32]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_le_bytes()).collect()
    }

    #[test]
    fn reads_f32_f16_bf16() {
        let f = file(Dtype::F32, &[2], &f32_bytes(&[1.5, -2.0]));
        let s = WeightStore::from_bytes(&f, "x.safetensors").unwrap();
        assert_eq!(s.metadata("k"), Some("v"));
        assert_eq!(s.tensor("a.weight", &[2]).unwrap(), vec![1.5, -2.0]);
        let h: Vec<u8> = [half::f16::from_f32(0.25), half::f16::from_f32(-3.0)]
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let s = WeightStore::from_bytes(&file(Dtype::F16, &[2], &h), "h").unwrap();
        assert_eq!(s.tensor("a.weight", &[2]).unwrap(), vec![0.25, -3.0]);
        let b: Vec<u8> = [half::bf16::from_f32(0.5)]
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let s = WeightStore::from_bytes(&file(Dtype::BF16, &[1], &b), "b").unwrap();
        assert_eq!(s.tensor("a.weight", &[1]).unwrap(), vec![0.5]);
    }

    #[test]
    fn half_bits_keep_the_stored_dtype() {
        let h = half::f16::from_f32(0.25);
        let s = WeightStore::from_bytes(&file(Dtype::F16, &[1], &h.to_le_bytes()), "h").unwrap();
        assert_eq!(
            s.tensor_half_bits("a.weight", &[1]).unwrap(),
            Some((HalfDtype::F16, vec![h.to_bits()]))
        );
        let b = half::bf16::from_f32(-2.5);
        let s = WeightStore::from_bytes(&file(Dtype::BF16, &[1], &b.to_le_bytes()), "b").unwrap();
        assert_eq!(
            s.tensor_half_bits("a.weight", &[1]).unwrap(),
            Some((HalfDtype::Bf16, vec![b.to_bits()]))
        );
        let s = WeightStore::from_bytes(&file(Dtype::F32, &[1], &f32_bytes(&[1.0])), "f").unwrap();
        assert_eq!(s.tensor_half_bits("a.weight", &[1]).unwrap(), None);
        let inf = half::f16::INFINITY.to_le_bytes();
        let s = WeightStore::from_bytes(&file(Dtype::F16, &[1], &inf), "i").unwrap();
        assert!(matches!(
            s.tensor_half_bits("a.weight", &[1]),
            Err(WeightsError::NonFinite { .. })
        ));
    }

    #[test]
    fn f16_parameters_round_all_but_norm() {
        let one = [0.1f32];
        let tensors: Vec<(&str, &[usize], &[f32])> =
            vec![("a.weight", &[1], &one), ("norm.std", &[1], &one)];
        let bytes = serialize_f32(tensors, &BTreeMap::new());
        let s = WeightStore::from_bytes(&bytes, "r")
            .unwrap()
            .with_f16_parameters();
        assert_eq!(s.dtype_name("a.weight").as_deref(), Some("F16"));
        assert_eq!(s.dtype_name("norm.std").as_deref(), Some("F32"));
        let rounded = half::f16::from_f32(0.1).to_f32();
        assert_eq!(s.tensor("a.weight", &[1]).unwrap(), vec![rounded]);
        assert_eq!(s.tensor("norm.std", &[1]).unwrap(), vec![0.1]);
    }

    #[test]
    fn errors_name_tensor_and_file() {
        let f = file(Dtype::F32, &[2], &f32_bytes(&[1.0, f32::NAN]));
        let s = WeightStore::from_bytes(&f, "w.safetensors").unwrap();
        let msg = s.tensor("a.weight", &[2]).unwrap_err().to_string();
        assert!(msg.contains("w.safetensors") && msg.contains("a.weight") && msg.contains("NaN"));
        let msg = s.tensor("a.weight", &[3]).unwrap_err().to_string();
        assert!(msg.contains("a.weight") && msg.contains("[3]"), "{msg}");
        let msg = s.tensor("b", &[3]).unwrap_err().to_string();
        assert!(
            msg.contains("w.safetensors") && msg.contains("`b`"),
            "{msg}"
        );
        let f = file(Dtype::I32, &[1], &[0, 0, 0, 0]);
        let s = WeightStore::from_bytes(&f, "i").unwrap();
        assert!(matches!(
            s.tensor("a.weight", &[1]),
            Err(WeightsError::UnsupportedDtype { .. })
        ));
        assert!(matches!(
            WeightStore::from_bytes(b"garbage", "g"),
            Err(WeightsError::Malformed { .. })
        ));
    }
}
