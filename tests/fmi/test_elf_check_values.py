"""The shared-object check on a hand-built 64-bit ELF image: complete, then cut one byte
short of each table and segment it must hold (issue 23: a check that read one program
header where it must read all of them survived)."""

from __future__ import annotations

import struct

import pytest

from ballbot_casadi.fmi.archive import shared_object_problem

PH, N_PH = 56, 3


def _elf(segment_end: int) -> bytearray:
    """64-bit little-endian header, N_PH program headers at 64, every segment [0, segment_end)."""
    data = bytearray(64 + N_PH * PH)
    data[:6] = b"\x7fELF\x02\x01"
    struct.pack_into("<Q", data, 0x20, 64)        # e_phoff
    struct.pack_into("<Q", data, 0x28, 0)         # e_shoff (no section headers)
    struct.pack_into("<HHHH", data, 0x36, PH, N_PH, 64, 0)
    for i in range(N_PH):
        struct.pack_into("<QQ", data, 64 + i * PH + 8, 0, 0)
        struct.pack_into("<Q", data, 64 + i * PH + 32, segment_end)
    return data


def test_a_complete_image_passes():
    assert shared_object_problem(bytes(_elf(64 + N_PH * PH))) is None


def test_program_headers_must_all_lie_inside():
    data = _elf(64 + N_PH * PH)
    cut = bytes(data[:64 + 2 * PH + 8])           # the first two headers fit, the third does not
    assert shared_object_problem(cut) == (f"truncated: program headers end at {64 + N_PH * PH}, "
                                          f"file has {len(cut)} bytes")


@pytest.mark.parametrize("extra", [1, 100])
def test_every_segment_must_lie_inside(extra):
    size = 64 + N_PH * PH
    problem = shared_object_problem(bytes(_elf(size + extra)))
    assert problem == f"truncated: segment 0 ends at byte {size + extra}, file has {size} bytes"


def test_no_program_header_is_refused():
    data = _elf(0)
    struct.pack_into("<H", data, 0x38, 0)
    assert "truncated" in shared_object_problem(bytes(data))


@pytest.mark.parametrize("shoff, problem", [
    (104, None),                                   # 2 x 64-byte section headers end at 232 = size
    (105, "truncated: section headers end at 233, file has 232 bytes"),
])
def test_section_headers_must_all_lie_inside(shoff, problem):
    size = 64 + N_PH * PH                          # 232
    data = _elf(size)
    struct.pack_into("<Q", data, 0x28, shoff)
    struct.pack_into("<HH", data, 0x3A, 64, 2)     # e_shentsize, e_shnum
    assert shared_object_problem(bytes(data)) == problem
