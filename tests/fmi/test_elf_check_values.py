"""The shared-object check on hand-built 64-bit and 32-bit ELF images (every program-header
field its own value, so a misread neighbour shows): complete, then cut one byte
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
        # p_type PT_LOAD, p_flags R+X, p_offset, p_vaddr, p_paddr, p_filesz, p_memsz: every
        # field its own value, so reading a neighbour of p_offset or p_filesz changes the end
        off = 8 * (i + 1)
        struct.pack_into("<IIQQQQQ", data, 64 + i * PH, 1, 5, off, 0x400000 + off, 0x400000 + off,
                         segment_end - off, segment_end - off + 0x1000)
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
    data = _elf(64 + N_PH * PH)
    struct.pack_into("<H", data, 0x38, 0)
    assert shared_object_problem(bytes(data)) == "truncated: program headers end at 64, file has 232 bytes"


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


@pytest.mark.parametrize("cls, order", [(0, 1), (3, 1), (2, 0), (2, 3), (3, 3)])
def test_an_unknown_class_or_byte_order_is_refused(cls, order):
    """Either field alone outside {1, 2} refuses the image, before any table is read."""
    data = _elf(64 + N_PH * PH)
    data[4:6] = bytes((cls, order))
    assert shared_object_problem(bytes(data)) == f"unknown ELF class {cls} or byte order {order}"


def _elf32_big(segment_end: int) -> bytearray:
    """32-bit big-endian header (as on some ARM and PowerPC targets), 2 program headers of 32
    bytes at 64, each segment [0, segment_end)."""
    data = bytearray(64 + 2 * 32)
    data[:6] = b"\x7fELF\x01\x02"
    struct.pack_into(">II", data, 0x1C, 64, 0)     # e_phoff, e_shoff
    struct.pack_into(">HHHH", data, 0x2A, 32, 2, 40, 0)
    for i in range(2):
        # p_type, p_offset, p_vaddr, p_paddr, p_filesz, p_memsz, p_flags: each its own value
        off = 8 * (i + 1)
        struct.pack_into(">IIIIIII", data, 64 + i * 32, 1, off, 0x10000 + off, 0x10000 + off,
                         segment_end - off, segment_end - off + 0x1000, 5)
    return data


def test_a_32_bit_big_endian_image_is_read_with_its_own_layout():
    assert shared_object_problem(bytes(_elf32_big(128))) is None
    assert shared_object_problem(bytes(_elf32_big(129))) == ("truncated: segment 0 ends at byte "
                                                             "129, file has 128 bytes")
    cut = bytes(_elf32_big(100)[:120])
    assert shared_object_problem(cut) == "truncated: program headers end at 128, file has 120 bytes"
