"""What reaches the importer's logger: the whole message up to twice the model message
length, ``#`` escaped as ``##`` (the FMI message syntax reserves ``#``), ``%`` never passed
on (a logger may treat the message as a format), and a longer message cut, not overrun."""

from __future__ import annotations

import re

import pytest
from _fmu_support import Plant
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
