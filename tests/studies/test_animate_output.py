"""``animate``'s checks and its output (issue 23, test strength): every refused argument at and
just past its bound, the GIF written whole into a folder that did not exist (nested), no
partial file left behind; the frames chosen at the frame rate."""

from __future__ import annotations

import gc
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from ballbot_casadi.errors import ScenarioError  # noqa: E402
from ballbot_casadi.studies import animate as A  # noqa: E402


@pytest.mark.parametrize("out, fps, frames, needle", [
    ("run.png", 15.0, 200, "output must end in .gif or .mp4"),
    ("run.gif", 0.0, 200, "fps must be > 0 and max_frames >= 1, got 0.0, 200"),
    ("run.gif", -1.0, 200, "fps must be > 0"),
    ("run.gif", 15.0, 0, "fps must be > 0 and max_frames >= 1, got 15.0, 0"),
])
def test_refused_before_reading_the_log(tmp_path, monkeypatch, out, fps, frames, needle):
    monkeypatch.setattr(A, "load_log", lambda run: pytest.fail("read"))
    with pytest.raises(ScenarioError, match=needle.replace("(", r"\(").replace(".", r"\.")):
        A.animate(tmp_path / "r.npz", tmp_path / out, fps=fps, max_frames=frames)


def test_mp4_without_ffmpeg_is_refused(tmp_path, monkeypatch):
    monkeypatch.setattr(A.shutil, "which", lambda name: None)
    with pytest.raises(ScenarioError, match="writing .mp4 needs ffmpeg on the PATH"):
        A.animate(tmp_path / "r.npz", tmp_path / "run.mp4")


def test_a_gif_into_a_new_nested_folder(tmp_path, monkeypatch):
    seen = []

    def scene(log, name, fps, max_frames):
        seen.append((log, name, fps, max_frames))
        fig, ax = plt.subplots(figsize=(1, 1))
        line, = ax.plot([0, 1], [0, 1])
        return fig, lambda i: (line,), np.array([0])

    monkeypatch.setattr(A, "load_log", lambda run: "LOG")
    monkeypatch.setattr(A, "animation_scene", scene)
    out = tmp_path / "a" / "b" / "run.gif"
    assert A.animate(tmp_path / "r.npz", out, fps=4.0, max_frames=1, dpi=10) == out
    assert out.read_bytes()[:6] in (b"GIF89a", b"GIF87a")
    assert seen == [("LOG", str(tmp_path / "r.npz"), 4.0, 1)]
    assert sorted(p.name for p in out.parent.iterdir()) == ["run.gif"]


@pytest.mark.filterwarnings("ignore:Animation was deleted without rendering")
@pytest.mark.parametrize("written", [False, True])
def test_a_failed_render_raises_its_own_error_and_leaves_nothing(tmp_path, monkeypatch, written):
    """The writer fails before or after it began the partial file: its error reaches the
    caller (not the clean-up's), no partial file and no output are left, the figure is closed."""
    fig, ax = plt.subplots(figsize=(1, 1))
    monkeypatch.setattr(A, "load_log", lambda run: "LOG")
    monkeypatch.setattr(A, "animation_scene", lambda *a: (fig, lambda i: (), np.array([0])))

    def save(self, path, writer=None, dpi=None):
        if written:
            Path(path).write_bytes(b"GIF89a half")
        raise RuntimeError("writer broke")

    monkeypatch.setattr(A.FuncAnimation, "save", save)
    with pytest.raises(RuntimeError, match="^writer broke$") as exc:
        A.animate(tmp_path / "r.npz", tmp_path / "o" / "run.gif")
    del exc  # its traceback holds the unrendered animation: collected here, warning filtered
    gc.collect()
    assert list((tmp_path / "o").iterdir()) == []
    assert not plt.fignum_exists(fig.number)


def test_frames_at_the_rate():
    t = np.arange(100) * 0.005                     # 200 Hz log
    assert A._frames(100, t, 20.0, 200).tolist() == list(range(0, 100, 10))
    assert A._frames(100, t, 1000.0, 200).tolist() == list(range(100))   # at most every sample
    assert A._frames(100, t, 20.0, 4).tolist() == [0, 33, 66, 99]
    assert A._frames(1, t[:1], 20.0, 5).tolist() == [0]
