"""Use case "compare": the metaheuristics of Stryczek (2014) beside the exact grid optimum.

The paper runs twelve trials of CRIPSO, PSO, GA and COA on one measurement set
("Comparison …" section, Figs. 12–17); here every method gets the same seeded
trials on one measured part, and the exact optimum (LP + MILP on the register
grid) is solved once as the yardstick none of those papers had — on the paper's
objective (eqs. 8–9, ``objective="paper"``), which the metaheuristics optimise too,
not the leximin centring ``correct`` uses by default.  The gap of a trial is exact
f1 − trial f1 (≥ 0 up to rounding), in the model unit.

When no correction brings every dimension into tolerance, the exact optimum gives some up (its
triage: ``given_up``); then every f1 here — the exact one, each trial's and so each gap — is the
error budget of the dimensions the exact optimum keeps (each trial's budget over all dimensions
stays in its ``margin_all``), and the given-up ones are listed apart (``exact_given_up``).

Seeds: trial t of every method uses the t-th 32-bit word of
``numpy.random.SeedSequence(seed)``, so a run is reproducible from ``--seed``
alone and all methods see the same seed list.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from setupfix.core.errors import Note
from setupfix.model import ProcessModel, load_model
from setupfix.optimize import CorrectionProblem, OptimizeResult, get_optimizer
from setupfix.usecases.correct import pose_cycle, read_cycles
from setupfix.usecases.requests import CorrectRequest

__all__ = [
    "DEFAULT_METHODS",
    "CompareRequest",
    "MethodTrials",
    "Comparison",
    "trial_seeds",
    "over_kept",
    "compare_steps",
    "compare_problem",
    "compare_report",
    "plot_comparison",
]

Array = npt.NDArray[np.float64]

#: Methods compared by default, in table order.
DEFAULT_METHODS: tuple[str, ...] = ("cripso", "pso", "ga", "coa", "cs")


def trial_seeds(seed: int, trials: int) -> list[int]:
    """Seeds of the trials, derived deterministically from one seed."""
    return [int(s) for s in np.random.SeedSequence(seed).generate_state(trials, dtype=np.uint32)]


@dataclass(frozen=True)
class CompareRequest:
    """What ``compare`` needs besides the report: ``correct``'s request, the methods, trials per
    method, the root seed and hyper-parameters by optimiser name (``"exact"`` included).

    ``request`` is the :class:`~setupfix.usecases.requests.CorrectRequest` ``correct`` takes
    (model, reader's and cycles' options, current offsets, history, the exact optimiser's
    settings), so the problem compared is the one ``correct`` solves; a model or its file
    stands for a request with every option at its default.  The exact yardstick pursues the
    paper's objective unless ``request.solve`` or ``params["exact"]`` asks otherwise.
    """

    request: CorrectRequest | ProcessModel | str | Path
    methods: tuple[str, ...] = DEFAULT_METHODS
    trials: int = 12
    seed: int = 0
    params: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)

    def correct_request(self) -> CorrectRequest:
        """``correct``'s request (the model file read once when a path was given)."""
        if isinstance(self.request, CorrectRequest):
            return self.request
        model = self.request if isinstance(self.request, ProcessModel) else load_model(self.request)
        return CorrectRequest(model)

    def exact_params(self, request: CorrectRequest) -> dict[str, Any]:
        """The exact yardstick's settings: the paper's objective, then ``request.solve``'s, then ``params``'."""
        solve = request.solve.params() if request.solve.optimizer == "exact" else {}
        return {"objective": "paper", **solve, **self.params.get("exact", {})}


@dataclass(frozen=True, eq=False)
class MethodTrials:
    """The N trials of one optimiser on one problem."""

    optimizer: str
    seeds: tuple[int, ...]
    results: tuple[OptimizeResult, ...]

    @property
    def f1(self) -> Array:
        """Error budget after correction per trial, shape (N,) [model unit]."""
        return np.array([r.margin_after for r in self.results])

    @property
    def f2(self) -> Array:
        """Correction norm per trial, shape (N,) [model unit]."""
        return np.array([r.norm for r in self.results])

    @property
    def f(self) -> Array:
        """f = 10·f1 − f2 per trial (eq. 10), shape (N,)."""
        return np.array([r.fitness for r in self.results])

    @property
    def evaluations(self) -> npt.NDArray[np.int64]:
        return np.array([r.evaluations for r in self.results], dtype=np.int64)

    @property
    def seconds(self) -> Array:
        return np.array([r.seconds for r in self.results])

    @property
    def histories(self) -> list[Array]:
        """Best-so-far [evaluations, f1, f2, f] of each trial, each of shape (k, 4)."""
        return [r.history if r.history is not None else np.zeros((0, 4)) for r in self.results]

    def gaps(self, exact: OptimizeResult) -> Array:
        """exact f1 − trial f1 per trial, shape (N,) [model unit]."""
        return exact.margin_after - self.f1

    def summary(self, exact: OptimizeResult) -> dict[str, float]:
        """Best / median / worst of f1, f2, f (best f1 and f are largest, best f2 smallest),
        median solutions and seconds, median and worst gap to the exact f1."""
        out: dict[str, float] = {}
        for key, values, larger in (("f1", self.f1, True), ("f2", self.f2, False), ("f", self.f, True)):
            out[f"{key}_best"] = float(values.max() if larger else values.min())
            out[f"{key}_median"] = float(np.median(values))
            out[f"{key}_worst"] = float(values.min() if larger else values.max())
        gaps = self.gaps(exact)
        out["gap_median"] = float(np.median(gaps))
        out["gap_worst"] = float(gaps.max())
        out["evaluations"] = float(np.median(self.evaluations))
        out["seconds"] = float(np.median(self.seconds))
        return out


@dataclass(frozen=True, eq=False)
class Comparison:
    """Exact optimum and the seeded trials of every method on one measured part."""

    problem: CorrectionProblem
    exact: OptimizeResult
    methods: tuple[MethodTrials, ...]
    seed: int
    trials: int
    part: str = ""
    report: str = ""
    unit: str = "mm"
    skipped: Mapping[str, str] = field(default_factory=dict)
    #: What reading, matching and posing assumed or skipped (rows skipped by --lenient, angles, forecast …).
    notes: tuple[Note, ...] = ()

    def given_up_margins(self) -> dict[str, float]:
        """The dimensions the exact optimum gives up, with their margins after it (every f1 is over the others)."""
        if not self.exact.given_up:
            return {}
        m = self.problem.margins(self.exact.x)
        return {d: float(v) for d, v in zip(self.problem.dimension_ids, m, strict=True) if d in self.exact.given_up}

    def table(self) -> list[dict[str, Any]]:
        """One summary row per method (see :meth:`MethodTrials.summary`), exact first."""
        e = self.exact
        rows: list[dict[str, Any]] = [
            {
                "optimizer": "exact",
                **{
                    f"{k}_{s}": v
                    for k, v in (("f1", e.margin_after), ("f2", e.norm), ("f", e.fitness))
                    for s in ("best", "median", "worst")
                },
                "gap_median": 0.0,
                "gap_worst": 0.0,
                "evaluations": float(e.evaluations),
                "seconds": e.seconds,
            }
        ]
        rows += [{"optimizer": m.optimizer, **m.summary(e)} for m in self.methods]
        return rows

    def to_json(self) -> dict[str, Any]:
        """The ``compare --json`` object of ``../shared/spec/cli-json.md`` plus extra keys."""
        d = d_ = 9
        e = self.exact
        results: list[dict[str, Any]] = []
        for m in self.methods:
            s = m.summary(e)
            results.append(
                {
                    "optimizer": m.optimizer,
                    "margins": [round(float(v), d) for v in m.f1],
                    "norms": [round(float(v), d) for v in m.f2],
                    "fitness": [round(float(v), d) for v in m.f],
                    "gaps": [round(float(v), d) for v in m.gaps(e)],
                    "seeds": list(m.seeds),
                    "evaluations": int(s["evaluations"]),
                    "evaluations_per_trial": [int(v) for v in m.evaluations],
                    "seconds": round(s["seconds"], 6),
                    "seconds_per_trial": [round(float(v), 6) for v in m.seconds],
                    "summary": {k: round(v, d) for k, v in s.items()},
                }
            )
        return {
            "part": self.part,
            "report": self.report,
            "unit": self.unit,
            "trials": self.trials,
            "seed": self.seed,
            "margin_before": round(e.margin_before, d),
            "exact_margin": round(e.margin_after, d),
            "exact_norm": round(e.norm, d),
            "exact_fitness": round(e.fitness, d),
            "exact_status": e.status,
            "exact_bound": None if e.bound is None else round(e.bound, d),
            "exact_seconds": round(e.seconds, 6),
            "exact_given_up": {d: round(float(v), d_) for d, v in self.given_up_margins().items()},
            "results": results,
            "skipped": dict(self.skipped),
            "warnings": [str(n) for n in self.notes],  # the JSON renderer: notes become text here
        }


def over_kept(problem: CorrectionProblem, result: OptimizeResult, given_up: tuple[str, ...]) -> OptimizeResult:
    """A trial's result restated over the dimensions the exact optimum keeps (δ before, after)."""
    if not given_up:
        return result
    x = np.asarray(result.x, dtype=float)
    return dataclasses.replace(
        result,
        margin_before=problem.kept_margin(np.zeros_like(x), given_up),
        margin_after=problem.kept_margin(x, given_up),
        margin_all=result.margin_after,
    )


def compare_steps(
    problem: CorrectionProblem,
    *,
    methods: Sequence[str] = DEFAULT_METHODS,
    trials: int = 12,
    seed: int = 0,
    params: Mapping[str, Mapping[str, Any]] | None = None,
    exact: OptimizeResult | None = None,
) -> Iterator[tuple[str, int, int, Comparison]]:
    """The comparison one trial at a time (the TUI shows progress and can stop within one trial).

    Yields ``(method, step, steps, comparison so far)`` after the exact optimum and
    after every trial; the last comparison is :func:`compare_problem`'s.  Arguments as
    :func:`compare_problem`; every name and parameter is checked before the first solve.
    """
    if trials < 1:
        raise ValueError("trials must be at least 1")
    params = params or {}
    for name in methods:  # every name and parameter checked before the first trial
        get_optimizer(name, **params.get(name, {}))
    if exact is None:
        # the yardstick of the metaheuristics is the paper's objective (eqs. 8-9), which they optimise too
        exact = get_optimizer("exact", **{"objective": "paper", **params.get("exact", {})}).solve(problem)
    seeds = tuple(trial_seeds(seed, trials))
    steps = 1 + len(methods) * trials
    step = 1
    done: tuple[MethodTrials, ...] = ()
    yield "exact", step, steps, Comparison(problem=problem, exact=exact, methods=(), seed=seed, trials=trials)
    for name in methods:
        kw = dict(params.get(name, {}))
        runs: tuple[OptimizeResult, ...] = ()
        for s in seeds:
            runs = (*runs, over_kept(problem, get_optimizer(name, seed=s, **kw).solve(problem), exact.given_up))
            step += 1
            partial = (*done, MethodTrials(optimizer=name, seeds=seeds[: len(runs)], results=runs))
            yield name, step, steps, Comparison(problem=problem, exact=exact, methods=partial, seed=seed, trials=trials)
        done = (*done, MethodTrials(optimizer=name, seeds=seeds, results=runs))


def compare_problem(
    problem: CorrectionProblem,
    *,
    methods: Sequence[str] = DEFAULT_METHODS,
    trials: int = 12,
    seed: int = 0,
    params: Mapping[str, Mapping[str, Any]] | None = None,
    exact: OptimizeResult | None = None,
) -> Comparison:
    """Solve ``problem`` exactly once and with ``trials`` seeded runs of each method.

    Parameters
    ----------
    problem : CorrectionProblem
    methods : sequence of str
        Registered optimiser names; an unknown name or parameter is refused
        (:class:`~setupfix.core.errors.ParameterError`) before any trial runs.
    trials : int
        Runs per method (the paper: 12).
    seed : int
        Root of the per-trial seeds (:func:`trial_seeds`).
    params : mapping name → hyper-parameters, optional
        Overrides of the paper's defaults, e.g. ``{"pso": {"n_solutions": 2000}}``.
    exact : OptimizeResult, optional
        A yardstick already solved for this problem.
    """
    *_, (_, _, _, last) = compare_steps(problem, methods=methods, trials=trials, seed=seed, params=params, exact=exact)
    return last


def compare_report(request: CompareRequest, report: str | Path) -> Comparison:
    """Compare the methods on one cycle of a report (the first one unless the cycles' ``part`` names it).

    The report is read and the problem posed by ``correct``'s own steps
    (:func:`setupfix.usecases.correct.read_cycles`, :func:`setupfix.usecases.correct.pose_cycle`:
    the smoothing and stand-ins of the history, the current offsets' cumulative bounds, the
    model's forecast, relations, guard band and register costs), so the exact result is
    ``correct``'s raw optimum on the same inputs.
    """
    correct = request.correct_request()
    source, _, parts = read_cycles(correct, report)
    measured = parts[0]
    posed = pose_cycle(correct, measured)
    result = compare_problem(
        posed.guarded,
        methods=request.methods,
        trials=request.trials,
        seed=request.seed,
        params={**request.params, "exact": request.exact_params(correct)},
    )
    return dataclasses.replace(
        result,
        part=measured.part,
        report=measured.report or source.name,
        unit=correct.model.unit,
        notes=(*measured.notes, *posed.notes),
    )


def plot_comparison(comparison: Comparison, path: str | Path) -> None:
    """Draw convergence (Figs. 12–15) and spread (Figs. 16–17) of a comparison to PNG or SVG."""
    from setupfix.outputs.plots import comparison_figure
    from setupfix.outputs.writers import write_figure

    e = comparison.exact
    fig = comparison_figure(
        {m.optimizer: m.histories for m in comparison.methods},
        {m.optimizer: {"f1": m.f1, "f2": m.f2, "f": m.f} for m in comparison.methods},
        exact=(e.margin_after, e.norm, e.fitness),
        unit=comparison.unit,
        title=f"{comparison.report} part {comparison.part or '—'}: {comparison.trials} trials per method",
    )
    write_figure(fig, path)
