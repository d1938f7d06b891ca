"""The plant FMU refuses sensor readings that overflow (``take_sample`` in
``fmu/plant/plant_model.c``).

No physical input makes a reading infinite, but the sensor parameters' rules let one
through: a positive accelerometer scale of 1e308 times gravity, or a gyroscope bias at the
edge of the doubles driven over it by its own random walk.  The FMU must then refuse with a
line naming the sample, never hand the importer an Inf.  Which sample overflows first is
worked out here from the counter-based noise (the same Philox draws the FMU makes).
"""

from __future__ import annotations

from ctypes import byref, c_double

import numpy as np
import pytest
from _fmu_support import SENSORS, Plant
from fmpy.fmi2 import fmi2EventInfo

from ballbot_casadi.core.rng import NoiseStream
from ballbot_casadi.model.sensors import NOISE_STREAMS

pytestmark = pytest.mark.needs_cc

TS = 0.005  # the sensor period the FMU starts with
B_EDGE = 1.79e308  # within a whisker of DBL_MAX (1.7977e308)
RW = 1e308  # the bias random walk sigma (rad/s/sqrt(s)): one step of sqrt(Ts) RW n


def _first_overflow(seed: int, axis: int, sign: float, n: int = 40) -> int:
    """The first sample k at which b_k = b_{k-1} + sqrt(Ts) RW n_{k-1} leaves the doubles."""
    draws = NoiseStream(seed).normal(NOISE_STREAMS["gyro_bias_rw"], n, 3)[:, axis]
    with np.errstate(over="ignore"):
        b = np.cumsum(np.r_[sign * B_EDGE, np.sqrt(TS) * RW * draws])
    bad = np.flatnonzero(~np.isfinite(b))
    assert bad.size, "the walk stays finite: choose another seed"
    return int(bad[0])


def test_an_infinite_reading_at_the_start_is_refused_at_initialisation():
    p = Plant("cs")
    p.fmu.setupExperiment(startTime=0.0)
    p.fmu.enterInitializationMode()
    p.set(acc_scale_z=1e308)  # at rest the z axis reads g: 9.81e308 is Inf
    st = p.raw("fmi2ExitInitializationMode")
    assert st == 3  # fmi2Error
    assert p.errors()[-1].endswith("the sensor readings at the start time are NaN or Inf")
    p.free()
    q = Plant("cs")  # a large but finite reading passes: the check is on finiteness
    q.init(acc_scale_z=1e300)
    assert np.isfinite(q.get(*SENSORS)).all() and q.get("sensor_acc_z")[0] > 1e300
    assert q.errors() == []
    q.free()


@pytest.mark.parametrize("axis,sign", [(0, 1.0), (2, -1.0)])
def test_a_bias_walk_out_of_the_doubles_is_refused_at_its_sample(axis, sign):
    seed = 5
    k_bad = _first_overflow(seed, axis, sign)
    assert k_bad >= 2  # the case separates "sample 1" from the sample that overflows
    c = "xyz"[axis]
    p = Plant("cs")
    p.init(noise_on=True, seed=seed, **{f"gyro_bias0_{c}": sign * B_EDGE,
                                        f"gyro_bias_rw_{c}": RW})
    for k in range(1, k_bad):
        p.step(TS)  # still finite: held and reported
        assert p.get_int("sensor_sample") == [k]
        assert np.isfinite(p.get(*SENSORS)).all()
        assert np.isfinite(p.get(f"sensor_gyro_bias_{c}")).all()
    st = p.raw("fmi2DoStep", c_double(p.t), c_double(TS), 1)
    assert st == 2  # fmi2Discard
    assert p.errors()[-1].endswith(f"sensor sample {k_bad} is NaN or Inf")
    p.free()


def test_model_exchange_refuses_the_overflowing_sample_at_its_event():
    seed, axis = 5, 0
    k_bad = _first_overflow(seed, axis, 1.0)
    m = Plant("me")
    m.init(noise_on=True, seed=seed, gyro_bias0_x=B_EDGE, gyro_bias_rw_x=RW)
    m.fmu.setTime(k_bad * TS)  # every sample up to k_bad is due at this event
    m.fmu.enterEventMode()
    st = m.raw("fmi2NewDiscreteStates", byref(fmi2EventInfo()))
    assert st == 3  # fmi2Error
    assert m.errors()[-1].endswith(f"sensor sample {k_bad} is NaN or Inf")
    m.free()
