"""Atomic file and folder writing, deterministic zip archives, content manifests and path checks.

A reader (another process, a Dask worker, the next run after a crash or Ctrl-C) must
never see a half-written output.  The helpers here give these guarantees:

* :func:`atomic_write_text` / :func:`atomic_write_bytes`: a file is written to a
  temporary name in the *same* directory, flushed to disk (``fsync``) and renamed over
  the target with :func:`os.replace`.  Readers see the old file or the new one, never a
  mix; an interrupted write leaves at most a hidden ``.<name>.*.tmp`` file behind.
* :func:`staged_dir`: a whole output folder (e.g. a study's ``run.npz``,
  ``metrics.json``, plots and ``report.md``) is written into a fresh sibling folder that
  replaces the old one in one step at the end, so the files always belong together.  On
  an error the old folder is left untouched.  Use it as::

      with staged_dir(out, owned=("*.json", "*.png")) as tmp:
          np.savez(tmp / "run.npz", ...)
          (tmp / "metrics.json").write_text(...)   # plain writes are fine inside
          (tmp / "report.md").write_text(...)
      # here `out` holds exactly the new files

  Only folders that ballbot wrote may be replaced: ``out`` must be new, empty, marked by
  an earlier :func:`staged_dir` (a hidden ``.ballbot-output`` file) or contain only
  files matching the ``owned`` patterns; anything else raises :class:`PathError`
  instead of deleting someone's files.  :func:`check_output_dir` with the same
  ``owned`` tells that before any computation.
* :func:`zip_bytes`: a deterministic zip archive (sorted members, fixed timestamps and
  modes), so an FMU or SSP rebuilt from the same content has the same bytes.
* :func:`write_manifest` / :func:`check_manifest`: the size and SHA-256 of build
  artifacts, recorded (atomically, last) when they are built and compared before they
  are used, so a truncated, emptied or deleted file is detected and rebuilt instead of
  crashing the process that loads it.

:func:`check_output_dir` and :func:`check_input_file` validate command-line paths before
any work starts (they raise :class:`PathError`, a :class:`~ballbot_casadi.errors.BallbotError`).
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import errno
import fnmatch
import hashlib
import io
import json
import os
import shutil
import tempfile
import zipfile
from pathlib import Path
from typing import Iterable, Iterator, Mapping

from ballbot_casadi.errors import PathError

__all__ = [
    "PathError",
    "OUTPUT_MARKER",
    "atomic_write_text",
    "atomic_write_bytes",
    "zip_bytes",
    "staged_dir",
    "sha256_file",
    "write_manifest",
    "check_manifest",
    "check_output_dir",
    "check_output_file",
    "check_input_file",
]

#: Hidden file that marks a folder written by :func:`staged_dir` (so it may be replaced).
OUTPUT_MARKER = ".ballbot-output"
#: Date and time of every member of a :func:`zip_bytes` archive (the zip format's epoch).
ZIP_DATE_TIME = (1980, 1, 1, 0, 0, 0)
#: Read block size of :func:`sha256_file`.
_BLOCK = 1 << 20


# --------------------------------------------------------------------------- atomic files


def _fsync_dir(path: Path) -> None:
    """Flush a directory entry (the rename) to disk; best effort."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def atomic_write_bytes(path: str | os.PathLike, data: bytes, mode: int = 0o644) -> Path:
    """Write ``data`` to ``path`` atomically (temporary file, ``fsync``, :func:`os.replace`).

    Parameters
    ----------
    path
        Target file; its directory must exist.
    data
        The complete content.
    mode
        Permission bits of the new file.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    _fsync_dir(path.parent)
    return path


def zip_bytes(members: Mapping[str, bytes], executable: Iterable[str] = ()) -> bytes:
    """A deflated zip archive of ``members`` (name -> content) that depends on nothing else:
    members in sorted order, each dated :data:`ZIP_DATE_TIME`, mode 0755 for the names in
    ``executable`` and 0644 for the others."""
    executable = set(executable)
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        for name in sorted(members):
            info = zipfile.ZipInfo(name, ZIP_DATE_TIME)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = (0o755 if name in executable else 0o644) << 16
            zf.writestr(info, members[name])
    return buf.getvalue()


def atomic_write_text(path: str | os.PathLike, text: str, encoding: str = "utf-8",
                      mode: int = 0o644) -> Path:
    """Write ``text`` to ``path`` atomically (see :func:`atomic_write_bytes`)."""
    return atomic_write_bytes(path, text.encode(encoding), mode)


# --------------------------------------------------------------------------- staged folders

_RENAME_EXCHANGE = 2  # linux/fs.h


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths atomically with ``renameat2(RENAME_EXCHANGE)``; False if unsupported."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd = -100
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    fn.restype = ctypes.c_int
    if fn(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _foreign_entries(folder: Path, owned: Iterable[str]) -> list[str]:
    """Entries of an existing output folder that :func:`staged_dir` must not delete."""
    if not folder.is_dir():
        return []
    names = sorted(p.name for p in folder.iterdir())
    if OUTPUT_MARKER in names:
        return []
    pats = tuple(owned)
    return [n for n in names if not any(fnmatch.fnmatchcase(n, p) for p in pats)]


@contextlib.contextmanager
def staged_dir(final: str | os.PathLike, owned: Iterable[str] = ()) -> Iterator[Path]:
    """Write a folder's content in a fresh sibling folder that replaces ``final`` at the end.

    Yields a new, empty temporary folder next to ``final`` (same file system, hidden
    name ``.<name>.stage-*``).  When the ``with`` block ends normally, the temporary
    folder takes the place of ``final`` in one atomic ``renameat2(RENAME_EXCHANGE)`` swap
    (two renames where the file system lacks it) and the old content is deleted.  When
    the block raises (or is interrupted), the temporary folder is deleted and ``final``
    is left exactly as it was.  Readers therefore see either all old or all new files.

    Parameters
    ----------
    final
        The output folder.  Its parent is created if missing.
    owned
        ``fnmatch`` patterns of files an existing ``final`` may hold without the marker
        (e.g. outputs of older versions, ``("*.json", "*.png")``).

    Raises
    ------
    PathError
        ``final`` is an existing file, or an existing folder holding entries that
        ballbot did not write (it is never deleted).
    """
    final = Path(final)
    owned = tuple(owned)
    _check_replaceable(final, owned)
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.stage-", dir=final.parent))
    try:
        yield tmp
        (tmp / OUTPUT_MARKER).write_text("written by ballbot-casadi (core/files.py staged_dir)\n")
        _check_replaceable(final, owned)  # the folder may have changed meanwhile
        for f in tmp.rglob("*"):
            if f.is_file():
                with open(f, "rb") as fh:
                    os.fsync(fh.fileno())
        os.chmod(tmp, 0o755)
        if final.exists() and _exchange(tmp, final):
            pass  # tmp now holds the old content, deleted below
        else:
            _replace_by_renames(tmp, final)
        _fsync_dir(final.parent)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _replace_by_renames(tmp: Path, final: Path) -> None:
    """Fallback of :func:`staged_dir` without RENAME_EXCHANGE: move old aside, new in."""
    for _ in range(10):
        old = None
        if final.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{final.name}.old-", dir=final.parent))
            os.replace(final, old)  # an empty directory target is replaced
        try:
            os.rename(tmp, final)
        except OSError as exc:
            if exc.errno not in (errno.ENOTEMPTY, errno.EEXIST):
                raise
            continue  # another process put its folder there first: retry
        finally:
            if old is not None:
                shutil.rmtree(old, ignore_errors=True)
        return
    raise PathError(f"could not replace {final}: another process keeps writing it")


def _check_replaceable(final: Path, owned: tuple[str, ...]) -> None:
    if final.exists() and not final.is_dir():
        raise PathError(f"{final} is an existing file; give a directory for the outputs")
    foreign = _foreign_entries(final, owned)
    if foreign:
        shown = ", ".join(repr(n) for n in foreign[:3]) + (" ..." if len(foreign) > 3 else "")
        raise PathError(
            f"{final} already holds files that ballbot did not write ({shown}); it would be "
            "replaced as a whole: give a new or empty directory")


# --------------------------------------------------------------------------- manifests


def sha256_file(path: str | os.PathLike) -> str:
    """Hex SHA-256 of a file's content."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(_BLOCK), b""):
            h.update(block)
    return h.hexdigest()


def write_manifest(folder: str | os.PathLike, names: Iterable[str],
                   manifest: str = "MANIFEST.json", extra: Mapping[str, str] | None = None) -> Path:
    """Record size and SHA-256 of the files ``names`` of ``folder`` in ``folder/manifest``.

    Write it *after* the files are in place: its presence means "complete".  Written
    atomically; returns its path.
    """
    folder = Path(folder)
    files = {}
    for n in names:
        p = folder / n
        files[n] = {"size": p.stat().st_size, "sha256": sha256_file(p)}
    doc = {"format": 1, "files": files, **({"extra": dict(extra)} if extra else {})}
    return atomic_write_text(folder / manifest, json.dumps(doc, indent=1, sort_keys=True) + "\n")


def check_manifest(folder: str | os.PathLike, names: Iterable[str] | None = None,
                   manifest: str = "MANIFEST.json") -> str | None:
    """Verify the files recorded in ``folder/manifest``; ``None`` if intact, else the reason.

    ``names`` (optional) must all be recorded.  Every recorded file must exist with the
    recorded size and SHA-256.
    """
    folder = Path(folder)
    mpath = folder / manifest
    try:
        doc = json.loads(mpath.read_text())
        files = doc["files"]
        if not isinstance(files, dict):
            raise TypeError
    except FileNotFoundError:
        return f"no manifest {mpath}"
    except (OSError, ValueError, KeyError, TypeError):
        return f"unreadable manifest {mpath}"
    for n in names or ():
        if n not in files:
            return f"{n} is not recorded in {mpath}"
    for n, rec in files.items():
        p = folder / n
        try:
            size = p.stat().st_size
        except OSError:
            return f"{p} is missing"
        if size != rec.get("size"):
            return f"{p} has {size} bytes, {rec.get('size')} were built"
        if sha256_file(p) != rec.get("sha256"):
            return f"{p} content differs from the build (SHA-256 mismatch)"
    return None


# --------------------------------------------------------------------------- path checks

_PSEUDO_FS = (Path("/proc"), Path("/sys"), Path("/dev"))


def check_output_dir(path: str | os.PathLike, what: str = "--out",
                     owned: Iterable[str] | None = None) -> Path:
    """Check that ``path`` can be used as an output folder, before any work is done.

    The folder may exist (then it must be a directory) or not (then its nearest
    existing ancestor must be a writable directory on a real file system, tested by
    creating and removing a temporary file).  With ``owned`` (see :func:`staged_dir`),
    an existing folder must also be replaceable.  Nothing is created.

    Returns
    -------
    Path
        ``path`` as given.

    Raises
    ------
    PathError
        With a one-line message naming ``what``.
    """
    p = Path(path)
    absolute = Path(os.path.abspath(p))
    real = Path(os.path.realpath(p))
    if any(r == d or d in r.parents for d in _PSEUDO_FS for r in (absolute, real)):
        raise PathError(f"{what} {p}: /proc, /sys and /dev are system pseudo-file systems; "
                        "give a normal directory")
    try:
        if p.exists() and not p.is_dir():
            raise PathError(f"{what} {p} is an existing file; give a directory")
        base = absolute
        while not base.exists():
            base = base.parent
    except OSError as exc:  # e.g. an ancestor that may not be entered
        raise PathError(f"{what} {p}: cannot access it ({exc.strerror or exc})") from None
    if not base.is_dir():
        raise PathError(f"{what} {p}: {base} is a file, so the directory cannot be created")
    try:
        fd, probe = tempfile.mkstemp(prefix=".ballbot-probe-", dir=base)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise PathError(f"{what} {p}: cannot write in {base} ({exc.strerror or exc})") from None
    if owned is not None:
        try:
            _check_replaceable(p, tuple(owned))
        except PathError as exc:
            raise PathError(f"{what} {exc}") from None
    return p


def check_output_file(path: str | os.PathLike, what: str = "--out") -> Path:
    """Check that ``path`` can be written as a file (not a folder; its folder writable)."""
    p = Path(path)
    if p.is_dir():
        raise PathError(f"{what} {p} is a directory; give a file name")
    check_output_dir(p.parent if str(p.parent) else Path("."), what=f"{what} {p}: folder")
    return p


def check_input_file(path: str | os.PathLike, what: str = "--params") -> Path:
    """Check that ``path`` is an existing, readable regular file, before any work is done.

    Raises
    ------
    PathError
        Missing, a directory, or unreadable (one-line message naming ``what``).
    """
    p = Path(path)
    if not p.exists():
        raise PathError(f"{what} {p} does not exist")
    if p.is_dir():
        raise PathError(f"{what} {p} is a directory; give a file")
    try:
        with open(p, "rb") as f:
            f.read(1)
    except OSError as exc:
        raise PathError(f"{what} {p} cannot be read ({exc.strerror or exc})") from None
    return p
