"""Shared fixtures: reference data, default parameters, model Functions (built once)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

REFERENCE = Path(__file__).resolve().parent.parent.parent / "shared" / "reference"


@pytest.fixture(scope="session")
def kugle_reference() -> dict:
    """The predecessor robot's independently derived model (shared/reference)."""
    path = Path(os.environ.get("BALLBOT_REFERENCE_DIR", REFERENCE)) / "kugle-model-reference.json"
    if not path.is_file():
        if os.environ.get("CI"):
            pytest.fail(f"reference data not found at {path} (CI must have shared/ beside the clone)")
        pytest.skip(f"reference data not found at {path}")
    return json.loads(path.read_text())


@pytest.fixture(scope="session")
def model_functions():
    from ballbot_casadi.model.dynamics import make_model_functions

    return make_model_functions()


@pytest.fixture(scope="session")
def default_params():
    from ballbot_casadi import load_params

    return load_params()


@pytest.fixture()
def rng() -> np.random.Generator:
    return np.random.default_rng(20201122)
