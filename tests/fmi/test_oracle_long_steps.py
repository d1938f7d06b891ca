"""The plant FMU's Python sensor oracle with communication steps longer than a second:
several sample instants inside one step (its noise table sized by the run's end time), the
same readings as the same run in steps of one sample period."""

from __future__ import annotations

import numpy as np

from ballbot_casadi.fmi.plant.oracle import plant_sensor_oracle
from ballbot_casadi.model.numeric import make_state


def test_long_steps_sample_every_instant_inside_them_as_short_steps_do():
    x0 = np.asarray(make_state(roll=0.02, pitch=-0.01), float).ravel()
    tau = np.array([[0.1, -0.05, 0.02], [0.0, 0.08, -0.03]])
    kw = dict(Ts_sensor=0.5, h_internal=0.05, noise_on=True, seed=3)
    long = plant_sensor_oracle(x0, tau, step=1.5, **kw)
    short = plant_sensor_oracle(x0, np.repeat(tau, 3, axis=0), step=0.5, **kw)
    assert list(long["sample"]) == [0, 3, 6]
    np.testing.assert_allclose(long["time"], [0.0, 1.5, 3.0], rtol=0, atol=1e-12)
    for key in ("acc", "gyro", "enc", "bias", "xw"):
        np.testing.assert_allclose(np.asarray(long[key]), np.asarray(short[key])[::3], rtol=1e-12, atol=1e-12,
                                   err_msg=key)
    assert np.ptp(np.asarray(long["gyro"])[:, 0]) > 0  # readings move (noise on)
