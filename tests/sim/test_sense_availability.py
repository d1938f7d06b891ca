"""The plant-side sensors' availability input: each entry of ``valid`` blanks exactly its
own sensor's readings (NaN), for every sensor alone, and the heading sensor's reading
exists only for an estimator that reads it."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.params import load_params
from ballbot_casadi.core.sensor_params import load_sensor_params
from ballbot_casadi.sim.embedded import MEAS_HEADING, NOISE, SENSOR_STATE, VALID, sense, software_blocks


def _sense_function(estimator):
    _, est = software_blocks("flc", estimator)
    xk, s_state = ca.MX.sym("xk", 15), ca.MX.sym("s_state", SENSOR_STATE.size)
    noise, valid = ca.MX.sym("noise", NOISE.size), ca.MX.sym("valid", VALID.size)
    p, s, Ts = ca.MX.sym("p", len(load_params().to_vector())), ca.MX.sym("s", est.imu.size1_in(3)), ca.MX.sym("Ts")
    meas, s_next = sense(est, xk, s_state, noise, valid, p, s, Ts)
    return ca.Function("sense", [xk, s_state, noise, valid, p, s, Ts], [meas, s_next]), est


@pytest.mark.parametrize("off", ["acc", "gyro", "enc", "heading", None])
def test_each_availability_entry_blanks_its_own_sensor(off):
    f, est = _sense_function("ukf_heading")
    x = np.zeros(15)
    x[2:6] = Q.from_rpy(0.02, -0.01, 0.4)
    x[8:12] = Q.mul(x[2:6], np.array([0.0, 0.1, 0.0, 0.05])) / 2
    x[12:15] = [0.3, -0.2, 0.1]  # wheel angles
    valid = np.ones(VALID.size)
    if off is not None:
        valid[VALID.index(off)] = 0.0
    meas = np.asarray(f(x, np.zeros(SENSOR_STATE.size), np.zeros(NOISE.size), valid,
                        load_params().to_vector(), load_sensor_params().to_vector(), 0.005)[0]).ravel()
    assert meas.size == MEAS_HEADING.size
    for name in MEAS_HEADING.fields:
        part = meas[MEAS_HEADING[name]]
        if name == off:
            assert np.all(np.isnan(part)), name
        else:
            assert np.all(np.isfinite(part)), name


def test_the_ukf_reads_no_heading():
    f, est = _sense_function("ukf")
    assert f.size1_out(0) == MEAS_HEADING.size - 1
