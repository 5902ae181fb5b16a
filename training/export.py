"""Write and read the self-describing weights file (schema: weights/README.md, format version 1)."""

from __future__ import annotations

import json
import os
import tempfile

import torch
from safetensors import safe_open
from safetensors.torch import save_file

from .models import MotionModel, build_model

FORMAT = "motion-weights"
FORMAT_VERSION = "1"
NORM_TENSORS = ("norm.mean", "norm.std", "labels.centroids", "labels.merge")


def weights_tensors(
    model: torch.nn.Module, dtype: torch.dtype = torch.float32, norm_dtype: torch.dtype = torch.float32
) -> dict[str, torch.Tensor]:
    """The state dict as stored: parameters in ``dtype``; the normalization statistics in
    ``norm_dtype`` (f32 by default even for f16/bf16 files: they are few numbers and f16 would
    shift every output by up to 5e-4 of the mean)."""
    if dtype not in (torch.float32, torch.float16, torch.bfloat16):
        raise ValueError(f"unsupported dtype {dtype}")
    tensors = {}
    for name, tensor in model.state_dict().items():
        target = norm_dtype if name in NORM_TENSORS else dtype
        tensors[name] = tensor.detach().to("cpu", target).contiguous()
    return tensors


def weights_metadata(model: torch.nn.Module, provenance: dict) -> dict[str, str]:
    """The ``__metadata__`` string map."""
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "config": json.dumps(model.config, sort_keys=True),
        "provenance": json.dumps(provenance, sort_keys=True),
    }


def save_weights(
    model: torch.nn.Module,
    path: str | os.PathLike,
    provenance: dict,
    dtype: torch.dtype = torch.float32,
    norm_dtype: torch.dtype = torch.float32,
) -> None:
    """Write ``model`` (a predictor or the action classifier: any module with ``config`` and the
    schema's state-dict names) to ``path`` atomically (temp file in the same directory, then rename)."""
    path = os.fspath(path)
    tensors = weights_tensors(model, dtype, norm_dtype)
    metadata = weights_metadata(model, provenance)
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".safetensors", dir=directory)
    os.close(fd)
    try:
        save_file(tensors, tmp, metadata=metadata)
        os.chmod(tmp, 0o644)  # mkstemp creates 0600
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def read_metadata(path: str | os.PathLike) -> dict[str, str]:
    """The raw metadata map of a weights file, checked for format and version."""
    with safe_open(os.fspath(path), framework="pt") as f:
        metadata = f.metadata() or {}
    if metadata.get("format") != FORMAT:
        raise ValueError(f"{path}: metadata 'format' is {metadata.get('format')!r}, expected {FORMAT!r}")
    if metadata.get("format_version") != FORMAT_VERSION:
        raise ValueError(
            f"{path}: unsupported format_version {metadata.get('format_version')!r} (expected {FORMAT_VERSION})"
        )
    return metadata


def load_weights(path: str | os.PathLike) -> MotionModel:
    """Build the model named by the file's config and load its tensors (as f32), in eval mode.

    The provenance dict is attached as ``model.provenance``.
    """
    metadata = read_metadata(path)
    config = json.loads(metadata["config"])
    model = build_model(config)
    expected = model.state_dict()
    state = {}
    with safe_open(os.fspath(path), framework="pt") as f:
        names = set(f.keys())
        missing = sorted(set(expected) - names)
        unexpected = sorted(names - set(expected))
        if missing or unexpected:
            raise ValueError(f"{path}: missing tensors {missing}, unexpected tensors {unexpected}")
        for name, reference in expected.items():
            tensor = f.get_tensor(name)
            if tensor.shape != reference.shape:
                raise ValueError(f"{path}: tensor {name} has shape {list(tensor.shape)}, expected {list(reference.shape)}")
            tensor = tensor.to(torch.float32)
            if not torch.isfinite(tensor).all():
                raise ValueError(f"{path}: tensor {name} contains NaN or Inf")
            state[name] = tensor
    model.load_state_dict(state)
    model.provenance = json.loads(metadata.get("provenance", "{}"))
    return model.eval()
