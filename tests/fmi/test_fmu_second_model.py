"""A second FMU on the shared layer: Co-Simulation only, Real, Integer and Boolean variables.

The toy "Counter" is what another FMU of the package costs: a variable table, one CasADi
Function and a per-model C file of some 60 lines (below), built by the same
``build_fmu_from_spec`` as the plant.  Every period (parameter ``period``) it adds the
Integer input ``increment`` to ``count`` and ``gain(u) = 2 u`` to ``total`` when the
Boolean ``enabled`` is true; a communication step must be a whole number of periods.
"""

from __future__ import annotations

from ctypes import c_double, c_int, c_uint, c_void_p

import casadi as ca
import numpy as np
import pytest
from _fmu_support import fmi2_callbacks, fuzz_counts
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave

from ballbot_casadi.errors import BuildError
from ballbot_casadi.fmi.package import build_fmu_from_spec
from ballbot_casadi.fmi.spec import FmuSpec, VarTable

pytestmark = pytest.mark.needs_cc

COUNTER_C = r"""
/* counter_model.c - per-model part of the toy Counter FMU (Co-Simulation only). */
#include <math.h>
#include <stdio.h>

#include "counter_cg.h"
#include "counter_vars.h"
#include "fmi2_common.h"

typedef struct {
    const casadi_real *arg[COUNTER_SZ_ARG];
    casadi_real *res[COUNTER_SZ_RES];
    casadi_int iw[COUNTER_SZ_IW + 1];
    casadi_real w[COUNTER_SZ_W + 1];
} counter_work;

static fmi2Status initialize(fmu_instance *inst, fmu_values *v, double t, char *msg,
                             size_t len) {
    (void)inst; (void)t; (void)msg; (void)len;
    v->i[COUNTER_IX_count] = 0;
    v->r[COUNTER_IX_total] = 0.0;
    v->b[COUNTER_IX_odd] = fmi2False;
    return fmi2OK;
}

static fmi2Status do_step(fmu_instance *inst, fmu_values *v, double t, double h, char *msg,
                          size_t len) {
    counter_work *wk = (counter_work *)fmu_model_work(inst);
    double period = v->r[COUNTER_IX_period], n = floor(h / period + 0.5), g;
    long k;
    (void)t;
    if (fabs(n * period - h) > 1e-9 * period || n < 1.0 || n > 1e6) {
        snprintf(msg, len, "step %g is not a whole number of periods of %g", h, period);
        return fmi2Error;
    }
    for (k = 0; k < (long)n; ++k) {
        if (!v->b[COUNTER_IX_enabled]) continue;
        wk->arg[0] = &v->r[COUNTER_IX_u];
        wk->res[0] = &g;
        if (toy_gain(wk->arg, wk->res, wk->iw, wk->w, 0) != 0) return fmi2Discard;
        v->r[COUNTER_IX_total] += g;
        v->i[COUNTER_IX_count] += v->i[COUNTER_IX_increment];
    }
    v->i[COUNTER_IX_ticks] += (fmi2Integer)n;
    v->b[COUNTER_IX_odd] = (v->i[COUNTER_IX_count] & 1) ? fmi2True : fmi2False;
    return isfinite(v->r[COUNTER_IX_total]) ? fmi2OK : fmi2Discard;
}

const fmu_model_def fmu_model = {
    COUNTER_MODEL_IDENTIFIER, COUNTER_GUID, FMU_CS, &counter_variables, sizeof(counter_work),
    NULL, initialize, NULL, do_step, NULL, NULL, NULL,
};
"""


def counter_spec(c_file) -> FmuSpec:
    t = VarTable()
    t.add("u", "discrete_input", "value added (doubled) every period", start=0.0)
    t.add("period", "parameter", "period", start=0.01, unit="s", rule="pos")
    t.add("total", "discrete_output", "sum of gain(u)")
    t.add("increment", "discrete_input", "added to count every period", type="Integer",
          start=1, bounds=(-100, 100))
    t.add("count", "discrete_output", "counter", type="Integer")
    t.add("ticks", "local", "periods done", type="Integer", bounds=(0, 2**31 - 1))
    t.add("enabled", "parameter", "count only when true", type="Boolean", start=True)
    t.add("odd", "discrete_output", "count is odd", type="Boolean")
    u = ca.SX.sym("u")
    return FmuSpec(model_identifier="Counter", description="toy counter", prefix="counter",
                   variables=t.rows(), functions=(ca.Function("toy_gain", [u], [2 * u]),),
                   model_source=c_file, cg_name="counter_cg", interfaces=("cs",),
                   default_experiment=(0.0, 1.0, 0.01))


@pytest.fixture(scope="module")
def counter(tmp_path_factory):
    d = tmp_path_factory.mktemp("counter")
    c_file = d / "counter_model.c"
    c_file.write_text(COUNTER_C)
    return build_fmu_from_spec(counter_spec(c_file), d / "out")


def _raw(slave, fname: str, *args) -> int:
    """An FMI call with the status returned (no fmpy exception)."""
    f = getattr(slave.dll, fname)
    f.restype = c_int
    return f(c_void_p(slave.component), *args)


def _log_list():
    logs = []

    def logger(env, name, status, category, message):
        logs.append((int(status), message.decode()))
    return logs, logger


def _slave(counter, logs_logger):
    cb = fmi2_callbacks(logs_logger)
    s = FMU2Slave(guid=counter.guid, unzipDirectory=str(counter.unzipped),
                  modelIdentifier="Counter", instanceName="counter")
    s.instantiate(callbacks=cb)
    s._keep = cb
    return s


def test_the_per_model_file_is_small_and_the_fmu_is_valid(counter):
    from fmpy.validation import validate_fmu

    assert len(COUNTER_C.strip().splitlines()) < 70
    assert validate_fmu(str(counter.fmu)) == []
    md = read_model_description(str(counter.fmu))
    assert md.modelExchange is None and md.coSimulation is not None
    assert not md.coSimulation.providesDirectionalDerivative
    types = {v.name: (v.type, v.causality, v.variability) for v in md.modelVariables}
    assert types["increment"] == ("Integer", "input", "discrete")
    assert types["enabled"] == ("Boolean", "parameter", "fixed")
    assert types["odd"] == ("Boolean", "output", "discrete")
    assert types["ticks"] == ("Integer", "local", "discrete")
    assert [v.valueReference for v in md.modelVariables] == list(range(8))


def test_fmpy_runs_it_with_integer_and_boolean_values(counter):
    inp = np.array([(0.0, 1.5, 3), (1.0, 1.5, 3)],
                   dtype=[("time", float), ("u", float), ("increment", np.int32)])
    r = simulate_fmu(str(counter.fmu), stop_time=0.1, output_interval=0.02, input=inp,
                     output=["count", "total", "odd"])
    # 0.02 per step = 2 periods: count += 2 * 3, total += 2 * 2 * 1.5
    assert r["count"].tolist() == [0, 6, 12, 18, 24, 30]
    np.testing.assert_allclose(r["total"], [0, 6, 12, 18, 24, 30], rtol=0, atol=1e-12)
    assert r["odd"].tolist() == [False] * 6
    off = simulate_fmu(str(counter.fmu), stop_time=0.05, output_interval=0.01,
                       start_values={"enabled": False}, output=["count"])
    assert off["count"].tolist() == [0] * 6


def test_no_model_exchange_refused_steps_state_and_checks(counter):
    logs, logger = _log_list()
    from fmpy.fmi2 import FMU2Model

    me = FMU2Model(guid=counter.guid, unzipDirectory=str(counter.unzipped),
                   modelIdentifier="Counter", instanceName="me")
    cb = fmi2_callbacks(logger)
    with pytest.raises(Exception, match="Failed to instantiate"):
        me.instantiate(callbacks=cb)
    assert any("Counter does not implement Model Exchange" in m for _, m in logs)

    s = _slave(counter, logger)
    vr = {v.name: v.valueReference for v in read_model_description(str(counter.fmu)).modelVariables}
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    assert _raw(s, "fmi2SetInteger", (c_uint * 1)(vr["increment"]), 1,
                                (c_int * 1)(101)) == 3
    assert "an integer in [-100, 100]" in logs[-1][1]
    assert _raw(s, "fmi2SetBoolean", (c_uint * 1)(vr["enabled"]), 1,
                                (c_int * 1)(5)) == 3
    assert _raw(s, "fmi2SetInteger", (c_uint * 1)(vr["count"]), 1, (c_int * 1)(1)) == 3
    assert "outputs are calculated" in logs[-1][1]
    s.setInteger([vr["increment"]], [7])
    s.exitInitializationMode()
    s.setReal([vr["u"]], [0.25])
    s.doStep(0.0, 0.03)
    assert s.getInteger([vr["count"], vr["ticks"]]) == [21, 3]
    assert s.getBoolean([vr["odd"]]) == [True]
    n = len(logs)
    st = _raw(s, "fmi2DoStep", c_double(0.03), c_double(0.015), 1)
    assert st == 3 and len(logs) == n + 1 and "not a whole number of periods" in logs[-1][1]
    assert s.getInteger([vr["count"], vr["ticks"]]) == [21, 3]  # refused: nothing changed
    # the FMU state carries Integer and Boolean values, serialised and restored
    state = s.getFMUstate()
    blob = s.serializeFMUstate(state)
    s.freeFMUstate(state)
    s.setInteger([vr["increment"]], [-2])
    s.doStep(0.03, 0.01)
    after = (s.getInteger([vr["count"], vr["ticks"]]), s.getBoolean([vr["odd"]]),
             s.getReal([vr["total"]]))
    assert after[0] == [19, 4]
    s2 = _slave(counter, logger)
    st2 = s2.deSerializeFMUstate(blob)
    s2.setFMUstate(st2)
    s2.freeFMUstate(st2)
    assert s2.getInteger([vr["increment"], vr["count"]]) == [7, 21]
    s2.setInteger([vr["increment"]], [-2])
    s2.doStep(0.03, 0.01)
    assert (s2.getInteger([vr["count"], vr["ticks"]]), s2.getBoolean([vr["odd"]]),
            s2.getReal([vr["total"]])) == after
    # ME-only calls on a CS instance are refused with a message
    n = len(logs)
    assert _raw(s2, "fmi2GetDerivatives", (c_double * 1)(), 0) == 3
    assert "only available for Model Exchange" in logs[-1][1] and len(logs) == n + 1
    for x in (s, s2):
        x.terminate()
        x.freeInstance()


def test_generic_fuzz_runs_against_the_second_fmu(counter):
    s = fuzz_counts(counter, 60000, 5)
    assert s["silent"] == 0, s
    assert s["steps_ok"] > 50 and s["integer_ok"] > 100 and s["boolean_ok"] > 100, s
    assert s["integer_error"] > 100 and s["boolean_error"] > 100, s


def test_spec_and_table_errors_are_clear(tmp_path):
    t = VarTable()
    t.add("n", "output", "an Integer cannot be a continuous output", type="Integer")
    with pytest.raises(BuildError, match="cannot be of kind 'output'"):
        t.rows()
    t = VarTable()
    t.add("k", "parameter", "missing start", type="Integer")
    with pytest.raises(BuildError, match="needs a start value"):
        t.rows()
    t = VarTable()
    t.add("b", "parameter", "not a bool", type="Boolean", start=1)
    with pytest.raises(BuildError, match="must be a bool"):
        t.rows()
    t = VarTable()
    t.add("x", "state", "no derivative", start=0.0)
    with pytest.raises(BuildError, match="exactly one derivative"):
        t.rows()
    t = VarTable()
    t.add("i", "parameter", "out of bounds", type="Integer", start=5, bounds=(0, 3))
    with pytest.raises(BuildError, match="is not an integer in \\[0, 3\\]"):
        t.rows()
    spec = counter_spec(tmp_path / "missing.c")
    with pytest.raises(BuildError, match="does not exist"):
        build_fmu_from_spec(spec, tmp_path / "out")
