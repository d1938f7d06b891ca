"""``heading_run`` refuses a duration or a logging step it cannot mean, each on its own,
before building anything."""

from __future__ import annotations

import pytest

from ballbot_casadi.analysis import heading as H
from ballbot_casadi.errors import ArgumentError


@pytest.mark.parametrize("duration, every", [(10.0, 0), (10.0, -1), (10.0, 2.0), (10.0, 1.5),
                                             (0.0, 1), (-1.0, 1), (float("nan"), 1)])
def test_bad_arguments_are_refused_one_at_a_time(monkeypatch, duration, every):
    monkeypatch.setattr(H, "load_sensor_params", lambda: pytest.fail("built before checking"))
    with pytest.raises(ArgumentError, match=r"^heading_run needs duration > 0 and an int log_every >= 1, got "):
        H.heading_run(duration, log_every=every)

