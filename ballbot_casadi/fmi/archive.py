"""Archives from elsewhere (``.ssp``, ``.fmu``) read without trusting them.

An SSP or FMU given by the user is checked before anything in it is extracted or loaded:

* :func:`check_members`: no member may land outside the extraction folder (absolute
  paths, ``..``: "zip slip"); checked for *every* member before the first is extracted
  (:func:`safe_extract`);
* :func:`verify_fmu`: an FMU is a readable zip with intact CRCs, safe members,
  ``modelDescription.xml`` and this platform's binary, and that binary is a *complete*
  shared object (:func:`shared_object_problem`: every ELF segment and the section
  table lie inside the file), so a truncated binary is refused with one line instead of
  killing the process with SIGBUS when it is loaded.

All raise :class:`~ballbot_casadi.errors.FileFormatError` (a user mistake, exit 2).
"""

from __future__ import annotations

import struct
import zipfile
from pathlib import Path

from ballbot_casadi.core.safe_paths import member_problem
from ballbot_casadi.errors import FileFormatError
from ballbot_casadi.fmi.package import _model_identifier, binary_member, validate_fmu_archive

__all__ = ["check_members", "safe_extract", "shared_object_problem", "verify_fmu"]


def check_members(zf: zipfile.ZipFile, where: str | Path) -> list[str]:
    """The member names of ``zf``, after checking that none escapes the extraction folder.

    Raises
    ------
    FileFormatError
        ``where``: the first offending member and why.
    """
    names = zf.namelist()
    for name in names:
        problem = member_problem(name)
        if problem is not None:
            raise FileFormatError(f"{where}: unsafe archive, {problem}; nothing was extracted")
    return names


def safe_extract(archive: str | Path, dest: str | Path) -> Path:
    """Extract ``archive`` into ``dest`` after :func:`check_members` accepted every member.

    Raises
    ------
    FileFormatError
        Not a readable zip, or an unsafe member (then nothing is extracted).
    """
    archive, dest = Path(archive), Path(dest)
    try:
        with zipfile.ZipFile(archive) as zf:
            check_members(zf, archive)
            zf.extractall(dest)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError) as exc:
        raise FileFormatError(f"{archive} is not a readable zip archive ({exc})") from None
    return dest


#: ELF layout by class (1: 32-bit, 2: 64-bit): word format, offsets of e_phoff, e_shoff and
#: e_phentsize (followed by e_phnum, e_shentsize, e_shnum), of p_offset and p_filesz.
_ELF = {1: ("I", 0x1C, 0x20, 0x2A, 4, 16), 2: ("Q", 0x20, 0x28, 0x36, 8, 32)}


def shared_object_problem(data: bytes) -> str | None:
    """Why ``data`` is not a complete ELF shared object, or ``None``.

    Checks the ELF magic, class and byte order, that the program header table and the
    section header table lie inside the data, and that every segment's file image
    (``p_offset + p_filesz``) does: a truncated binary fails one of these.
    """
    size = len(data)
    if size < 64 or data[:4] != b"\x7fELF":
        return f"not an ELF shared object ({size} bytes, magic {data[:4]!r})"
    cls, order = data[4], data[5]
    if cls not in _ELF or order not in (1, 2):
        return f"unknown ELF class {cls} or byte order {order}"
    fmt, phoff_at, shoff_at, sizes_at, off_at, filesz_at = _ELF[cls]
    e = "<" if order == 1 else ">"
    word = e + fmt
    phoff = struct.unpack_from(word, data, phoff_at)[0]
    shoff = struct.unpack_from(word, data, shoff_at)[0]
    phentsize, phnum, shentsize, shnum = struct.unpack_from(e + "HHHH", data, sizes_at)
    if phnum == 0 or phoff + phnum * phentsize > size:
        return f"truncated: program headers end at {phoff + phnum * phentsize}, file has {size} bytes"
    if shoff + shnum * shentsize > size:
        return f"truncated: section headers end at {shoff + shnum * shentsize}, file has {size} bytes"
    for i in range(phnum):
        base = phoff + i * phentsize
        p_offset = struct.unpack_from(word, data, base + off_at)[0]
        p_filesz = struct.unpack_from(word, data, base + filesz_at)[0]
        if p_offset + p_filesz > size:
            return (f"truncated: segment {i} ends at byte {p_offset + p_filesz}, file has "
                    f"{size} bytes")
    return None


def verify_fmu(path: str | Path, what: str | None = None) -> None:
    """Check an FMU archive before it is extracted or its binary loaded (module docstring).

    Raises
    ------
    FileFormatError
        ``what`` (default the path): what is wrong, in one line.
    """
    path = Path(path)
    what = what or str(path)
    try:
        validate_fmu_archive(path)  # readable zip, CRCs, modelDescription.xml, binary present
    except FileFormatError as exc:
        raise FileFormatError(f"{what}: {str(exc).removeprefix(str(path)).lstrip(': ')}") from None
    with zipfile.ZipFile(path) as zf:
        check_members(zf, what)
        member = binary_member(*_model_identifier(zf.read("modelDescription.xml"), path))
        problem = shared_object_problem(zf.read(member))
    if problem is not None:
        raise FileFormatError(f"{what}: {member} is {problem}")
