"""Fixtures of the study tests: what the plots draw, read back when they are saved; every
Markdown table a report function returns or a test writes is checked well formed."""

from __future__ import annotations

import functools
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure


_DELIMITER = re.compile(r"^:?-{3,}:?$")


def _cells(line: str) -> list[str]:
    """A table row's cells (a pipe inside a cell is written ``\\|``)."""
    return [c.strip() for c in re.split(r"(?<!\\)\|", line.strip()[1:-1])]


def check_markdown_tables(text: str, where: str = "report") -> None:
    """Each table (a run of lines starting with ``|``): a header, a delimiter row of
    ``---`` cells, then rows, all with the header's number of cells."""
    lines = text.split("\n")
    i = 0
    while i < len(lines):
        if not lines[i].startswith("|"):
            i += 1
            continue
        j = i
        while j < len(lines) and lines[j].startswith("|"):
            j += 1
        block = lines[i:j]
        n = len(_cells(block[0]))
        assert len(block) >= 2 and all(_DELIMITER.match(c) for c in _cells(block[1])), \
            f"{where}: table without a delimiter row at {block[0]!r}"
        for row in block[1:]:
            assert row.endswith("|") and len(_cells(row)) == n, \
                f"{where}: {len(_cells(row))} cells where the header {block[0]!r} has {n}: {row!r}"
        i = j


@pytest.fixture(autouse=True)
def _tables_well_formed(monkeypatch):
    """Wraps the studies' report functions (``*report_lines``, ``table_lines``) and
    ``Path.write_text`` of ``.md`` files with :func:`check_markdown_tables`."""
    for name, mod in list(sys.modules.items()):
        if not name.startswith(("studies.", "ballbot_casadi.studies.")) or mod is None:
            continue
        for attr, fn in list(vars(mod).items()):
            if callable(fn) and (attr.endswith("report_lines") or attr == "table_lines") \
                    and getattr(fn, "__module__", None) == name:
                def checked(*a, _fn=fn, _where=f"{name}.{attr}", **k):
                    out = _fn(*a, **k)
                    check_markdown_tables("\n".join(out), _where)
                    return out
                monkeypatch.setattr(mod, attr, functools.wraps(fn)(checked))
    real = Path.write_text

    def write_text(self, data, *a, **k):
        if self.suffix == ".md":
            check_markdown_tables(data, str(self.name))
        return real(self, data, *a, **k)
    monkeypatch.setattr(Path, "write_text", write_text)


@pytest.fixture
def saved(monkeypatch):
    """file name -> list of axes, each {"lines": [(label, x, y)], "scatter": [(label, xy)],
    "circles": [(centre, r)], "spans": [(label, ymin, ymax)] (other patches, e.g. ``axhspan``),
    "xspans": the same patches' [(label, xmin, xmax)],
    "xlabel", "ylabel", "title", "xscale", "yscale", "xlim", "ylim"}, plus the figure's
    suptitle under ``"<file name>:suptitle"`` and its look (:func:`_style`) under
    ``"<file name>:style"``; ``Figure.savefig`` is wrapped to record them."""
    figs: dict[str, list[dict]] = {}
    real = Figure.savefig

    def grab(self, fname, *a, **kw):
        axes = []
        for ax in self.axes:
            axes.append({"lines": [(ln.get_label(), np.asarray(ln.get_xdata(), float),
                                    np.asarray(ln.get_ydata(), float)) for ln in ax.lines],
                         "scatter": [(c.get_label(), np.asarray(c.get_offsets(), float)) for c in ax.collections],
                         "circles": [(tuple(map(float, c.get_center())), float(c.get_radius()))
                                     for c in ax.patches if hasattr(c, "get_radius")],
                         "spans": [(c.get_label(), *_range(c, 1)) for c in ax.patches
                                   if not hasattr(c, "get_radius")],
                         "xspans": [(c.get_label(), *_range(c, 0)) for c in ax.patches
                                    if not hasattr(c, "get_radius")],
                         "xlabel": ax.get_xlabel(), "ylabel": ax.get_ylabel(), "title": ax.get_title(),
                         "yscale": ax.get_yscale(), "xscale": ax.get_xscale(),
                         "xlim": tuple(map(float, ax.get_xlim())), "ylim": tuple(map(float, ax.get_ylim()))})
        figs[Path(fname).name] = axes
        figs[Path(fname).name + ":suptitle"] = self._suptitle.get_text() if self._suptitle else ""
        figs[Path(fname).name + ":style"] = _style(self, kw.get("dpi"))
        return real(self, fname, *a, **kw)

    monkeypatch.setattr(Figure, "savefig", grab)
    yield figs
    import matplotlib.pyplot as plt

    plt.close("all")  # the figures a plot function left open



def _range(patch, axis: int) -> tuple[float, float]:
    """The data range of a patch along ``axis`` (0: x, 1: y; a span's bounds)."""
    v = patch.get_path().transformed(patch.get_patch_transform()).vertices[:, axis]
    return float(v.min()), float(v.max())


def _style(fig, dpi) -> dict:
    """What a figure looks like beyond its data: size, resolution, and per axes the lines'
    width, style, marker, its size, edge width and face colour (open or filled), alpha, draw style, colour, number of points (a curve's
    resolution) and, for a straight horizontal or vertical line (a limit, a threshold), its
    level; the scatter sets' sizes, colours and counts; the patches' colours; the legend's,
    title's and axis labels' font sizes; the axis scales and the limits set on purpose (not
    autoscaled); the grid lines drawn (visible, alpha, style per axis); where the axes sits
    in its grid with the grid's height and width ratios,
    and whether it shares its x axis with the first axes (compared with a pinned copy by
    ``_figures.assert_style``)."""
    from matplotlib.colors import to_hex

    def legend(ax):
        leg = ax.get_legend()
        return None if leg is None else {"fontsize": leg.get_texts()[0].get_fontsize() if leg.get_texts() else None,
                                         "loc": leg._loc, "ncol": leg._ncols}

    def grid(ax):  # where the axes sits in its grid and the grid's ratios (not fonts: exact)
        spec = ax.get_subplotspec()
        if spec is None:
            return None
        gs = spec.get_gridspec()
        return {"shape": list(gs.get_geometry()), "rows": [spec.rowspan.start, spec.rowspan.stop],
                "cols": [spec.colspan.start, spec.colspan.stop],
                "height_ratios": [float(v) for v in gs.get_height_ratios() or [1] * gs.nrows],
                "width_ratios": [float(v) for v in gs.get_width_ratios() or [1] * gs.ncols]}

    def level(ln):  # the level of a two-point horizontal or vertical line, 6 significant digits
        x, y = (np.asarray(v, float) for v in (ln.get_xdata(), ln.get_ydata()))
        for axis, v in (("y", y), ("x", x)):
            if v.size == 2 and np.isfinite(v).all() and v[0] == v[1]:
                return [axis, float(f"{v[0]:.6g}")]
        return None

    def line(ln):
        return [ln.get_linewidth(), ln.get_linestyle(), ln.get_marker(), ln.get_markersize(),
                ln.get_markeredgewidth(), to_hex(ln.get_markerfacecolor(), keep_alpha=True), ln.get_alpha(),
                ln.get_drawstyle(), to_hex(ln.get_color(), keep_alpha=True), len(ln.get_xdata()), level(ln)]

    def collection(c):
        fc = c.get_facecolors()
        return [len(c.get_offsets()), [float(v) for v in c.get_sizes()[:1]],
                to_hex(fc[0], keep_alpha=True) if len(fc) else None]

    def gridlines(ax):  # per axis: the first major grid line's visibility, alpha and style
        out = []
        for a in (ax.xaxis, ax.yaxis):
            gl = a.get_gridlines()
            out.append([gl[0].get_visible(), gl[0].get_alpha(), gl[0].get_linestyle()] if len(gl) else None)
        return out

    def limits(ax):
        return {"x": None if ax.get_autoscalex_on() else [float(f"{v:.6g}") for v in ax.get_xlim()],
                "y": None if ax.get_autoscaley_on() else [float(f"{v:.6g}") for v in ax.get_ylim()]}

    return {"figsize": [float(v) for v in fig.get_size_inches()], "dpi": dpi,
            "axes": [{"lines": [line(ln) for ln in ax.lines],
                      "collections": [collection(c) for c in ax.collections],
                      "patches": [[[float(v) for v in p.get_facecolor()], p.get_alpha()] for p in ax.patches],
                      "legend": legend(ax), "title_size": ax.title.get_fontsize(),
                      "label_sizes": [ax.xaxis.label.get_fontsize(), ax.yaxis.label.get_fontsize()],
                      "scales": [ax.get_xscale(), ax.get_yscale()], "limits": limits(ax), "grid": grid(ax),
                      "gridlines": gridlines(ax),
                      "shares_x_with_first": bool(ax.get_shared_x_axes().joined(ax, fig.axes[0]))}
                     for ax in fig.axes]}
