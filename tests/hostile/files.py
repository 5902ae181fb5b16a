"""Hostile and ordinary input files for the hostile-input corpus, written with the standard
library only (no numpy): BVH rigs, exp-map text, gzip bombs, ``.npy`` and safetensors edits."""

from __future__ import annotations

import gzip
import json
import math
import os
import struct
import zlib
from pathlib import Path

# A CMU-named rig (millimetres, y up): (name, parent, offset). The names are the CMU mocap BVH
# conversion's, so retargeting detects the rig; joint maps name these joints.
CMU_RIG = [
    ("Hips", None, (0, 0, 0)),
    ("LeftUpLeg", "Hips", (90, 0, 0)),
    ("LeftLeg", "LeftUpLeg", (0, -420, 0)),
    ("LeftFoot", "LeftLeg", (0, -410, 0)),
    ("LeftToeBase", "LeftFoot", (0, -60, 120)),
    ("RightUpLeg", "Hips", (-90, 0, 0)),
    ("RightLeg", "RightUpLeg", (0, -420, 0)),
    ("RightFoot", "RightLeg", (0, -410, 0)),
    ("RightToeBase", "RightFoot", (0, -60, 120)),
    ("LowerBack", "Hips", (0, 120, 0)),
    ("Spine", "LowerBack", (0, 150, 0)),
    ("Neck", "Spine", (0, 200, 0)),
    ("Head", "Neck", (0, 100, 0)),
    ("LeftShoulder", "Spine", (40, 180, 0)),
    ("LeftArm", "LeftShoulder", (150, 0, 0)),
    ("LeftForeArm", "LeftArm", (280, 0, 0)),
    ("LeftHand", "LeftForeArm", (250, 0, 0)),
    ("RightShoulder", "Spine", (-40, 180, 0)),
    ("RightArm", "RightShoulder", (-150, 0, 0)),
    ("RightForeArm", "RightArm", (-280, 0, 0)),
    ("RightHand", "RightForeArm", (-250, 0, 0)),
]

# The same rig's H3.6M joint map (H3.6M name -> rig name).
CMU_MAP = {
    "Hips": "Hips", "RightUpLeg": "RightUpLeg", "RightLeg": "RightLeg", "RightFoot": "RightFoot",
    "RightToeBase": "RightToeBase", "LeftUpLeg": "LeftUpLeg", "LeftLeg": "LeftLeg",
    "LeftFoot": "LeftFoot", "LeftToeBase": "LeftToeBase", "Spine": "LowerBack", "Spine1": "Spine",
    "Neck": "Neck", "Head": "Head", "LeftShoulder": "LeftShoulder", "LeftArm": "LeftArm",
    "LeftForeArm": "LeftForeArm", "LeftHand": "LeftHand", "RightShoulder": "RightShoulder",
    "RightArm": "RightArm", "RightForeArm": "RightForeArm", "RightHand": "RightHand",
}


def rig_bvh(frames: int = 120, frame_time: float = 1 / 30, offset_scale: float = 1.0) -> str:
    """The CMU-named rig walking in place (legs and arms swinging), ``frames`` frames."""
    children: dict[str | None, list[int]] = {}
    for i, (_, parent, _) in enumerate(CMU_RIG):
        children.setdefault(parent, []).append(i)
    lines = ["HIERARCHY"]

    def joint(i: int, depth: int) -> None:
        name, parent, offset = CMU_RIG[i]
        pad = "  " * depth
        lines.append(f"{pad}{'ROOT' if parent is None else 'JOINT'} {name}")
        lines.append(f"{pad}{{")
        o = " ".join(repr(v * offset_scale) for v in offset)
        lines.append(f"{pad}  OFFSET {o}")
        if parent is None:
            lines.append(f"{pad}  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation")
        else:
            lines.append(f"{pad}  CHANNELS 3 Zrotation Xrotation Yrotation")
        kids = children.get(name, [])
        for k in kids:
            joint(k, depth + 1)
        if not kids:
            lines.append(f"{pad}  End Site")
            lines.append(f"{pad}  {{")
            lines.append(f"{pad}    OFFSET 0 -50 0")
            lines.append(f"{pad}  }}")
        lines.append(f"{pad}}}")

    joint(0, 0)
    lines += ["MOTION", f"Frames: {frames}", f"Frame Time: {frame_time}"]
    swing = {"LeftUpLeg": 1, "RightUpLeg": -1, "LeftArm": -0.5, "RightArm": 0.5}
    for f in range(frames):
        phase = 2 * math.pi * f * frame_time
        values = [0.0, 930.0, 300.0 * f * frame_time, 0.0, 0.0, 0.0]
        for name, _, _ in CMU_RIG[1:]:
            x = 25.0 * swing.get(name, 0.0) * math.sin(phase)
            values += [0.0, round(x, 4), 0.0]
        lines.append(" ".join(f"{v:.4f}" for v in values))
    return "\n".join(lines) + "\n"


def thin_bvh(path: Path, frames: int, frame_time: float) -> None:
    """A two-joint rig with ``frames`` frames, written in blocks (sizes up to ~100 MB)."""
    head = (
        "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition "
        "Zrotation Xrotation Yrotation\n JOINT Leg\n {\n  OFFSET 0 -10 0\n  CHANNELS 3 Zrotation "
        "Xrotation Yrotation\n  End Site\n  {\n   OFFSET 0 -10 0\n  }\n }\n}\nMOTION\n"
        f"Frames: {frames}\nFrame Time: {frame_time}\n"
    )
    line = "0 0 0 0 0 0 0 0 0\n"
    with open(path, "w") as f:
        f.write(head)
        block = line * 100_000
        for _ in range(frames // 100_000):
            f.write(block)
        f.write(line * (frames % 100_000))


def expmap_text(rows: int, columns: int = 99) -> str:
    """H3.6M-style exp-map text: small smooth values, ``columns`` per row."""
    out = []
    for r in range(rows):
        out.append(",".join(f"{0.01 * math.sin(0.05 * r + c):.6f}" for c in range(columns)))
    return "\n".join(out) + "\n"


def gzip_bomb(path: Path, mib: int) -> None:
    """A ``.txt.gz`` that expands to ``mib`` MiB of one repeated exp-map row (~1 MB on disk)."""
    row = (",".join(["0.0"] * 99) + "\n").encode()
    chunk = row * ((1 << 20) // len(row) + 1)
    with gzip.open(path, "wb", compresslevel=9) as f:
        for _ in range(mib):
            f.write(chunk)


def long_line(path: Path, mib: int, gz: bool = False) -> None:
    """A text file of one ``mib`` MiB line of numbers (no newline)."""
    chunk = b"0.0," * (1 << 18)
    opener = gzip.open if gz else open
    with opener(path, "wb") as f:
        for _ in range(mib):
            f.write(chunk)


def npy(path: Path, shape: tuple, values: list[float] | None = None, descr: str = "<f8",
        header_shape: str | None = None, truncate: int = 0) -> None:
    """A version-1 ``.npy`` of float64 (or ``descr``) data, ``header_shape`` overriding the
    header's shape text, the data cut short by ``truncate`` bytes."""
    count = 1
    for s in shape:
        count *= s
    if values is None:
        values = [0.01 * math.sin(i) for i in range(count)]
    shape_text = header_shape or (f"({shape[0]},)" if len(shape) == 1 else f"({', '.join(map(str, shape))})")
    header = f"{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape_text}, }}"
    header += " " * ((64 - (10 + len(header) + 1) % 64) % 64) + "\n"
    data = struct.pack(f"<{count}d", *values) if descr == "<f8" else bytes(8 * count)
    if truncate:
        data = data[:-truncate]
    path.write_bytes(b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header.encode() + data)


def edit_safetensors(source: Path, path: Path, config_edit=None, tensor_fill: dict | None = None) -> None:
    """A copy of ``source`` with its config edited (``config_edit(dict)``) and named f32
    tensors filled with one value (``tensor_fill``: name -> value)."""
    raw = source.read_bytes()
    n = struct.unpack("<Q", raw[:8])[0]
    header = json.loads(raw[8:8 + n])
    data = bytearray(raw[8 + n:])
    if config_edit:
        config = json.loads(header["__metadata__"]["config"])
        config_edit(config)
        header["__metadata__"]["config"] = json.dumps(config)
    for name, value in (tensor_fill or {}).items():
        start, end = header[name]["data_offsets"]
        assert header[name]["dtype"] == "F32"
        data[start:end] = struct.pack("<f", value) * ((end - start) // 4)
    text = json.dumps(header).encode()
    text += b" " * ((8 - len(text) % 8) % 8)
    path.write_bytes(struct.pack("<Q", len(text)) + text + bytes(data))


def data_dir(root: Path, columns: int, rows: int = 400) -> Path:
    """A data root ``root/h3.6m/dataset/S5`` whose walking files have ``columns`` columns."""
    s5 = root / "h3.6m" / "dataset" / "S5"
    s5.mkdir(parents=True, exist_ok=True)
    for sub in (1, 2):
        (s5 / f"walking_{sub}.txt").write_text(expmap_text(rows, columns))
    return root


def mutate_text(text: str, rng, kind: str) -> str:
    """One random corruption of a text file (``kind`` picks which)."""
    lines = text.split("\n")
    i = rng.randrange(len(lines))
    if kind == "truncate":
        return text[: rng.randrange(len(text))]
    if kind == "drop-line":
        del lines[i]
    elif kind == "dup-line":
        lines.insert(i, lines[i])
    elif kind == "token":
        words = lines[i].split(" ")
        j = rng.randrange(len(words))
        words[j] = rng.choice(["nan", "inf", "-inf", "1e309", "-", "1e-400", "99999999999999999999",
                               "0x10", "", "\x00", "\u00e9", "{", "}", "CHANNELS", "-1", "7"])
        lines[i] = " ".join(words)
    elif kind == "bytes":
        b = bytearray(text.encode())
        for _ in range(rng.randrange(1, 8)):
            b[rng.randrange(len(b))] = rng.randrange(256)
        return b.decode("utf-8", errors="replace")
    return "\n".join(lines)


def sparse(path: Path, size: int) -> None:
    """A file of ``size`` zero bytes that takes no disk space."""
    with open(path, "wb") as f:
        f.truncate(size)


def fifo(path: Path) -> None:
    """A FIFO nobody writes to."""
    os.mkfifo(path)


def adler(path: Path) -> int:
    """A checksum of a file's bytes (inputs must not change); -1 when it is not a regular file."""
    if not path.is_file():
        return -1
    with open(path, "rb") as f:
        return zlib.adler32(f.read())
