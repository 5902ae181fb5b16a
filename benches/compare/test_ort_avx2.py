"""The byte patch of `ort_avx2.py` on synthetic libraries (CI runs this without ONNX Runtime)."""

from __future__ import annotations

import os
import sys

import pytest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ort_avx2 import AVX512_TEST, NOP6, PatchError, patch_library  # noqa: E402

SITE = b"\x48\xf7\xd0\xa8\xe0\x0f\x84\xef\x00\x00\x00"  # not %rax; test $0xe0,%al; je rel32


def library(sites: int) -> bytearray:
    filler = bytes(range(7, 251))  # contains no site
    return bytearray(filler + b"".join(SITE + filler for _ in range(sites)))


def test_every_site_loses_its_branch_and_nothing_else_changes():
    data = library(4)
    before = bytes(data)
    assert patch_library(data, "libonnxruntime.so.1.31.1") == 4
    assert AVX512_TEST.search(data) is None
    patched = SITE[:5] + NOP6
    assert bytes(data) == before.replace(SITE, patched)
    assert len(data) == len(before)


def test_an_unexpected_number_of_sites_is_refused_untouched():
    data = library(3)
    before = bytes(data)
    with pytest.raises(PatchError, match="found the AVX-512 test of MLAS 3 times, expected 4"):
        patch_library(data, "onnxruntime_pybind11_state.cpython-311-x86_64-linux-gnu.so")
    assert bytes(data) == before


def test_a_library_without_expectations_is_patched_where_the_test_is():
    assert patch_library(library(0), "libother.so") == 0
    assert patch_library(library(2), "libother.so") == 2
