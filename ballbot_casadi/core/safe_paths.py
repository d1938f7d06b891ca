"""Names that become paths, and archive member paths, checked before any file is touched.

Two kinds of untrusted text end up as file names:

* a *name* the user chose (a scenario's ``name``, ``--set name=...``) from which ballbot
  builds a file name inside its own output folder (``worst/<name>_mc0007.toml``).  It must
  be one plain file-name component: :func:`name_problem` / :func:`check_file_name`;
* a *member path* inside an archive someone else wrote (``.ssp``, ``.fmu``), extracted
  under a folder of ours.  It must stay below that folder ("zip slip"):
  :func:`member_problem`.

Both return (or raise with) one line saying what was wrong and what is allowed.
"""

from __future__ import annotations

import re

from ballbot_casadi.errors import PathError

__all__ = ["NAME_MAX", "name_problem", "check_file_name", "member_problem"]

#: Longest name allowed (bytes of UTF-8), leaving room for suffixes such as ``_mc0001.toml``
#: within the usual 255-byte file-name limit.
NAME_MAX = 200
_ALLOWED = "one file-name component: no '/', '\\', drive prefix, '.', '..' or control characters"
_CONTROL = re.compile(r"[\x00-\x1f\x7f]")
_DRIVE = re.compile(r"^[A-Za-z]:")


def name_problem(name: str) -> str | None:
    """Why ``name`` cannot be used as one file-name component, or ``None`` if it can.

    Refused: empty, ``.`` or ``..``, a path separator (``/``, ``\\``), a
    Windows drive prefix, control characters, a leading ``-`` or more than
    :data:`NAME_MAX` bytes.
    """
    if not isinstance(name, str):
        return f"expected a string, got {type(name).__name__}"
    if not name.strip():
        return f"must not be empty; allowed: {_ALLOWED}"
    if "/" in name or "\\" in name or _DRIVE.match(name):
        return f"must be a plain name, not a path ({name!r}); allowed: {_ALLOWED}"
    if name.strip() in (".", ".."):
        return f"must not be '.' or '..'; allowed: {_ALLOWED}"
    if _CONTROL.search(name):
        return f"must not contain control characters ({name!r}); allowed: {_ALLOWED}"
    if name.startswith("-"):
        return f"must not start with '-' ({name!r}); allowed: {_ALLOWED}"
    if len(name.encode("utf-8")) > NAME_MAX:
        return f"at most {NAME_MAX} bytes, got {len(name.encode('utf-8'))}"
    return None


def check_file_name(name: str, what: str) -> str:
    """``name`` if it is one plain file-name component (see :func:`name_problem`).

    Raises
    ------
    PathError
        ``what``: the reason and what is allowed (one line).
    """
    problem = name_problem(name)
    if problem is not None:
        raise PathError(f"{what}: {problem}")
    return name


def member_problem(member: str) -> str | None:
    """Why an archive member path would land outside the extraction folder, or ``None``.

    Refused: absolute paths (``/x``, ``\\x``, ``C:x``), any ``..`` component (with either
    separator), NUL and other control characters, empty names.
    """
    if not member or _CONTROL.search(member):
        return f"member {member!r} has an empty name or control characters"
    if member.startswith(("/", "\\")) or _DRIVE.match(member):
        return f"member {member!r} has an absolute path"
    if ".." in re.split(r"[/\\]", member):
        return f"member {member!r} climbs out of the archive folder ('..')"
    return None
