"""ONNX Runtime held to its AVX2 kernels on an AVX-512 machine, for `compare_inference.py --ort-avx2`.

Issue 16's targets compare our AVX2 path with ONNX Runtime's AVX2 kernels. On a machine with
AVX-512, ONNX Runtime (its MLAS library) always picks its AVX-512 kernels, and there is no option
to hold it to AVX2; the CPUID-faulting trick (`arch_prctl(ARCH_SET_CPUID)`) that would hide the
AVX-512 bits from a process is not offered inside these VMs (ENODEV). So this module makes a
private copy of the installed `onnxruntime` package in which MLAS's platform set-up never takes its
AVX-512 branch:

    MLAS_PLATFORM::MLAS_PLATFORM():  ...  if (AVX512F in CPUID leaf 7) {
        if ((xcr0 & 0xE0) == 0xE0) { <AVX-512 kernels> }     // compiled: not rax; test $0xe0,%al; je
    }

In the compiled library (x86-64 builds of 1.31.x: the constructor is inlined at 4 places in each
of `libonnxruntime.so` and the Python extension) the `je` after ``48 f7 d0 a8 e0`` (``not %rax;
test $0xe0,%al``) becomes a 6-byte NOP, so MLAS keeps the AVX2/FMA3 kernels it selected just
before (the same as on a CPU without AVX-512). Nothing else changes; the installed package is not
touched. The copy is refused (an error, no copy) when the pattern is not found exactly as
expected, e.g. for another ONNX Runtime version.

It works: on a 2-core AMD EPYC Zen 4 VM a 1 x 512 @ 512 x 1536 MatMul (GEMV) takes 45-46 µs
with the installed package and 58-65 µs with the copy (the AVX2 GEMV), the same within noise at
256 rows (Zen 4 executes AVX-512 on 256-bit units, so both GEMMs have the same FMA peak there).

`python ort_avx2.py --serve` is the worker `compare_inference.py` runs with the copy first on
``PYTHONPATH``: one JSON request per line on stdin (``{"onnx": PATH, "threads": N, "feeds":
NPZ, "steps": N}``), one JSON reply per line (``{"us": median µs per step, "ort": the imported
package's path}``), the same closed loop as the in-process ORT runner (`step_graph.run_closed_loop`).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys

# `not %rax; test $0xe0,%al; je rel32` — the AVX-512 state test of MLAS's platform set-up.
AVX512_TEST = re.compile(rb"\x48\xf7\xd0\xa8\xe0\x0f\x84")
NOP6 = b"\x66\x0f\x1f\x44\x00\x00"
# Libraries that carry MLAS in the wheel, and how many inlined copies of the test each must have.
EXPECTED_SITES = {"libonnxruntime.so": 4, "onnxruntime_pybind11_state": 4}


class PatchError(RuntimeError):
    """The installed ONNX Runtime does not look like the build this patch was written for."""


def installed_package() -> str:
    """The directory of the `onnxruntime` package this interpreter imports."""
    import importlib.util

    spec = importlib.util.find_spec("onnxruntime")
    if spec is None or spec.origin is None:
        raise PatchError("onnxruntime is not installed (pip install -r benches/compare/requirements.txt)")
    return os.path.dirname(spec.origin)


def patch_library(data: bytearray, name: str) -> int:
    """Replaces every AVX-512 branch in ``data`` (the bytes of library ``name``); returns how many."""
    sites = [m.start() for m in AVX512_TEST.finditer(data)]
    expected = next((n for key, n in EXPECTED_SITES.items() if name.startswith(key)), None)
    if expected is not None and len(sites) != expected:
        raise PatchError(
            f"{name}: found the AVX-512 test of MLAS {len(sites)} times, expected {expected}; "
            "this onnxruntime build is not the one the patch was written for (1.31.x, x86-64)"
        )
    for at in sites:
        data[at + 5 : at + 11] = NOP6
    return len(sites)


def make_avx2_copy(dest: str) -> str:
    """Copies the installed onnxruntime into ``dest/onnxruntime`` with MLAS held to AVX2; returns
    ``dest`` (the directory to put first on ``PYTHONPATH``)."""
    src = installed_package()
    pkg = os.path.join(dest, "onnxruntime")
    if os.path.exists(pkg):
        shutil.rmtree(pkg)
    shutil.copytree(src, pkg)
    capi = os.path.join(pkg, "capi")
    patched = {}
    for name in sorted(os.listdir(capi)):
        if not any(name.startswith(key) for key in EXPECTED_SITES):
            continue
        path = os.path.join(capi, name)
        with open(path, "rb") as f:
            data = bytearray(f.read())
        patched[name] = patch_library(data, name)
        with open(path, "wb") as f:
            f.write(data)
    if not any(patched.values()):
        shutil.rmtree(pkg)
        raise PatchError(f"no library of {src} has MLAS's AVX-512 test; nothing to hold to AVX2")
    return dest


class Worker:
    """A ``--serve`` process importing the AVX2 copy; ``time(onnx, threads, feeds_npz, steps)``."""

    def __init__(self, copy_dir: str):
        env = dict(os.environ, PYTHONPATH=os.pathsep.join([copy_dir, os.environ.get("PYTHONPATH", "")]))
        self.proc = subprocess.Popen(
            [sys.executable, os.path.abspath(__file__), "--serve"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            env=env,
        )
        self.package = None

    def time(self, onnx: str, threads: int, feeds: str, steps: int) -> float:
        request = {"onnx": onnx, "threads": threads, "feeds": feeds, "steps": steps}
        self.proc.stdin.write(json.dumps(request) + "\n")
        self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError(f"the ONNX Runtime AVX2 worker exited (code {self.proc.wait()})")
        reply = json.loads(line)
        self.package = reply["ort"]
        return reply["us"]

    def close(self) -> None:
        self.proc.stdin.close()
        self.proc.wait()


def serve() -> int:
    import numpy as np
    import onnxruntime as ort

    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from step_graph import run_closed_loop, session_for  # noqa: E402

    sessions = {}
    for line in sys.stdin:
        req = json.loads(line)
        key = (req["onnx"], req["threads"])
        if key not in sessions:
            sessions[key] = session_for(req["onnx"], req["threads"])
        session = sessions[key]
        with np.load(req["feeds"]) as npz:
            feeds = {k: npz[k] for k in npz.files}
        us = run_closed_loop(lambda state: session.run(None, state), feeds, req["steps"])
        print(json.dumps({"us": us, "ort": os.path.dirname(ort.__file__)}), flush=True)
    return 0


if __name__ == "__main__":
    if sys.argv[1:] == ["--serve"]:
        sys.exit(serve())
    print(__doc__)
    sys.exit(2)
