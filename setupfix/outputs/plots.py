"""Figures of the optimiser comparison (Stryczek 2014, Figs. 12–18).

Pure drawing on plain arrays: convergence of the best-so-far f1, f2 and f against
the number of evaluated solutions (Figs. 12–15), the spread of the final results
per method (Figs. 16–17), and the sorted results over many measurement sets
(Fig. 18).  matplotlib is imported inside the functions and used through its
object interface (``matplotlib.figure.Figure``, Agg canvas), so importing this
module costs nothing and no global backend is switched.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from setupfix.core.errors import ExportError, SourceLocation

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["comparison_figure", "validation_figure", "figure_format", "FORMATS"]

Array = npt.NDArray[np.float64]

#: File suffix → matplotlib format.
FORMATS: dict[str, str] = {".png": "png", ".svg": "svg"}

_LABELS = (("f1", "f₁ = error budget δ (eq. 8)"), ("f2", "f₂ = ‖x‖ (eq. 9)"), ("f", "f = 10·f₁ − f₂ (eq. 10)"))


def _colour(i: int) -> str:
    return f"C{i % 10}"


def comparison_figure(
    histories: Mapping[str, Sequence[Array]],
    finals: Mapping[str, Mapping[str, Array]],
    *,
    exact: tuple[float, float, float] | None = None,
    unit: str = "mm",
    title: str = "",
) -> Figure:
    """Convergence (top row) and spread (bottom row) of several optimisers.

    Parameters
    ----------
    histories : mapping method → list of ndarray of shape (k, 4)
        Best-so-far [evaluations, f1, f2, f] of each trial.  Every trial is drawn
        thin; the trial with the median final f is drawn bold ("a typical run",
        as Figs. 12–15 show).
    finals : mapping method → {"f1", "f2", "f"} → ndarray of shape (N,)
        Final results per trial (Figs. 16–17 as strip plots with the median marked).
    exact : (f1, f2, f), optional
        The exact grid optimum, drawn as a dashed line on every panel.
    unit : str
        Model unit for the axis labels.
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(13, 7.5), layout="constrained")
    axes = fig.subplots(2, 3)
    methods = list(finals)
    for col, (key, label) in enumerate(_LABELS):
        k = {"f1": 1, "f2": 2, "f": 3}[key]
        ax = axes[0, col]
        for i, name in enumerate(histories):
            runs = [h for h in histories[name] if len(h)]
            if not runs:
                continue
            final_f = np.array([h[-1, 3] for h in runs])
            typical = int(np.argsort(final_f)[len(final_f) // 2])
            for j, h in enumerate(runs):
                bold = j == typical
                ax.step(
                    h[:, 0],
                    h[:, k],
                    where="post",
                    color=_colour(i),
                    lw=1.8 if bold else 0.6,
                    alpha=1.0 if bold else 0.25,
                    label=name if bold else None,
                )
        if exact is not None:
            ax.axhline(exact[col], color="k", ls="--", lw=1, label="exact (grid optimum)")
        ax.set_xscale("log")
        ax.set_xlabel("solutions evaluated")
        ax.set_ylabel(f"{label} [{unit}]" if key != "f" else label)
        ax.grid(alpha=0.3)
        if key != "f2" and methods and exact is not None:
            # A run starts far below its end; show the last stretch, where the methods differ.
            low = min(float(np.min(finals[m][key])) for m in methods)
            span = max(exact[col] - low, 1e-6)
            ax.set_ylim(low - 2 * span, exact[col] + 0.3 * span)
        if col == 0:
            ax.legend(fontsize=8, loc="lower right")
        ax = axes[1, col]
        for i, name in enumerate(methods):
            values = np.asarray(finals[name][key], dtype=float)
            jitter = np.linspace(-0.15, 0.15, values.size) if values.size > 1 else np.zeros(1)
            ax.plot(i + jitter, values, "o", color=_colour(i), ms=4, alpha=0.8)
            ax.plot([i - 0.25, i + 0.25], [np.median(values)] * 2, color=_colour(i), lw=2)
        if exact is not None:
            ax.axhline(exact[col], color="k", ls="--", lw=1)
        ax.set_xticks(range(len(methods)), methods)
        ax.set_ylabel(f"final {label} [{unit}]" if key != "f" else f"final {label}")
        ax.grid(alpha=0.3, axis="y")
    if title:
        fig.suptitle(title)
    return fig


def validation_figure(
    initial: Array, exact: Array, results: Mapping[str, Array], *, unit: str = "mm", title: str = ""
) -> Figure:
    """Sorted results over many measurement sets (Fig. 18) with the exact optimum beside them.

    Parameters
    ----------
    initial : ndarray of shape (S,) [unit]
        f1 before correction of each set.
    exact : ndarray of shape (S,) [unit]
        Exact grid optimum of f1 of each set.
    results : mapping method → ndarray of shape (S, N) [unit]
        f1 of N trials per set.  Sets are sorted by their initial f1, as the paper
        sorts them; per method the median trial is drawn and the top panel shows
        the worst gap per set.
    """
    from matplotlib.figure import Figure

    order = np.argsort(initial, kind="stable")
    fig = Figure(figsize=(12, 7.5), layout="constrained")
    ax_f1, ax_gap = fig.subplots(2, 1, sharex=True, height_ratios=(3, 2))
    sets = np.arange(1, initial.size + 1)
    ax_f1.plot(sets, initial[order], "k.", ms=4, label="before correction")
    ax_f1.plot(sets, exact[order], "k-", lw=1.2, label="exact grid optimum")
    for i, (name, f1) in enumerate(results.items()):
        f1 = np.asarray(f1, dtype=float)[order]
        ax_f1.plot(sets, np.median(f1, axis=1), ".", color=_colour(i), ms=5, label=f"{name} (median trial)")
        gap = exact[order][:, None] - f1
        ax_gap.plot(sets, 1000.0 * np.median(gap, axis=1), "-", color=_colour(i), lw=1, label=f"{name} median")
        ax_gap.plot(sets, 1000.0 * np.max(gap, axis=1), ":", color=_colour(i), lw=1)
    ax_f1.set_ylabel(f"error budget f₁ [{unit}]")
    ax_f1.legend(fontsize=8, ncol=2)
    ax_f1.grid(alpha=0.3)
    ax_gap.set_yscale("symlog", linthresh=1.0)
    ax_gap.set_ylabel(f"gap to exact f₁ [10⁻³ {unit}]\n(solid median, dotted worst)")
    ax_gap.set_xlabel("measurement set, sorted by f₁ before correction")
    ax_gap.grid(alpha=0.3)
    if title:
        fig.suptitle(title)
    return fig


def figure_format(path: str | os.PathLike[str]) -> str:
    """matplotlib format of a figure file by its suffix.

    Raises
    ------
    ExportError
        If the suffix is neither .png nor .svg.
    """
    path = Path(path)
    fmt = FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise ExportError(
            f"plot format {path.suffix or '(none)'!r} not supported; use .png or .svg",
            location=SourceLocation(str(path)),
        )
    return fmt
