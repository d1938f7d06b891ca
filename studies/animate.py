"""``ballbot animate RUN.npz -o run.gif``: a 3D view of a logged run, headless.

Draws the ball (a wire sphere of radius ``rk`` rolling on the floor), the body axes
(x red, y green, z blue, from the ball centre, the z axis ``l`` long to the body's
centre of mass), the heading (the body x axis projected on the floor), the ball's path
and the time.  The view follows the ball; for a path run (the log's path table,
:func:`~ballbot_casadi.sim.log.log_path`) it shows the whole course instead, with the path
to follow (dashed, black) and its obstacles (grey discs on the floor).  Matplotlib with
the Agg backend: a GIF through Pillow, an MP4 through ffmpeg when it is installed.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Callable

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after selecting the headless backend)
import numpy as np
from matplotlib.animation import FFMpegWriter, FuncAnimation, PillowWriter
from matplotlib.patches import Circle
from mpl_toolkits.mplot3d import art3d

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.files import atomic_write_bytes
from ballbot_casadi.core.layout import STATE, STATE_XY
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.log import SimulationLog, load_log, log_path

__all__ = ["animate", "animation_scene", "FORMATS", "PATH_GID", "OBSTACLE_GID", "BALL_GID", "HEADING_GID"]

#: Output formats by suffix.
FORMATS = (".gif", ".mp4")
#: Matplotlib ``gid`` of the drawn path line and of each obstacle disc.
PATH_GID, OBSTACLE_GID, BALL_GID, HEADING_GID = "path", "obstacle", "ball", "heading"


def _frames(n: int, time: np.ndarray, fps: float, max_frames: int) -> np.ndarray:
    """Indices of the logged samples shown: ``fps`` frames per simulated second, at most ``max_frames``."""
    dt = float(time[1] - time[0]) if n > 1 else 1.0
    step = max(1, int(round(1.0 / (fps * dt))))
    idx = np.arange(0, n, step)
    if idx.size > max_frames:
        idx = np.linspace(0, n - 1, max_frames).round().astype(int)
    return idx


def animate(run: str | Path, out: str | Path, fps: float = 15.0, max_frames: int = 200, dpi: int = 70) -> Path:
    """Render ``run`` (a ``run.npz`` log) to ``out`` (``.gif``, or ``.mp4`` with ffmpeg).

    Raises
    ------
    ScenarioError
        Unknown suffix, or ``.mp4`` without ffmpeg on the PATH.
    """
    out = Path(out)
    if out.suffix not in FORMATS:
        raise ScenarioError(f"{out}: output must end in {' or '.join(FORMATS)}")
    if out.suffix == ".mp4" and shutil.which("ffmpeg") is None:
        raise ScenarioError(f"{out}: writing .mp4 needs ffmpeg on the PATH; write a .gif instead")
    if not (fps > 0 and max_frames >= 1):
        raise ScenarioError(f"fps must be > 0 and max_frames >= 1, got {fps}, {max_frames}")
    log = load_log(run)
    fig, draw, idx = animation_scene(log, str(run), fps, max_frames)
    anim = FuncAnimation(fig, draw, frames=list(idx), interval=1000.0 / fps)
    tmp = out.with_name(f".{out.stem}.partial{out.suffix}")
    out.parent.mkdir(parents=True, exist_ok=True)
    writer = PillowWriter(fps=fps) if out.suffix == ".gif" else FFMpegWriter(fps=fps)
    try:
        anim.save(str(tmp), writer=writer, dpi=dpi)
        atomic_write_bytes(out, tmp.read_bytes())
    finally:
        plt.close(fig)
        tmp.unlink(missing_ok=True)
    return out


def animation_scene(log: SimulationLog, name: str = "log", fps: float = 15.0, max_frames: int = 200
                    ) -> tuple[plt.Figure, Callable[[int], None], np.ndarray]:
    """The figure, its ``draw(k)`` for logged sample ``k`` and the samples shown (see the
    module docstring); ``name`` names the log in errors.

    Raises
    ------
    ScenarioError
        The log has no finite state to show.
    """
    x = np.asarray(log["state"], float)
    t = np.asarray(log["time"], float)
    ok = np.all(np.isfinite(x), axis=1)
    n = int(np.argmin(ok)) if not np.all(ok) else x.shape[0]
    if n < 1:
        raise ScenarioError(f"{name}: the log has no finite state to show")
    rk, l = float(log.params.rk), float(log.params.l)
    idx = _frames(n, t, fps, max_frames)
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 13), np.linspace(0, np.pi, 7))
    sphere = rk * np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)])
    span = max(0.6, l + 2 * rk)
    course = log_path(log, name)
    if course is not None:  # a path run: the whole course in view, not following the ball
        xy, obstacles = course
        pts = np.vstack([xy, x[:n, STATE_XY], obstacles[:, :2] - obstacles[:, 2:],
                         obstacles[:, :2] + obstacles[:, 2:]])
        lo, hi = pts.min(axis=0) - 0.3, pts.max(axis=0) + 0.3
        height = max(l + 2 * rk, 0.25 * float(np.max(hi - lo)))
    fig = plt.figure(figsize=(5, 5) if course is None else (8, 5.5))
    ax = fig.add_subplot(111, projection="3d")

    def draw(k: int) -> None:
        ax.cla()
        px, py = x[k, STATE.index("x")], x[k, STATE.index("y")]
        ball = np.array([px, py, rk])
        Rm = np.asarray(Q.rotation_matrix(x[k, STATE["q"]] / np.linalg.norm(x[k, STATE["q"]])))
        ax.plot_wireframe(sphere[0] + ball[0], sphere[1] + ball[1], sphere[2] + ball[2], color="0.6", lw=0.4,
                          gid=BALL_GID)
        for j, (col, length) in enumerate((("r", 0.5 * l), ("g", 0.5 * l), ("b", l))):
            e = ball + length * Rm[:, j]
            ax.plot([ball[0], e[0]], [ball[1], e[1]], [ball[2], e[2]], color=col, lw=2.5 if j == 2 else 1.5)
        head = Rm[:, 0].copy()
        head[2] = 0.0
        if np.linalg.norm(head) > 1e-9:
            head = 0.3 * span * head / np.linalg.norm(head)
            ax.quiver(px, py, 0.0, head[0], head[1], 0.0, color="k", arrow_length_ratio=0.3, lw=1,
                      gid=HEADING_GID)
        ax.plot(x[: k + 1, STATE.index("x")], x[: k + 1, STATE.index("y")], np.zeros(k + 1), "m-", lw=1)
        if course is None:
            ax.set_xlim(px - span, px + span)
            ax.set_ylim(py - span, py + span)
            ax.set_zlim(0, 2 * span)
        else:
            ax.plot(xy[:, 0], xy[:, 1], np.zeros(len(xy)), "k--", lw=0.8, gid=PATH_GID)
            for ox, oy, r in obstacles:
                disc = Circle((ox, oy), r, color="0.5", alpha=0.6, gid=OBSTACLE_GID)
                ax.add_patch(disc)
                art3d.pathpatch_2d_to_3d(disc, z=0.0, zdir="z")
            ax.set_xlim(lo[0], hi[0])
            ax.set_ylim(lo[1], hi[1])
            ax.set_zlim(0, height)
            ax.set_box_aspect((hi[0] - lo[0], hi[1] - lo[1], height))
            ax.view_init(elev=40, azim=-70)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_zlabel("z (m)")
        ax.set_title(f"{log.scenario.get('name', 'run')}  t = {t[k]:6.2f} s", fontsize=9)

    return fig, draw, idx
