"""The followed path as a log keeps it: points every ``spacing`` metres, both ends, and the
obstacles as ``[x, y, r]`` rows."""

from __future__ import annotations

import numpy as np

from ballbot_casadi.guidance.paths import line_path
from ballbot_casadi.sim.guided import GUIDANCE_EVERY, PATH_LOG_SPACING, path_metadata


def test_line_points_every_spacing_with_both_ends_and_obstacle_rows():
    path = line_path((1.0, 0.0), (1.0, 0.5), obstacles=[(3.0, 3.0, 0.25), (-2.0, 1.0, 0.5)])
    meta = path_metadata(path, spacing=0.1)
    xy = np.asarray(meta["xy"])
    assert xy.shape == (6, 2)
    np.testing.assert_allclose(xy, np.column_stack([np.ones(6), np.linspace(0.0, 0.5, 6)]), atol=1e-9)
    assert meta["obstacles"] == [[3.0, 3.0, 0.25], [-2.0, 1.0, 0.5]]
    # spacing not dividing the length: one more point, ends kept
    xy = np.asarray(path_metadata(path, spacing=0.15)["xy"])
    assert xy.shape == (5, 2)
    np.testing.assert_allclose(xy[[0, -1]], [[1.0, 0.0], [1.0, 0.5]], atol=1e-9)
    # default spacing 2 cm: 26 points on 0.5 m; a tiny path still has its two ends
    assert PATH_LOG_SPACING == 0.02 and len(path_metadata(path)["xy"]) == 26
    assert len(path_metadata(line_path((0, 0), (0.001, 0)))["xy"]) == 2
    assert GUIDANCE_EVERY == 20  # 10 Hz at the 200 Hz control period
