"""Plotly figures as plain data: each figure is the JSON plotly.js draws
(its traces, layout and frames), built as dicts.

plotly's figure objects (``plotly.graph_objects``) check every property
as it is set; building a report's figures through them was most of the
time of writing the report (``benchmarks/bench_report_ab.py`` measures the
two ways side by side).  The figures here hold the same properties as
those objects would (tests/test_report_html.py compares the two for every
kind of figure): an update merges nested dicts as plotly's ``update`` does,
subplot grids have plotly's ``make_subplots`` domains and titles, a named
colour scale is spelled out as plotly spells it, and numeric arrays go to
the page as plotly's typed arrays (``convert_to_base64``).
"""
from __future__ import annotations

import base64
import copy
import functools

import numpy as np

__all__ = ["Figure", "subplots", "colorscale", "merge", "typed_arrays"]


def merge(dst: dict, src: dict) -> dict:
    """plotly's ``update``: a dict value merges into the dict already there,
    None removes the key, anything else (lists included) replaces it."""
    for k, v in src.items():
        if v is None:
            dst.pop(k, None)
        elif isinstance(v, dict) and isinstance(dst.get(k), dict):
            merge(dst[k], v)
        else:
            dst[k] = copy.deepcopy(v) if isinstance(v, dict) else v
    return dst


@functools.cache
def _scale(name: str) -> tuple:
    # plotly's own validator, which its figure objects apply (plotly.colors.get_colorscale, the
    # public table, imports the same module, and its positions differ from the validator's by an ulp)
    from _plotly_utils.basevalidators import ColorscaleValidator

    return tuple(tuple(p) for p in ColorscaleValidator("colorscale", "scatter").validate_coerce(name))


def colorscale(name: str) -> list:
    """A named colour scale (``"Viridis"``) as plotly writes it: [[position, colour], ...]."""
    return [list(p) for p in _scale(name)]


class Figure:
    """A figure's traces (``data``, dicts with their ``type``), ``layout`` and ``frames``."""

    def __init__(self, data=(), layout: dict | None = None, frames: list | None = None):
        self.data: list[dict] = [dict(t) for t in data]
        self.layout: dict = {} if layout is None else layout
        self.frames = frames
        self._cells: dict = {}     # (row, col) -> (x axis, y axis) of a subplot grid

    def add_trace(self, trace: dict, row: int | None = None, col: int | None = None) -> "Figure":
        t = dict(trace)
        if row is not None:
            t["xaxis"], t["yaxis"] = self._cells[(row, col)]
        self.data.append(t)
        return self

    def update_layout(self, props: dict | None = None, **more) -> "Figure":
        merge(self.layout, {**(props or {}), **more})
        return self

    def _axes(self, letter: str, row, col) -> list[str]:
        if row is not None:
            ref = self._cells[(row, col)][0 if letter == "x" else 1]
            return [f"{letter}axis{ref[1:]}"]
        keys = [k for k in self.layout if k.startswith(f"{letter}axis")]
        return keys or [f"{letter}axis"]

    def _update_axes(self, letter: str, row, col, props: dict) -> "Figure":
        for k in self._axes(letter, row, col):
            merge(self.layout.setdefault(k, {}), props)
        return self

    def update_xaxes(self, row: int | None = None, col: int | None = None, **props) -> "Figure":
        return self._update_axes("x", row, col, props)

    def update_yaxes(self, row: int | None = None, col: int | None = None, **props) -> "Figure":
        return self._update_axes("y", row, col, props)

    def update_annotations(self, **props) -> "Figure":
        for a in self.layout.get("annotations", []):
            merge(a, props)
        return self

    def to_dict(self) -> dict:
        """The figure as plotly.js reads it (numeric arrays as typed arrays, :func:`typed_arrays`)."""
        out = {"data": typed_arrays(self.data), "layout": typed_arrays(self.layout)}
        if self.frames:
            out["frames"] = typed_arrays(self.frames)
        return out


#: plotly.js's typed arrays: numpy's dtype -> its short name
_SHORT = {"int8": "i1", "uint8": "u1", "int16": "i2", "uint16": "u2", "int32": "i4", "uint32": "u4",
          "float32": "f4", "float64": "f8"}
#: values plotly leaves as they are (never typed arrays)
_SKIPPED = ("geojson", "layer", "layers", "range")


def typed_arrays(obj):
    """A copy of obj (dicts, lists, tuples) with every numpy array as plotly.js's
    typed array ``{"dtype", "bdata"[, "shape"]}``, as plotly's
    ``convert_to_base64`` writes it (a 64-bit integer array in the smallest
    integer type that holds it; an empty array, or one of another type, kept)."""
    if isinstance(obj, dict):
        return {k: (v if k in _SKIPPED and isinstance(v, np.ndarray) else typed_arrays(v)) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [typed_arrays(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _typed(obj)
    return obj


def _typed(v: np.ndarray):
    if v.size == 0:
        return v
    if v.dtype in (np.int64, np.uint64):
        lo, hi = v.min(), v.max()
        kinds = (np.int8, np.int16, np.int32) if v.dtype == np.int64 else (np.uint8, np.uint16, np.uint32)
        fit = next((k for k in kinds if np.iinfo(k).min <= lo and hi <= np.iinfo(k).max), None)
        if fit is None:
            return v
        v = v.astype(fit)
    short = _SHORT.get(str(v.dtype))
    if short is None:
        return v
    out = {"dtype": short, "bdata": base64.b64encode(np.ascontiguousarray(v)).decode("ascii")}
    if v.ndim > 1:
        out["shape"] = str(v.shape)[1:-1]
    return out


def subplots(rows: int, cols: int, titles: list[str], horizontal_spacing: float, vertical_spacing: float) -> Figure:
    """An empty grid of rows x cols plots, numbered row by row from the top
    left, with their titles above them: plotly's ``make_subplots`` (its
    domains computed the same way, so the same numbers)."""
    widths = [(1.0 - horizontal_spacing * (cols - 1)) / cols] * cols
    heights = [(1.0 - vertical_spacing * (rows - 1)) / rows] * rows
    # the grid's lower-left corners, its rows counted from the bottom (make_subplots' row_dir -1)
    grid = [[(sum(widths[:c]) + c * horizontal_spacing, sum(heights[:r]) + r * vertical_spacing)
             for c in range(cols)] for r in range(rows)[::-1]]
    fig = Figure()
    annotations = []
    n = 0
    for r in range(rows):
        for c in range(cols):
            n += 1
            x_dom = [grid[r][c][0], grid[r][c][0] + widths[c]]
            y_dom = [_unit(grid[r][c][1]), _unit(grid[r][c][1] + heights[-1 - r])]
            suffix = str(n) if n > 1 else ""
            fig.layout[f"xaxis{suffix}"] = {"domain": x_dom, "anchor": f"y{suffix}"}
            fig.layout[f"yaxis{suffix}"] = {"domain": y_dom, "anchor": f"x{suffix}"}
            fig._cells[(r + 1, c + 1)] = (f"x{suffix}", f"y{suffix}")
            if n - 1 < len(titles) and titles[n - 1]:
                annotations.append({"y": y_dom[1], "xref": "paper", "x": sum(x_dom) / 2.0, "yref": "paper",
                                    "text": titles[n - 1], "showarrow": False, "font": {"size": 16},
                                    "xanchor": "center", "yanchor": "bottom"})
    if annotations:
        fig.layout["annotations"] = annotations
    return fig


def _unit(y: float) -> float:
    """make_subplots' rounding of a domain end within 0.01 outside [0, 1]."""
    if -0.01 < y < 0.0:
        return 0.0
    if 1.0 < y < 1.01:
        return 1.0
    return y
