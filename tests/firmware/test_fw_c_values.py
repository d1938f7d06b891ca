"""The firmware's hand-written C (csrc/ballbot_fw.c, csrc/replay_main.c) compiled for this PC
with the firmware's strict flags around a hand-written stand-in for the generated period
(tests/firmware/fw_stub: a period and a guidance sample whose results are computed by hand
here), so the default suite sees the C API, the split guidance's schedule (snapshot, due
period, latency, late and failed samples) and the replay program's file format without
the Cortex-M toolchain, QEMU or the MPC (the slow tests replay the real builds).

Stand-in (fw_stub/stub_cg.c): state c (8) = (count, guidance counter, first, x, due, snap0,
snap1, 7); a period returns tau = (c[0], meas[0], 10 cascade + Ts) and c[0] + 1; the guided
one gives v_ref_used = (c[3], c[1], k_guid[1]); split, a period with counter 0 (every 4)
stores due = 3 (first) or 2 and snap = (c[0], c[7]); the first sample gives x = 1000 + 100
X0 + X1 + k0, a later one x + 100 X0 + X1 + k1.
"""

from __future__ import annotations

import ctypes
import math
import subprocess
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from ballbot_casadi.errors import BuildError
from ballbot_casadi.firmware import replay as R
from ballbot_casadi.firmware.build import FW_CFLAGS
from ballbot_casadi.firmware.sources import FirmwareValues, csrc_path

pytestmark = pytest.mark.needs_cc

STUB = Path(__file__).parent / "fw_stub"
OK, PREDICT_ONLY, EPARAM, EFAULT, EARG = 0, 1, -1, -2, -3
IDLE, PENDING, RUNNING, DONE = 0, 1, 2, 3
ULONG_MAX = 2**64 - 1 if ctypes.sizeof(ctypes.c_ulong) == 8 else 2**32 - 1
P0 = [0.005, 1.0, 0.0, 0.0, 2.0, 3.0, 4.0]  # Ts, Qa (2 x 2), k: stub_defaults.c
C0 = [0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 7.0]
G0 = [5.0, 6.0, 7.0]
VARIANTS = {"plain": (0, 0), "guided": (1, 0), "split": (1, 1)}
D = ctypes.POINTER(ctypes.c_double)


def _compile(out: Path, variant: str, shared: bool) -> Path:
    g, s = VARIANTS[variant]
    main = [] if shared else [str(csrc_path("replay_main.c"))]
    extra = [str(STUB / "stub_access.c")] if shared else []
    cmd = ["gcc", *FW_CFLAGS, *(["-fPIC", "-shared"] if shared else []), f"-DSTUB_GUIDANCE={g}",
           f"-DSTUB_SPLIT={s}", "-I", str(STUB), "-I", str(csrc_path("ballbot_fw.c").parent),
           "-o", str(out), str(STUB / "stub_cg.c"), str(STUB / "stub_defaults.c"), *extra, *main,
           str(csrc_path("ballbot_fw.c")), "-lm"]
    res = subprocess.run(cmd, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    return out


class Lib:
    """One stand-in build of ballbot_fw.c loaded with ctypes (one static context)."""

    def __init__(self, path: Path) -> None:
        self.lib = ctypes.CDLL(str(path))
        for name in ("t_c", "t_echo", "t_vref", "t_guidance", "t_bg_X", "t_bg_g"):
            if hasattr(self.lib, name):
                getattr(self.lib, name).restype = D
        for name in ("t_period", "t_faults", "t_bg_field"):
            if hasattr(self.lib, name):
                getattr(self.lib, name).restype = ctypes.c_ulong

    @staticmethod
    def arr(v) -> ctypes.Array:
        v = [float(x) for x in v]
        return (ctypes.c_double * len(v))(*v)

    def init(self, p=P0, c0=C0) -> int:
        return self.lib.t_init(self.arr(p), None if c0 is None else self.arr(c0))

    def step(self, meas=(0.1, 0.2, 0.3, 0.4, 0.5), refs=None, balance_only=0):
        refs = np.zeros(15) if refs is None else refs
        tau = self.arr([9.0, 9.0, 9.0])
        rc = self.lib.t_step(self.arr(meas), self.arr(refs), balance_only, tau)
        return rc, list(tau)

    def vec(self, name: str, n: int) -> list[float]:
        p = getattr(self.lib, name)()
        return [p[i] for i in range(n)]

    def c(self) -> list[float]:
        return self.vec("t_c", 8)

    def echo(self) -> list[float]:
        return self.vec("t_echo", 16)

    def bg(self, which: int) -> int:
        return self.lib.t_bg_field(which)

    def params(self) -> list[float]:
        out = self.arr([0.0] * 7)
        self.lib.t_params(out)
        return list(out)


@pytest.fixture(scope="module")
def builds(tmp_path_factory):
    d = tmp_path_factory.mktemp("fw_c_values")
    return {(v, shared): _compile(d / f"{v}{'.so' if shared else ''}", v, shared)
            for v in VARIANTS for shared in (True, False)}


@pytest.fixture()
def plain(builds):
    return Lib(builds["plain", True])


@pytest.fixture()
def guided(builds):
    return Lib(builds["guided", True])


@pytest.fixture()
def split(builds):
    lib = Lib(builds["split", True])
    lib.lib.t_interrupt(0)
    return lib


# ------------------------------------------------------------------ the C API, no guidance


def test_defaults_are_copied_out(plain):
    assert plain.lib.t_npar() == 7
    out = plain.arr([0.0] * 7)
    plain.lib.t_default_params(out)
    assert list(out) == P0
    c0 = plain.arr([-1.0] * 8)
    plain.lib.t_default_state(c0)
    assert list(c0) == C0


@pytest.mark.parametrize("index, value, want", [
    (None, None, OK),
    (0, 0.0, EPARAM), (0, -0.005, EPARAM), (0, 1e-9, OK),  # Ts > 0
    (1, 0.0, OK), (1, -1e-12, EPARAM), (4, -1e-12, EPARAM),  # the diagonal Qa[0], Qa[3] >= 0
    (2, -1.0, OK), (3, -1.0, OK),  # off the diagonal: any finite value
    (2, math.inf, EPARAM), (3, math.nan, EPARAM), (5, math.nan, EPARAM), (6, -math.inf, EPARAM),
])
def test_check_params_at_each_bound(plain, index, value, want):
    p = list(P0)
    if index is not None:
        p[index] = value
    assert plain.lib.t_check_params(plain.arr(p)) == want


def test_init_set_params_and_null_pointers(plain):
    assert plain.init(c0=None) == OK
    assert plain.c() == C0  # NULL: the default power-on state
    c0 = [2.0, 1, 0, 0, 0, 0, 0, 3]
    assert plain.init(c0=c0) == OK and plain.c() == c0 and plain.lib.t_period() == 0
    assert plain.init(c0=[0.0, math.nan, 0, 0, 0, 0, 0, 0]) == EPARAM
    assert plain.init(p=[0.0, *P0[1:]]) == EPARAM
    assert plain.init() == OK
    new = [0.01, 2.0, 0.5, 0.5, 3.0, -1.0, 8.0]
    assert plain.lib.t_set_params(plain.arr(new)) == OK and plain.params() == new
    assert plain.lib.t_set_params(plain.arr([*new[:4], -3.0, *new[5:]])) == EPARAM
    assert plain.params() == new  # a rejected set changes nothing
    assert [plain.lib.t_null(i) for i in range(5)] == [EARG] * 5


def test_step_wires_readings_references_mode_and_parameters(plain):
    assert plain.init() == OK
    refs = np.arange(1.0, 16.0) / 10  # q_ref 0.1..0.4, dq_ref 0.5.., ddq_ref 0.9.., v_ref 1.3..1.5
    meas = [0.11, 0.12, 0.13, 0.14, 0.15]
    rc, tau = plain.step(meas, refs, balance_only=0)
    # period 0: the encoders (readings 2..4) are missing, the gyroscope is used
    assert rc == PREDICT_ONLY
    assert plain.echo()[:5] == [0.11, 0.12, -1, -1, -1]
    assert tau == pytest.approx([0.0, 0.11, 10 + 0.005 + 0.124], rel=0, abs=1e-15)  # 1e-3 sum i^2 / 10
    np.testing.assert_array_equal(plain.echo()[5:], [0.1, 0.4, 0.6, 1.1, 1.3, 1.4, 1.5, 1.0,
                                                     0.005, 2.0, 4.0])
    rc, tau = plain.step(meas, refs, balance_only=1)
    assert rc == OK and plain.echo()[:5] == meas
    assert tau == pytest.approx([1.0, 0.11, 0.005 + 0.124], rel=0, abs=1e-15)  # the count before; cascade 0
    assert plain.echo()[12] == 0.0
    assert plain.c() == [2.0, *C0[1:]] and plain.lib.t_period() == 2


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("index", [0, 1, 2, 4])
def test_a_non_finite_reading_is_missing_after_period_zero(plain, index, bad):
    assert plain.init() == OK
    plain.step()
    meas = [0.1, 0.2, 0.3, 0.4, 0.5]
    meas[index] = bad
    rc, _ = plain.step(meas)
    assert rc == PREDICT_ONLY
    assert plain.echo()[:5] == [-1 if i == index else m for i, m in enumerate(meas)]
    assert plain.step()[0] == OK


@pytest.mark.parametrize("magic", [666.0, 777.0, 888.0])  # returns 1, state NaN, torque NaN
def test_a_rejected_period_zeroes_the_torques_and_keeps_the_state(plain, magic):
    assert plain.init() == OK
    plain.step()
    rc, tau = plain.step([magic, 0.2, 0.3, 0.4, 0.5])
    assert (rc, tau) == (EFAULT, [0.0, 0.0, 0.0])
    assert plain.c() == [1.0, *C0[1:]] and plain.lib.t_faults() == 1
    assert plain.lib.t_period() == 2  # the period still counts
    rc, tau = plain.step()
    assert rc == OK and tau[0] == 1.0 and plain.c()[0] == 2.0 and plain.lib.t_faults() == 1


def test_null_arguments_of_the_step(plain):
    assert plain.init() == OK
    for which in range(3):
        tau = plain.arr([9.0, 9.0, 9.0])
        assert plain.lib.t_step_null(which, tau) == EARG
        assert list(tau) == [0.0, 0.0, 0.0]  # torques are always written first
    assert plain.lib.t_step_null(3, None) == EARG
    assert plain.lib.t_period() == 0


def test_guidance_data_is_kept_by_pointer_and_checked(guided):
    assert guided.init() == OK
    guided.step()
    assert guided.vec("t_vref", 3) == [0.0, 0.0, 6.0]  # the default data's k_guid[1]
    assert guided.lib.t_set_guidance(guided.arr([1.0, 2.5, 3.0])) == OK
    guided.step()
    assert guided.vec("t_vref", 3) == [0.0, 0.0, 2.5]
    assert guided.lib.t_set_guidance(guided.arr([1.0, math.nan, 3.0])) == EPARAM
    assert guided.lib.t_set_guidance(None) == EARG
    assert guided.vec("t_guidance", 3) == [1.0, 2.5, 3.0]  # unchanged by the refusals


# ------------------------------------------------------------------ split guidance


def _x(lib: Lib, n: int) -> list[float]:
    """Step ``n`` periods, the background right after each; x = v_ref_used[0] per period."""
    xs = []
    for _ in range(n):
        assert lib.step()[0] in (OK, PREDICT_ONLY)
        xs.append(lib.vec("t_vref", 3)[0])
        lib.lib.t_background()
    return xs


# the hand schedule: snapshots at 0, 4, 8 (count X0 = period, X1 = 7, data 5, 6, 7); the
# first due at 0 + 3, the next at 4 + 2, 8 + 2
X1 = 1000 + 0 + 7 + 5
X2 = X1 + 400 + 7 + 6
X3 = X2 + 800 + 7 + 6
SCHEDULE = [0, 0, 0, X1, X1, X1, X2, X2, X2, X2, X3, X3]


def test_split_schedule_by_hand(split):
    assert split.init() == OK
    assert (split.bg(0), split.bg(1), split.bg(2), split.bg(3)) == (IDLE, ULONG_MAX, 0, 0)
    assert split.lib.t_background() == 0  # nothing pending: GUIDANCE_IDLE
    split.step()
    # the snapshot of period 0: the loop state the period stored, the sample state, due 3
    assert (split.bg(0), split.bg(1)) == (PENDING, 3)
    assert split.vec("t_bg_X", 2) == [0.0, 7.0] and split.vec("t_bg_g", 2) == [1.0, 0.0]
    assert split.lib.t_background() == 1 and split.bg(0) == DONE
    assert split.lib.t_background() == 0  # ran once
    xs = [split.vec("t_vref", 3)[0]] + _x(split, 11)
    assert xs == SCHEDULE
    assert split.bg(1) == ULONG_MAX and split.bg(2) == 0 and split.bg(3) == 0
    assert split.c()[2:4] == [0.0, X3] and split.c()[1] == 0.0  # applied; counter 12 % 4
    assert split.lib.t_background_null() == EARG


@pytest.mark.parametrize("delay, late", [(0, 0), (1, 0), (2, 2)])
def test_a_result_after_its_due_period_is_counted_and_never_applied(split, delay, late):
    assert split.init() == OK
    xs, pending_at = [], None
    for k in range(12):
        split.step()
        xs.append(split.vec("t_vref", 3)[0])
        if split.bg(0) == PENDING and pending_at is None:
            pending_at = k
        if pending_at is not None and k >= pending_at + delay:
            split.lib.t_background()
            pending_at = None
    assert split.bg(2) == late
    # delay 2: the first sample (due 3 periods later) in time, every later one (due 2) late
    assert xs == (SCHEDULE if late == 0 else [0, 0, 0] + [X1] * 9)


def test_a_sample_still_running_skips_the_next_snapshot(split):
    assert split.init() == OK
    split.step()  # period 0: snapshot, due 3
    split.lib.t_interrupt(4)  # periods 1..4 interrupt the sample: 3 is due, 4 snapshots
    assert split.lib.t_background() == 1
    split.lib.t_interrupt(0)
    assert split.lib.t_period() == 5 and split.bg(2) == 2  # due missed, snapshot skipped
    assert split.bg(0) == DONE and split.bg(1) == ULONG_MAX  # finished, never applied
    xs = _x(split, 8)  # periods 5..12: the snapshot at 8 is cold again (first), due 11
    assert xs == [0.0] * 6 + [1000 + 800 + 7 + 5] * 2
    assert split.bg(2) == 2


def test_a_failed_sample_is_counted_and_not_applied(split):
    assert split.init() == OK
    assert split.lib.t_set_guidance(split.arr([-1.0, 6.0, 7.0])) == OK  # the stub's NaN sample
    split.step()
    assert split.lib.t_background() == EFAULT
    assert (split.bg(0), split.bg(3)) == (IDLE, 1)
    xs = [split.vec("t_vref", 3)[0]] + _x(split, 4)
    assert xs == [0.0] * 5 and split.bg(2) == 1  # its due period found nothing: late


def test_a_rejected_snapshot_period_takes_no_snapshot(split):
    assert split.init() == OK
    rc, _ = split.step([666.0, 0.2, 0.3, 0.4, 0.5])
    assert rc == EFAULT and split.bg(0) == IDLE and split.bg(1) == ULONG_MAX
    split.step()  # period 1 has the counter 0 the rejected period kept: due 1 + 3
    assert (split.bg(0), split.bg(1)) == (PENDING, 4)
    assert split.vec("t_bg_X", 2) == [0.0, 7.0]  # the count the rejected period kept


# ------------------------------------------------------------------ the replay program


def _input(path: Path, n: int, variant: str, balance_only: float = 0.0, bg_delay: int = 0,
           npar: int = 7, c0=C0, guid=G0, drop: int = 0, refs=None) -> Path:
    g = VARIANTS[variant][0]
    gd = list(guid) if g else []
    meas = np.tile([0.1, 0.2, 0.3, 0.4, 0.5], (n, 1))
    meas[:, 0] += np.arange(n)  # meas[0] = 0.1 + k: tau[1] names the period
    refs = np.zeros((n, 15)) if refs is None else refs
    hdr = [n, npar, 8, balance_only, R.CALIB_LOOPS, len(gd), bg_delay]
    data = np.concatenate([hdr, P0, c0, gd, np.hstack([meas, refs]).ravel()])
    path.write_bytes(data[:data.size - drop].astype("<f8").tobytes())
    return path


def _replay(builds, tmp_path, variant, **kw):
    n = kw.pop("n", 12)
    _input(tmp_path / "in.bin", n, variant, **kw)
    res = subprocess.run([str(builds[variant, False]), "in.bin", "out.bin"], cwd=tmp_path,
                         capture_output=True, text=True)
    return res, (R._read_output(tmp_path / "out.bin", n) if res.returncode == 0 else None)


@pytest.mark.parametrize("variant, extra", [("plain", 0), ("guided", 3), ("split", 4)])
def test_replay_rows_and_header(builds, tmp_path, variant, extra):
    res, out = _replay(builds, tmp_path, variant, balance_only=1.0)
    assert res.returncode == 0, res.stderr
    h = np.frombuffer((tmp_path / "out.bin").read_bytes(), "<f8")[:R.OUT_HEADER]
    assert h[0] == 12 and h[5] == 8 and h[6] == extra and h[4] > 0
    assert list(h[[1, 2, 3, 7, 8]]) == [0, 0, 0, 0, 0]  # host: no SysTick, stack, late result
    k = np.arange(12)
    np.testing.assert_allclose(out.tau, np.column_stack([k, 0.1 + k, np.full(12, 0.005)]),
                               rtol=0, atol=1e-15)
    assert list(out.rc) == [PREDICT_ONLY] + [OK] * 11  # period 0: no encoder readings
    np.testing.assert_array_equal(out.ticks, 0.0)  # no SysTick on the host
    np.testing.assert_array_equal(out.bg_ticks, 0.0)  # nor for the background samples
    if variant == "split":
        assert list(out.v_ref[:, 0]) == SCHEDULE
    if variant == "guided":
        np.testing.assert_array_equal(out.v_ref, np.tile([0.0, 0.0, 6.0], (12, 1)))
    assert out.v_ref.shape == (12, min(extra, 3))


@pytest.mark.parametrize("variant", ["plain", "guided"])
def test_replay_reads_each_reference_of_each_row_in_place(builds, tmp_path, variant):
    """Rows of 15 different references (q_ref, dq_ref, ddq_ref, v_ref): the stand-in adds
    1e-3 sum_j (j + 1) ref_j to tau[2], so a reference read one place off shows."""
    n = 5
    refs = (np.arange(15)[None, :] + 1) * 0.01 + np.arange(n)[:, None] * 0.1
    res, out = _replay(builds, tmp_path, variant, n=n, refs=refs, balance_only=1.0)
    assert res.returncode == 0, res.stderr
    want = 0.005 + 1e-3 * refs @ (np.arange(15) + 1)
    np.testing.assert_allclose(out.tau[:, 2], want, rtol=0, atol=1e-13)


def test_replay_mode_cascade(builds, tmp_path):
    res, out = _replay(builds, tmp_path, "plain", balance_only=0.0, n=3)
    assert list(out.tau[:, 2]) == [10.005] * 3


@pytest.mark.parametrize("delay, late, v", [(2, 0, SCHEDULE), (3, 2, [0, 0, 0] + [X1] * 9),
                                            (4, 3, [0] * 12)])
def test_replay_background_delay(builds, tmp_path, delay, late, v):
    # bg_delay d: the sample runs after the step d periods after its snapshot's, in time
    # while d < due - snapshot; the replay's delay counts from the step that took it
    res, out = _replay(builds, tmp_path, "split", bg_delay=delay - 1)
    assert res.returncode == 0, res.stderr
    assert out.guidance_late == late
    assert list(out.v_ref[:, 0]) == v


def test_replay_reports_a_failed_sample_in_its_row(builds, tmp_path):
    res, out = _replay(builds, tmp_path, "split", guid=[-1.0, 6.0, 7.0])
    assert res.returncode == 0
    assert list(out.rc) == [EFAULT] + [OK] * 3 + [EFAULT] + [OK] * 3 + [EFAULT] + [OK] * 3
    assert out.guidance_late == 3 and list(out.v_ref[:, 0]) == [0] * 12


@pytest.mark.parametrize("variant, kw, code, message", [
    ("plain", {"npar": 6}, 2, "input header does not match the library (7 params, nc 8, 0 "),
    ("split", {"guid": [1.0, 2.0]}, 2, "input header does not match"),
    ("plain", {"c0": [math.nan] + C0[1:]}, 2, "ballbot_fw_init returned -1"),
    ("split", {"guid": [1.0, math.inf, 2.0]}, 2, "ballbot_fw_set_guidance returned -1"),
    ("plain", {"drop": 1}, 2, ""),
])
def test_replay_refuses_a_bad_input(builds, tmp_path, variant, kw, code, message):
    res, _ = _replay(builds, tmp_path, variant, **kw)
    assert res.returncode == code and message in res.stderr


@pytest.mark.parametrize("drop, where", [
    (1, "row 2"), (20, "row 2"), (21, "row 1"), (60, "row 0"),  # 3 rows of 20 values
    (61, "the guidance data"), (63, "the guidance data"),     # 3 guidance values
    (64, "the initial state"), (71, "the initial state"),     # 8 state values
    (72, "the parameters"), (78, "the parameters"),           # 7 parameters
])
def test_replay_names_where_a_short_input_ends(builds, tmp_path, drop, where):
    res, _ = _replay(builds, tmp_path, "guided", n=3, drop=drop)
    assert res.returncode == 2
    assert res.stderr == f"replay: the input ends early, in {where}\n"


def test_replay_without_an_input_file(builds, tmp_path):
    res = subprocess.run([str(builds["plain", False]), "missing.bin", "out.bin"], cwd=tmp_path,
                         capture_output=True, text=True)
    assert res.returncode == 2 and "cannot open missing.bin" in res.stderr
    res = subprocess.run([str(builds["plain", False]), str(_input(tmp_path / "in.bin", 2, "plain")),
                          str(tmp_path / "no" / "out.bin")], capture_output=True, text=True)
    assert res.returncode == 2 and "cannot open" in res.stderr and "out.bin" in res.stderr


def test_short_replay_output_is_refused(builds, tmp_path):
    res, _ = _replay(builds, tmp_path, "plain", drop=20 * 3, n=12)  # 3 rows missing
    assert res.returncode == 2
    with pytest.raises(BuildError, match="stopped early"):
        R._read_output(tmp_path / "out.bin", 12)


# ------------------------------------------------------------------ replay.py around the stand-in


def _stub_function(guided: bool):
    import casadi as ca

    sizes = [("c", 8, 1), ("meas", 5, 1), ("q_ref", 4, 1), ("dq_ref", 4, 1), ("ddq_ref", 4, 1),
             ("v_ref", 3, 1), ("cascade", 1, 1), ("Ts", 1, 1), ("Qa", 2, 2), ("k", 2, 1),
             *((("k_guid", 3, 1),) if guided else ())]
    xs = [ca.SX.sym(n, r, c) for n, r, c in sizes]
    return ca.Function("stub_period", xs, [xs[0]], [n for n, _, _ in sizes], ["c_next"])


@pytest.mark.parametrize("variant, guidance, latency", [("plain", None, 0), ("split", "mpc", 2)])
def test_run_host_writes_the_input_the_replay_program_reads(builds, tmp_path, monkeypatch,
                                                             variant, guidance, latency):
    """write_replay_input's layout (header order, parameters in the Function's order and
    column-major, power-on state, guidance data, rows) read by the real replay program,
    and run_host / _read_output on what it writes: the stand-in's hand values."""
    f = _stub_function(guidance is not None)
    monkeypatch.setattr(R, "firmware_function", lambda *a: f)
    monkeypatch.setattr(R, "embedded_readings", lambda fn: SimpleNamespace(size=5))
    folder = tmp_path / "fw"
    folder.mkdir()
    (folder / "replay_host").write_bytes(builds[variant, False].read_bytes())
    (folder / "replay_host").chmod(0o755)
    fw = R.FirmwareBuild(folder, "flc", "ukf", "double", "0" * 16, guidance=guidance, latency=latency)
    n = 12
    meas = np.tile([0.1, 0.2, 0.3, 0.4, 0.5], (n, 1))
    meas[:, 0] += np.arange(n)
    refs = np.zeros((n, 15))
    refs[:, 14] = 0.25
    # Ts, Qa (column-major: Qa[1] is row 1 of column 0), k: the stand-in echoes Ts, Qa[3], k[1]
    params = {"Ts": np.array([0.01]), "Qa": np.array([[1.0, 0.0], [-3.0, 2.5]]),
              "k": np.array([3.0, 4.5])}
    vals = FirmwareValues({k: v.ravel("F") for k, v in params.items()}, np.array(C0),
                          np.array([5.0, 6.0, 7.0]) if guidance else None)
    rec = R.RecordedLog(meas, refs, False, vals, np.zeros((n, 3)))
    path = R.write_replay_input(tmp_path / "in.bin", rec, fw, bg_delay=1)
    data = np.frombuffer(path.read_bytes(), "<f8")
    n_guid = 3 if guidance else 0
    assert list(data[:7]) == [n, 7, 8, 0.0, R.CALIB_LOOPS, n_guid, 1]
    assert list(data[7:14]) == [0.01, 1.0, -3.0, 0.0, 2.5, 3.0, 4.5]
    assert list(data[14:22]) == C0 and list(data[22:22 + n_guid]) == [5.0, 6.0, 7.0][:n_guid]
    assert data.size == 22 + n_guid + n * 20
    out = R.run_host(fw, rec, bg_delay=1)
    k = np.arange(n)
    np.testing.assert_allclose(out.tau, np.column_stack([k, 0.1 + k, np.full(n, 10.01 + 1e-3 * 15 * 0.25)]),
                               rtol=0, atol=1e-15)  # cascade: balance_only False
    assert list(out.rc) == [PREDICT_ONLY] + [OK] * (n - 1)
    if guidance:
        # the sample after the step one period after its snapshot's: still in time
        assert list(out.v_ref[:, 0]) == SCHEDULE and out.guidance_late == 0
        assert list(out.v_ref[:, 2]) == [6.0] * n
    else:
        assert out.v_ref.shape == (n, 0)
    with pytest.raises(BuildError, match=r"replay log has readings \(12, 4\) and references "
                       r"\(12, 15\); expected \(N, 5\) and \(N, 15\)"):
        R.write_replay_input(tmp_path / "x.bin", R.RecordedLog(meas[:, :4], refs, False, vals,
                                                               rec.tau_mission), fw)
    if guidance:
        bare = R.RecordedLog(meas, refs, False, FirmwareValues(vals.params, vals.c0), rec.tau_mission)
        with pytest.raises(BuildError, match="the firmware has a guidance block; the replay log "
                           "has no guidance data"):
            R.write_replay_input(tmp_path / "y.bin", bare, fw)


def test_run_tool_errors_are_one_line_with_the_exit(tmp_path):
    with pytest.raises(BuildError, match=r"^the thing failed \(exit 3\): boom$"):
        R._run(["sh", "-c", "echo boom >&2; exit 3"], tmp_path, "the thing", 10.0)
    with pytest.raises(BuildError, match=r"^the slow thing did not finish within 0.2 s$"):
        R._run(["sleep", "5"], tmp_path, "the slow thing", 0.2)
    R._run(["true"], tmp_path, "fine", 10.0)
