"""Names that become paths: each refusal's own reason (one line, what was wrong and what
is allowed), the length limit exactly at and one byte past ``NAME_MAX``, and the archive
member rules one by one."""

from __future__ import annotations

import pytest

from ballbot_casadi.core.safe_paths import NAME_MAX, check_file_name, member_problem, name_problem
from ballbot_casadi.errors import PathError


def test_name_max_is_200_bytes_counted_in_utf8_at_and_past_the_limit():
    assert NAME_MAX == 200
    assert name_problem("a" * 200) is None
    assert name_problem("a" * 201) == "at most 200 bytes, got 201"
    assert name_problem("é" * 100) is None                         # 200 bytes, 100 characters
    assert name_problem("é" * 100 + "a") == "at most 200 bytes, got 201"


@pytest.mark.parametrize("name, reason", [
    (3, "expected a string, got int"),
    ("", "must not be empty"),
    ("  ", "must not be empty"),
    ("a/b", "must be a plain name, not a path ('a/b')"),
    ("a\\b", "must be a plain name, not a path"),
    ("C:x", "must be a plain name, not a path ('C:x')"),
    ("..", "must not be '.' or '..'"),
    (" . ", "must not be '.' or '..'"),
    ("a\tb", "must not contain control characters ('a\\tb')"),
    ("a\x7fb", "must not contain control characters"),
    ("-x", "must not start with '-' ('-x')"),
])
def test_each_refusal_names_its_own_reason(name, reason):
    problem = name_problem(name)
    assert problem is not None and problem.startswith(reason), problem
    assert "\n" not in problem
    if not isinstance(name, int) and "bytes" not in problem:
        assert problem.endswith("allowed: one file-name component: no '/', '\\', drive prefix, "
                                "'.', '..' or control characters")


@pytest.mark.parametrize("name", ["x-", "a-b", "a.b", "..x", "x..", "1:2", "ab:c", "é"])
def test_names_that_only_look_suspicious_are_kept(name):
    assert name_problem(name) is None
    assert check_file_name(name, "what") == name


def test_check_file_name_prefixes_what_and_raises_path_error():
    with pytest.raises(PathError) as exc:
        check_file_name("../x", "scenario name")
    assert str(exc.value) == ("scenario name: must be a plain name, not a path ('../x'); allowed: "
                              "one file-name component: no '/', '\\', drive prefix, '.', '..' or "
                              "control characters")


@pytest.mark.parametrize("member, reason", [
    ("", "member '' has an empty name or control characters"),
    ("a\nb", "member 'a\\nb' has an empty name or control characters"),
    ("/x", "member '/x' has an absolute path"),
    ("\\x", "member '\\\\x' has an absolute path"),
    ("c:x", "member 'c:x' has an absolute path"),
    ("a/../b", "member 'a/../b' climbs out of the archive folder ('..')"),
    ("a\\..", "member 'a\\\\..' climbs out of the archive folder ('..')"),
    ("..", "member '..' climbs out of the archive folder ('..')"),
])
def test_member_refusals_by_reason(member, reason):
    assert member_problem(member) == reason


@pytest.mark.parametrize("member", ["a", "a/b.fmu", "resources/x..y", "...", "a/.../b",
                                    "binaries/linux64/m.so", "ab:c", "./a"])
def test_members_inside_the_folder_are_kept(member):
    assert member_problem(member) is None
