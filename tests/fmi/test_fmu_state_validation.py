"""FMU edges: crafted serialised states are refused, the error state is sticky until reset.

The serialised layout (fmu/fmi2_common.c) is public, and so is its FNV-1a checksum, so
a crafted state passes the checksum: the restore itself must validate the content.
Layout: magic[8] | GUID hash u64 | n_reals u64 | n_integers u64 | n_booleans u64 |
type i32 | mode u32 | time f64 | t_start f64 | reals f64[] | integers i32[] |
booleans i32[] | FNV-1a-64 of everything before.
"""

from __future__ import annotations

import struct
from ctypes import addressof, byref, c_char, c_double, c_size_t, c_uint, c_void_p

import numpy as np
import pytest
from _fmu_support import NXW, STATES, Plant, vr_table, vrs, vrs_of_type
from fmpy.fmi1 import FMICallException

from ballbot_casadi.model.numeric import make_state

pytestmark = pytest.mark.needs_cc

MODE_OFFSET, R_OFFSET = 44, 64
ST_EVENT, ST_STEP_COMPLETE, ST_STEP_FAILED = 1 << 2, 1 << 4, 1 << 5


def _fnv1a(data: bytes) -> int:
    h = 1469598103934665603
    for b in data:
        h = ((h ^ b) * 1099511628211) & 0xFFFFFFFFFFFFFFFF
    return h


def _reseal(body: bytes) -> bytes:
    """Append the checksum the FMU expects (anyone can compute it)."""
    return body + struct.pack("<Q", _fnv1a(body))


def _offset(name: str) -> tuple[int, str]:
    """Byte offset and struct format of a variable's value in a serialised state."""
    vr = vr_table()[name]
    reals, ints, bools = vrs_of_type("Real"), vrs_of_type("Integer"), vrs_of_type("Boolean")
    if vr in reals:
        return R_OFFSET + 8 * reals.index(vr), "<d"
    base = R_OFFSET + 8 * len(reals)
    if vr in ints:
        return base + 4 * ints.index(vr), "<i"
    return base + 4 * len(ints) + 4 * bools.index(vr), "<i"


def _craft(blob: bytes, mode: int | None = None, **values: float) -> bytes:
    body = bytearray(blob[:-8])
    if mode is not None:
        body[MODE_OFFSET:MODE_OFFSET + 4] = struct.pack("<I", mode)
    for name, v in values.items():
        off, fmt = _offset(name)
        body[off:off + struct.calcsize(fmt)] = struct.pack(fmt, v)
    return _reseal(bytes(body))


@pytest.fixture()
def cs_blob():
    p = Plant("cs", name="source")
    x0 = make_state(roll=0.02, dx=0.1)
    p.init(**dict(zip(STATES, x0.tolist())))
    p.step(0.005, 4)
    s = p.fmu.getFMUstate()
    blob = bytes(p.fmu.serializeFMUstate(s))
    p.fmu.freeFMUstate(s)
    p.free()
    assert struct.unpack_from("<I", blob, MODE_OFFSET)[0] == ST_STEP_COMPLETE
    assert struct.unpack_from("<i", blob, _offset("sensor_sample")[0])[0] == 4
    return blob


def _restore(blob: bytes) -> tuple[Plant, bool]:
    q = Plant("cs", name="target")
    try:
        s = q.fmu.deSerializeFMUstate(blob)
    except FMICallException:
        return q, False
    q.fmu.setFMUstate(s)
    q.fmu.freeFMUstate(s)
    return q, True


def test_resealed_unmodified_state_is_accepted(cs_blob):
    # the checksum computed here is the FMU's: a refusal below is about the content
    assert _reseal(cs_blob[:-8]) == cs_blob
    q, ok = _restore(_craft(cs_blob, q1=0.0, q2=0.0, q3=0.0, q0=1.0))
    assert ok and q.errors() == []
    assert q.get("q0")[0] == 1.0
    q.free()


@pytest.mark.parametrize("mode, message", [
    (ST_STEP_COMPLETE | ST_STEP_FAILED, "exactly one mode bit"),
    (ST_STEP_COMPLETE | 1, "exactly one mode bit"),
    (0, "invalid mode"),
    (1 << 8, "invalid mode"),  # fatal is never a state to restore
    (ST_EVENT, "does not exist for a Co-Simulation instance"),
])
def test_crafted_mode_is_refused(cs_blob, mode, message):
    q, ok = _restore(_craft(cs_blob, mode=mode))
    assert not ok
    assert any(message in m for m in q.errors()), q.errors()
    q.free()


@pytest.mark.parametrize("values, message", [
    ({"q0": 5.0}, "quaternion"),
    ({"q0": 0.0, "q1": 0.0, "q2": 0.0, "q3": 0.0}, "quaternion"),
    ({"Mb": -1.0}, "Mb"),
    ({"dq1": float("nan")}, "dq1"),
    ({"sensor_acc_x": float("inf")}, "sensor_acc_x"),
    ({"sensor_sample": -1}, "sensor_sample"),
    ({"seed": -5}, "an integer in [0, 2147483647]"),
    ({"noise_on": 2}, "must be fmi2True (1) or fmi2False (0)"),
    ({"Ts_sensor": 0.0}, "Ts_sensor"),
])
def test_crafted_values_are_refused_by_the_start_value_checks(cs_blob, values, message):
    q, ok = _restore(_craft(cs_blob, **values))
    assert not ok
    assert any(message in m for m in q.errors()), q.errors()
    # the instance is unchanged and still usable
    q.init()
    q.step(0.005)
    assert np.all(np.isfinite(q.state()))
    q.free()


def test_restored_state_may_carry_integration_drift(cs_blob):
    # a state the FMU integrated is not exactly unit norm; a tiny drift must restore
    q, ok = _restore(_craft(cs_blob, q0=1.0 + 1e-5, q1=0.0, q2=0.0, q3=0.0))
    assert ok, q.errors()
    q.free()


def _raw_get(p: Plant, names: list[str]) -> tuple[int, list[float]]:
    vr = vrs(*names)
    out = (c_double * len(vr))()
    st = p.raw("fmi2GetReal", (c_uint * len(vr))(*vr), len(vr), out)
    return st, list(out)


def test_get_real_keeps_failing_after_an_error_until_reset():
    p = Plant("me")
    p.init()
    x = make_state().tolist() + [0.0, 0.0, 0.0]
    x[STATES.index("dq1")] = 1e200  # the derivatives overflow
    p.fmu.setContinuousStates((c_double * NXW)(*x), NXW)
    # states and parameters are read without evaluating the model: no error yet
    st, vals = _raw_get(p, ["dq1", "q0", "Mk"])
    assert st == 0 and vals[:2] == [1e200, x[STATES.index("q0")]] and vals[2] > 0, vals
    assert p.errors() == []
    st, _ = _raw_get(p, ["der(dq1)"])
    assert st == 3  # fmi2Error: the model evaluated to Inf/NaN
    assert "NaN or Inf" in p.errors()[-1]
    n_logged = len(p.errors())
    for names in (["der(dq1)"], ["x", "q0"], ["roll"]):
        st, _ = _raw_get(p, names)
        assert st == 3, names  # not fmi2OK with NaN values
        assert "error state" in p.errors()[-1] and "fmi2Reset" in p.errors()[-1]
    assert len(p.errors()) == n_logged + 3  # every refusal went through the FMI logger
    p.fmu.reset()
    p.init()
    st, vals = _raw_get(p, ["der(dq1)", "q0"])
    assert st == 0 and vals[1] == 1.0 and np.all(np.isfinite(vals))
    p.free()


@pytest.mark.parametrize("offset, message", [
    (8, "the state was serialised by an FMU with a different GUID"),
    (16, "corrupt state: wrong number of Real variables"),
    (24, "corrupt state: wrong number of Integer variables"),
    (32, "corrupt state: wrong number of Boolean variables"),
])
def test_a_state_of_another_fmu_or_layout_is_refused(cs_blob, offset, message):
    """The header's GUID hash and variable counts, each changed by one and resealed."""
    body = bytearray(cs_blob[:-8])
    (u,) = struct.unpack_from("<Q", body, offset)
    struct.pack_into("<Q", body, offset, u + 1)
    q, ok = _restore(_reseal(bytes(body)))
    assert not ok
    assert q.errors() == [f"fmi2DeSerializeFMUstate: {message}"]
    q.free()


def test_state_pointer_arguments_are_checked():
    """NULL where a state or buffer must be, and a pointer to memory that is no state of
    this FMU, each refused with its own line (no crash, no write through it)."""
    p = Plant("cs", name="pointers")
    p.init()
    foreign = (c_char * 256).from_buffer_copy(b"Z" * 256)  # no state's magic number
    fp = c_void_p(addressof(foreign))
    s = c_void_p(None)
    size = c_size_t(0)
    calls = [
        (("fmi2GetFMUstate", None), "fmi2GetFMUstate: FMUstate is NULL"),
        (("fmi2GetFMUstate", byref(fp)), "fmi2GetFMUstate: *FMUstate is neither NULL nor a state "
                                         "of this FMU"),
        (("fmi2FreeFMUstate", None), "fmi2FreeFMUstate: FMUstate is NULL"),
        (("fmi2FreeFMUstate", byref(fp)), "fmi2FreeFMUstate: not an FMU state of this FMU"),
        (("fmi2SerializedFMUstateSize", None, byref(size)),
         "fmi2SerializedFMUstateSize: invalid FMUstate or size pointer"),
        (("fmi2DeSerializeFMUstate", None, c_size_t(8), byref(s)),
         "fmi2DeSerializeFMUstate: NULL argument"),
    ]
    for (fn, *args), message in calls:
        assert p.raw(fn, *args) == 3, fn
        assert p.errors()[-1] == message
    assert p.raw("fmi2GetFMUstate", byref(s)) == 0 and s.value is not None
    assert p.raw("fmi2SerializedFMUstateSize", s, byref(size)) == 0 and size.value > 64
    assert p.raw("fmi2SerializeFMUstate", s, None, size) == 3
    assert p.errors()[-1] == "fmi2SerializeFMUstate: invalid FMUstate or NULL buffer"
    buf = (c_char * size.value)()
    assert p.raw("fmi2SerializeFMUstate", s, buf, size) == 0
    assert p.raw("fmi2DeSerializeFMUstate", buf, size, byref(fp)) == 3
    assert p.errors()[-1] == ("fmi2DeSerializeFMUstate: *FMUstate is neither NULL nor a state of "
                              "this FMU")
    assert p.raw("fmi2FreeFMUstate", byref(s)) == 0 and s.value is None
    p.free()
