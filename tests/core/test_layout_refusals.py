"""A packed vector's layout refuses a definition it cannot mean (a field twice, a dotted
field, an empty field, element names that do not match) and a pack or lookup that does
not fit, naming the layout and the field; the parameter view refuses a vector of the
wrong size and an unknown name, and reads a Params by name."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core.layout import Layout
from ballbot_casadi.core.params import PARAM_NAMES, ParamView, load_params
from ballbot_casadi.errors import ParameterError

INNER = Layout("inner", [("a", 2), ("b", 1)])
OUTER = Layout("outer", [("x", 1), ("in", INNER), ("y", 3)])


@pytest.mark.parametrize("fields, names, message", [
    ([("a", 1), ("a", 2)], None, r"^layout L: field 'a' repeated, dotted or of size 2$"),
    ([("a.b", 1)], None, r"^layout L: field 'a\.b' repeated, dotted or of size 1$"),
    ([("a", 0)], None, r"^layout L: field 'a' repeated, dotted or of size 0$"),
    ([("a", 2)], ["only"], r"^layout L: 1 element names for 2 entries$"),
])
def test_a_definition_it_cannot_mean(fields, names, message):
    with pytest.raises(ValueError, match=message):
        Layout("L", fields, names)


def test_the_smallest_definitions_are_allowed():
    one = Layout("L", [("a", 1)], ["alpha"])
    assert (one.size, one.names, len(one)) == (1, ("alpha",), 1)
    assert OUTER.names == ("x", "in.a0", "in.a1", "in.b", "y0", "y1", "y2") and len(OUTER) == 7


def test_lookups_that_do_not_fit():
    assert OUTER.part("in") is INNER
    with pytest.raises(KeyError, match=r"outer field 'y' is not a nested layout; nested: in"):
        OUTER.part("y")
    with pytest.raises(KeyError, match=r"inner field 'a' is not a nested layout; nested: none"):
        INNER.part("a")
    assert OUTER.has("in.b") and not OUTER.has("in.c") and not OUTER.has("z")


def test_pack_refuses_a_field_of_the_wrong_size():
    with pytest.raises(ValueError, match=r"^outer: field 'y' has 2 entries, expected 3$"):
        OUTER.pack({"x": 1.0, "in": np.zeros(3), "y": [1.0, 2.0]})
    v = OUTER.pack({"x": 1.0, "in.a": [2.0, 3.0], "in.b": 4.0, "y": [5.0, 6.0, 7.0]})
    np.testing.assert_array_equal(v, [1, 2, 3, 4, 5, 6, 7])


def test_the_parameter_view():
    p = load_params().replace(Mb=13.0)
    assert ParamView(p).Mb == 13.0                       # a Params, read by name
    assert ParamView(p.to_vector()).l == p.l
    with pytest.raises(ParameterError, match=rf"^parameter vector has {len(PARAM_NAMES) - 1} "
                                             rf"entries, expected {len(PARAM_NAMES)}$"):
        ParamView(p.to_vector()[:-1])
    with pytest.raises(AttributeError, match=r"^unknown parameter 'mass'$"):
        ParamView(p).mass  # noqa: B018
