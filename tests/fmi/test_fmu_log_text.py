"""What reaches the importer's logger: the whole message up to twice the model message
length, ``#`` escaped as ``##`` (the FMI message syntax reserves ``#``), ``%`` never passed
on (a logger may treat the message as a format), and a longer message cut, not overrun."""

from __future__ import annotations

import ctypes
import re

import pytest
from _fmu_support import Plant, fmi2_callbacks, plant_build, plant_dll
from fmpy.fmi1 import FMICallException

from ballbot_casadi.fmi.package import fmu_source_dir

pytestmark = pytest.mark.needs_cc

PREFIX = "fmi2SetDebugLogging: unknown log category '"
#: the FMI layer's model message length, read from its header
MSG_LEN = int(re.search(r"#define MSG_LEN (\d+)",
                        (fmu_source_dir() / "layer" / "fmi2_internal.h").read_text()).group(1))


def _logged(category: str) -> str:
    p = Plant("cs", name="log_text")
    with pytest.raises(FMICallException):
        p.fmu.setDebugLogging(True, [category])
    msg = p.errors()[-1]
    p.free()
    return msg


def test_a_message_longer_than_one_model_message_reaches_the_logger_whole():
    cat = "c" * 600 + "#" + "d" * 99  # 700 characters: more than MSG_LEN + 16 escaped
    assert _logged(cat) == PREFIX + "c" * 600 + "##" + "d" * 99 + "'"


def test_percent_signs_are_blanked_and_a_too_long_message_is_cut_at_its_buffer():
    assert _logged("a%sb") == PREFIX + "a sb'"
    msg = _logged("e" * 3000)
    # the text is formatted into 2 MSG_LEN bytes: its first 2 MSG_LEN - 1 characters
    assert msg == (PREFIX + "e" * 3000)[:2 * MSG_LEN - 1]


def _cut(prefix: str, n_hash: int) -> str:
    """``prefix`` then ``n_hash`` '#' as the layer escapes them into its 2 MSG_LEN + 16 byte
    output buffer: a character is copied while fewer than buflen - 3 are written (room for
    '##' and the terminator), so a run of '#' stops at the first even count past that."""
    buflen, out = 2 * MSG_LEN + 16, prefix
    for _ in range(n_hash):
        if len(out) + 3 >= buflen:
            break
        out += "##"
    return out


def test_a_message_of_hashes_is_cut_at_the_escaped_buffer_not_beyond():
    msg = _logged("#" * 3000)  # 2 MSG_LEN - 1 formatted characters, each escaped to two
    assert msg == _cut(PREFIX, 3000)
    assert len(msg) == 2 * MSG_LEN + 16 - 3  # 1037 characters with MSG_LEN 512


def test_an_instantiation_message_is_escaped_and_cut_like_an_instance_message():
    """The refusals before an instance exists (``fmu_log_early``) have their own buffer."""
    got = []
    cb = fmi2_callbacks(lambda env, name, status, category, msg: got.append((status, msg.decode())))
    f = plant_dll().fmi2Instantiate
    f.restype = ctypes.c_void_p
    for guid, want in (("g#1%d", "fmi2Instantiate: wrong GUID 'g##1 d', this binary of "
                                 f"BallbotPlant has GUID '{plant_build().guid}'"),
                       ("#" * 3000, _cut("fmi2Instantiate: wrong GUID '", 3000))):
        got.clear()
        assert f(b"early", ctypes.c_int(1), guid.encode(), b"", ctypes.byref(cb),
                 ctypes.c_int(0), ctypes.c_int(0)) is None
        assert got == [(3, want)]
