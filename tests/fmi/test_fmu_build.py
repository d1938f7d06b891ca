"""Build of BallbotPlant.fmu: validity, one-table consistency, exports, sources, CLI."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from _fmu_support import ALL_STATES, SENSORS, STATES, plant_build

from ballbot_casadi import PARAM_NAMES, load_params
from ballbot_casadi.cli import main as cli_main
from ballbot_casadi.core.params import PARAM_INFO
from ballbot_casadi.core.sensor_params import SENSOR_VECTOR_NAMES, load_sensor_params
from ballbot_casadi.fmi.build import fmu_source_dir, plant_variables
from ballbot_casadi.model.numeric import make_state


@pytest.fixture(scope="module")
def plant():
    return plant_build()


def test_fmpy_validation_reports_no_problems(plant):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(plant.fmu)) == []


def test_model_description_matches_the_table(plant):
    from fmpy import read_model_description

    md = read_model_description(str(plant.fmu))
    assert md.guid == plant.guid
    assert md.modelExchange is not None and md.coSimulation is not None
    for t in (md.modelExchange, md.coSimulation):
        assert t.providesDirectionalDerivative
        assert t.canGetAndSetFMUstate and t.canSerializeFMUstate
    by_name = {v.name: v for v in md.modelVariables}
    rows = plant_variables()
    assert len(md.modelVariables) == len(rows)
    conv = {"Real": float, "Integer": int, "Boolean": lambda s: {"true": True, "false": False}[s]}
    for row in rows:
        v = by_name[row.name]
        assert v.valueReference == row.vr and v.type == row.type
        assert (v.causality, v.variability) == (row.causality, row.variability)
        if row.start is not None:
            assert conv[row.type](v.start) == row.start
        else:
            assert v.start is None and v.initial == "calculated"
    params = load_params()
    for name in PARAM_NAMES:  # every parameter under its load_params name
        v = by_name[name]
        unit, desc, _ = PARAM_INFO[name]
        assert (v.causality, v.variability) == ("parameter", "fixed")
        assert v.unit == unit and v.description == desc
        assert float(v.start) == getattr(params, name)
    assert by_name["h_internal"].causality == "parameter"
    sensors = load_sensor_params().to_vector()
    for j, name in enumerate(SENSOR_VECTOR_NAMES):  # sensor parameters under their names
        v = by_name[name]
        assert (v.causality, v.variability, v.type) == ("parameter", "fixed", "Real")
        assert float(v.start) == sensors[j]
    assert (by_name["Ts_sensor"].causality, float(by_name["Ts_sensor"].start)) == (
        "parameter", 0.005)
    assert (by_name["noise_on"].type, by_name["noise_on"].start) == ("Boolean", "false")
    seed = by_name["seed"]
    assert (seed.type, seed.start, seed.min, seed.max) == ("Integer", "0", "0", str(2**31 - 1))
    # states are outputs calculated from the start parameters x0_<state> (what an SSP
    # parameter set binds), derivatives point at them
    assert [s.variable.name for s in md.derivatives] == [f"der({n})" for n in ALL_STATES]
    assert [d.variable.derivative.name for d in md.derivatives] == list(ALL_STATES)
    assert all(by_name[n].initial == "calculated" and by_name[n].start is None
               for n in ALL_STATES)
    x0 = [by_name[f"x0_{n}"] for n in ALL_STATES]
    assert all((v.causality, v.variability, v.initial) == ("parameter", "fixed", "exact")
               for v in x0)
    assert [float(v.start) for v in x0[:12]] == make_state().tolist()
    initial_unknowns = {u.variable.name for u in md.initialUnknowns}
    assert set(ALL_STATES) <= initial_unknowns
    outs = {u.variable.name for u in md.outputs}
    assert set(ALL_STATES) <= outs
    assert {"roll", "pitch", "yaw", "dphi0", "acc_z", "gyro_x", "enc2", *SENSORS} <= outs
    # the robot's readings are discrete (sampled and held); their state is local
    assert all(by_name[n].variability == "discrete" for n in SENSORS)
    assert all(by_name[n].variability == "continuous" for n in ("acc_z", "enc0", "roll"))
    locals_ = {v.name for v in md.modelVariables if v.causality == "local"
               and v.variability == "discrete"}
    assert locals_ == {"sensor_gyro_bias_x", "sensor_gyro_bias_y", "sensor_gyro_bias_z",
                       "sensor_tau_prev0", "sensor_tau_prev1", "sensor_tau_prev2",
                       "sensor_phi_prev0", "sensor_phi_prev1", "sensor_phi_prev2",
                       "sensor_sample"}
    assert by_name["sensor_sample"].type == "Integer"
    unknowns = {u.variable.name for u in md.initialUnknowns}
    assert set(SENSORS) <= unknowns and not unknowns & locals_
    assert [v.name for v in md.modelVariables if v.causality == "input"] == [
        "tau0", "tau1", "tau2", "tau_dist0", "tau_dist1", "tau_dist2"]


def test_generated_header_uses_the_same_value_references(plant):
    text = (plant.unzipped / "sources" / "plant_vr.h").read_text()
    defs = dict(re.findall(r"#define PLANT_VR_(\w+) (\d+)", text))
    index = dict(re.findall(r"#define PLANT_IX_(\w+) (\d+)", text))
    rows = plant_variables()
    first = {t: min(v.vr for v in rows if v.type == t) for t in ("Real", "Integer", "Boolean")}
    for row in rows:
        key = row.name.replace("(", "_").replace(")", "")
        assert int(defs[key]) == row.vr
        assert int(index[key]) == row.vr - first[row.type]
    assert len(defs) == len(index) == len(rows)
    assert f'#define PLANT_GUID "{plant.guid}"' in text
    # the descriptor table of the shared layer lists every variable in VR order
    table = (plant.unzipped / "sources" / "plant_vars.h").read_text()
    names = re.findall(r'^    \{"([^"]+)", FMU_KIND_', table, re.M)
    assert names == [v.name for v in rows]


def test_binary_exports_only_fmi2_and_needs_only_libc_libm(plant):
    nm = subprocess.run(["nm", "-D", "--defined-only", str(plant.binary)], capture_output=True,
                        text=True, check=True).stdout
    syms = [line.split()[-1] for line in nm.splitlines() if line.strip()]
    assert syms and all(s.startswith("fmi2") for s in syms), [s for s in syms
                                                               if not s.startswith("fmi2")]
    assert len(syms) == 44  # the complete FMI 2.0 ME + CS API
    dyn = subprocess.run(["readelf", "-d", str(plant.binary)], capture_output=True, text=True,
                         check=True).stdout
    needed = set(re.findall(r"NEEDED.*\[(.+)\]", dyn))
    assert needed <= {"libc.so.6", "libm.so.6"}, needed


def test_fmu_carries_sources_and_fmpy_compile_rebuilds_it(plant, tmp_path):
    import sys

    from fmpy import simulate_fmu

    with zipfile.ZipFile(plant.fmu) as zf:
        names = set(zf.namelist())
    for f in ("fmi2_common.c", "fmi2_common.h", "fmu_casadi.c", "fmu_casadi.h", "plant_model.c", "plant_vars.h", "plant_vr.h",
              "fmu_model_info.h", "ballbot_plant_cg.c", "ballbot_plant_cg.h", "ballbot_rng.c",
              "ballbot_rng.h"):
        assert f"sources/{f}" in names
    assert "binaries/linux64/BallbotPlant.so" in names
    if shutil.which("cmake") is None and not (Path(sys.executable).parent / "cmake").exists():
        pytest.skip("cmake is not available for fmpy compile")
    copy = tmp_path / "BallbotPlant.fmu"
    shutil.copyfile(plant.fmu, copy)
    env = {**os.environ,
           "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    res = subprocess.run([sys.executable, "-m", "fmpy", "compile", str(copy)],
                         capture_output=True, text=True, env=env)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    with zipfile.ZipFile(copy) as zf:
        rebuilt = zf.read("binaries/linux64/BallbotPlant.so")
    assert rebuilt != plant.binary.read_bytes()  # really a new binary from the sources
    sv = {"tau0": 0.02, "tau1": -0.01, "x0_q1": 0.01, "x0_q0": float(np.sqrt(1 - 1e-4))}
    r0 = simulate_fmu(str(plant.fmu), fmi_type="CoSimulation", stop_time=0.5,
                      output_interval=0.005, start_values=sv, output=list(STATES))
    r1 = simulate_fmu(str(copy), fmi_type="CoSimulation", stop_time=0.5,
                      output_interval=0.005, start_values=sv, output=list(STATES))
    for n in STATES:
        np.testing.assert_allclose(r1[n], r0[n], rtol=0, atol=1e-12)


def test_sources_are_installed_package_data():
    import importlib.resources as res

    from ballbot_casadi.fmi.package import COMMON_SOURCES, TOOLS_DIR

    d = fmu_source_dir()
    # one folder per part: the shared layer, each FMU's per-model C, the C tools
    for rel in (*COMMON_SOURCES, "plant/plant_model.c", "controller/controller_model.c",
                "reference/reference_model.c", f"{TOOLS_DIR}/host.c",
                f"{TOOLS_DIR}/controller_host.c", f"{TOOLS_DIR}/fuzz.c",
                f"{TOOLS_DIR}/fmi2_host.h"):
        assert (d / rel).is_file(), rel
    assert not list(d.glob("*.c")) and not list(d.glob("*.h"))  # nothing left at the top
    pkg = res.files("ballbot_casadi.fmu_src")
    assert pkg.joinpath("layer").joinpath("fmi2_common.h").is_file()


def test_generation_is_deterministic(plant):
    from ballbot_casadi.fmi.package import generated_files
    from ballbot_casadi.fmi.plant.plant import plant_spec

    a = generated_files(plant_spec(), plant.guid)
    b = generated_files(plant_spec(), plant.guid)
    assert a == b
    again = plant_build.__wrapped__()  # same content hash -> same cached archive
    assert again.digest == plant.digest
    assert again.fmu.read_bytes() == plant.fmu.read_bytes()


def test_the_archive_is_written_deterministically(plant, tmp_path):
    """Members sorted by name, each dated 1980-01-01 00:00:00, deflated, mode 0755 for the
    binary and 0644 for the rest; the same tree zipped twice (its files touched in between)
    gives the same bytes."""
    import os
    import zipfile

    from ballbot_casadi.fmi.package import _write_zip  # the FMU's files through zip_bytes

    def check(archive):
        with zipfile.ZipFile(archive) as zf:
            infos = zf.infolist()
        names = [i.filename for i in infos]
        assert names == sorted(names) and any(n.endswith(".so") for n in names)
        for i in infos:
            assert i.date_time == (1980, 1, 1, 0, 0, 0), i
            assert i.compress_type == zipfile.ZIP_DEFLATED, i
            assert i.external_attr >> 16 == (0o755 if i.filename.endswith(".so") else 0o644), i
    check(plant.fmu)
    tree = tmp_path / "tree"
    (tree / "b").mkdir(parents=True)
    for rel, data in (("z.txt", b"z"), ("a.xml", b"<a/>"), ("b/m.so", b"\x7fELF")):
        (tree / rel).write_bytes(data)
    _write_zip(tree, tmp_path / "one.zip")
    for rel in ("z.txt", "a.xml", "b/m.so"):
        os.utime(tree / rel, (1.7e9, 1.7e9))
    _write_zip(tree, tmp_path / "two.zip")
    assert (tmp_path / "one.zip").read_bytes() == (tmp_path / "two.zip").read_bytes()
    check(tmp_path / "one.zip")
    with zipfile.ZipFile(tmp_path / "one.zip") as zf:
        assert zf.namelist() == ["a.xml", "b/m.so", "z.txt"]
        assert zf.read("b/m.so") == b"\x7fELF"


def test_cli_build_info_validate(plant, capsys):
    out = plant.fmu.parent
    assert cli_main(["fmu", "build", "--out", str(out)]) == 0
    assert cli_main(["fmu", "validate", str(plant.fmu)]) == 0
    assert "valid" in capsys.readouterr().out
    assert cli_main(["fmu", "info", str(plant.fmu)]) == 0
    assert "BallbotPlant" in capsys.readouterr().out
    capsys.readouterr()
    assert cli_main(["fmu", "validate", str(out / "missing.fmu")]) == 2  # a bad path: user error
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "missing.fmu does not exist" in err


def test_source_dir_prefers_complete_package_data_then_the_checkout(monkeypatch, tmp_path):
    """The installed package data when it holds every common source (checked file by file),
    else ``fmu/`` of the checkout; neither complete: one clear error."""
    from ballbot_casadi.errors import BuildError
    from ballbot_casadi.fmi import package as pk

    installed = tmp_path / "installed"
    for rel in pk.COMMON_SOURCES:
        (installed / rel).parent.mkdir(parents=True, exist_ok=True)
        (installed / rel).write_text("")
    checkout = Path(pk.__file__).resolve().parents[2] / "fmu"
    monkeypatch.setattr(pk.resources, "files", lambda name: installed)
    assert pk.fmu_source_dir() == installed
    (installed / pk.COMMON_SOURCES[-1]).unlink()          # incomplete: the checkout's
    assert pk.fmu_source_dir() == checkout
    monkeypatch.setattr(pk, "__file__", str(tmp_path / "a" / "b" / "c" / "package.py"))
    with pytest.raises(BuildError, match=r"^the FMU C sources \(.*\) were not found; reinstall"):
        pk.fmu_source_dir()
