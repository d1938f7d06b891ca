"""Firmware sources and the missing-toolchain path (no cross toolchain needed)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from ballbot_casadi.cli import main
from ballbot_casadi.firmware import toolchain
from ballbot_casadi.firmware.build import build_firmware, default_scenario
from ballbot_casadi.firmware.sources import (
    firmware_function,
    generate_sources,
    param_inputs,
    scenario_values,
)
from ballbot_casadi.firmware.toolchain import INSTALL_HINT, ToolchainMissing


@pytest.fixture(scope="module")
def embedded():
    return firmware_function()  # the default firmware (default_scenario's estimator)


def test_float_sources_have_no_double_math_or_out_of_range_constants(embedded):
    vals = scenario_values(embedded, default_scenario())
    src = generate_sources(embedded, "single", vals)["ballbot_fw_cg.c"]
    assert "#define casadi_real float" in src
    assert not re.search(r"(?<![\w.])(sqrt|sin|cos|atan2|exp|fabs|fmin|fmax)\(", src)
    assert "sqrtf(" in src and "atan2f(" in src
    assert "e+308" not in src and "e-300" not in src  # clamped to FLT_MAX / FLT_MIN
    config = generate_sources(embedded, "single", vals)["ballbot_fw_config.h"]
    assert "typedef float ballbot_fw_real;" in config
    assert f"#define BALLBOT_FW_NC {embedded.numel_in(0)}" in config


def test_parameters_follow_the_function_and_the_scenario(embedded):
    vals = scenario_values(embedded, default_scenario())
    names = param_inputs(embedded)
    assert names[:2] == ["p_ctrl", "p_est"] and "cascade" not in names and "meas" not in names
    flat = vals.flat_params(embedded)
    assert flat.size == sum(embedded.numel_in(embedded.index_in(n)) for n in names)
    inp = default_scenario().inputs()
    np.testing.assert_allclose(vals.params["Qa"], np.asarray(inp["estimation"]["Qa"]).ravel("F"),
                               rtol=0, atol=0)
    # power-on state: unit attitude estimate (the filters aligned upright)
    assert vals.c0.size == embedded.numel_in(0)


def test_missing_toolchain_says_how_to_install(monkeypatch, capsys):
    monkeypatch.setattr(toolchain.shutil, "which", lambda name: None)
    with pytest.raises(ToolchainMissing, match="apt-get install -y gcc-arm-none-eabi"):
        build_firmware()
    assert main(["firmware"]) == 3
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and INSTALL_HINT in err


def test_unknown_precision_is_a_user_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["firmware", "--precision", "half"])
    assert exc.value.code == 2
    assert "invalid choice" in capsys.readouterr().err


def test_heading_variant_configures_its_readings_from_the_function():
    """``ukf_heading``: the readings end with the heading (NaN = no reading), the attitude
    covariances are 7 x 7; the configuration follows the Function, not a fixed layout."""
    f = firmware_function("flc", "ukf_heading")
    vals = scenario_values(f, default_scenario("flc", "ukf_heading"))
    config = generate_sources(f, "double", vals)["ballbot_fw_config.h"]
    assert "#define BALLBOT_FW_N_READINGS 10" in config
    assert "#define BALLBOT_FW_READING_HEADING 9" in config
    assert "#define BALLBOT_FW_READING_ENC 6" in config
    assert "X(Qa, 7)" in config and "X(Ra, 7)" in config
    assert vals.c0.size == f.numel_in(0)
    base = generate_sources(firmware_function("flc", "ukf"),
                            "double", scenario_values(firmware_function("flc", "ukf"),
                                                      default_scenario("flc", "ukf")))["ballbot_fw_config.h"]
    assert "#define BALLBOT_FW_N_READINGS 9" in base and "READING_HEADING" not in base
