"""Requests and outcomes of the ``correct`` use case: typed, frozen, the same through every door.

The CLI, batch, the TUI and the diagnosis build a :class:`CorrectRequest` and call
:func:`setupfix.usecases.correct.correct_report` (a report) or
:func:`~setupfix.usecases.correct.correct_cycle` (one cycle); they get a
:class:`CorrectOutcome` / :class:`CycleCorrection` back and render it
(:mod:`setupfix.views.present`) or export it (:mod:`setupfix.usecases.export`).
Every request is picklable (batch sends it to worker processes).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from setupfix.core.errors import MatchError, Note, ParameterError, SourceLocation
from setupfix.correction.conformance import conformance_rows
from setupfix.correction.pose import PosedProblem
from setupfix.correction.safety import Recommendation, RuleEffect
from setupfix.correction.zones import cmm_position
from setupfix.inputs.cycles import ReadOptions
from setupfix.inputs.smoothing import History
from setupfix.model import PartMeasurement, ProcessModel
from setupfix.optimize import OPTIMIZERS, CorrectionProblem, OptimizeResult, get_optimizer

if TYPE_CHECKING:  # the thermal modules bring scipy.signal (~0.5 s): loaded only with --thermal
    from parsers.temperature import TemperatureLog
    from setupfix.links.snapshot import ControlSnapshot
    from setupfix.thermal.persist import SavedModel
    from setupfix.usecases.thermal_feedforward import ThermalFeedForward

__all__ = [
    "ReadOptions",
    "CycleOptions",
    "SolveOptions",
    "ThermalInputs",
    "load_thermal",
    "CurrentOffsets",
    "History",
    "CorrectRequest",
    "CycleCorrection",
    "CorrectOutcome",
]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class CycleOptions:
    """How a report's parts become fixture cycles, and which cycle to correct.

    ``stations``: the stations in part order (``("P1", "P2")``) or part → station
    pairs (``(("A7", "P1"), ("A8", "P2"))``); see :mod:`setupfix.inputs.cycles`.
    """

    stations: tuple[str, ...] | tuple[tuple[str, str], ...] | None = None
    parts_per_cycle: int | None = None
    strict: bool = False
    part: str | None = None

    @classmethod
    def of(
        cls,
        stations: Sequence[str] | Mapping[str, str] | None = None,
        *,
        parts_per_cycle: int | None = None,
        strict: bool = False,
        part: str | None = None,
    ) -> CycleOptions:
        """From a list or a mapping of stations (made hashable)."""
        st: tuple[str, ...] | tuple[tuple[str, str], ...] | None = None
        if isinstance(stations, Mapping):
            st = tuple((str(k), str(v)) for k, v in stations.items())
        elif stations is not None:
            st = tuple(str(s) for s in stations)
        return cls(st, parts_per_cycle, strict, part)

    def station_map(self) -> list[str] | dict[str, str] | None:
        """The stations as :func:`setupfix.inputs.cycles.assign_stations` takes them."""
        if self.stations is None:
            return None
        if self.stations and isinstance(self.stations[0], tuple):
            return {str(k): str(v) for k, v in self.stations}
        return [str(s) for s in self.stations]

    def kwargs(self) -> dict[str, Any]:
        """Stations, parts per cycle and strictness as keyword arguments of ``read_parts``."""
        return {"stations": self.station_map(), "parts_per_cycle": self.parts_per_cycle, "strict": self.strict}

    def select(self, parts: Sequence[PartMeasurement], report: str | Path) -> list[PartMeasurement]:
        """All cycles, or only the one named by ``part``.

        Raises
        ------
        MatchError
            If no cycle of the report has that name (the message lists the names).
        """
        if self.part is None:
            return list(parts)
        chosen = [p for p in parts if p.part == self.part]
        if not chosen:
            raise MatchError(
                f"no part {self.part!r} in the report (parts: {', '.join(p.part or '(none)' for p in parts)})",
                location=SourceLocation(str(report)),
            )
        return chosen


@dataclass(frozen=True)
class SolveOptions:
    """The optimiser: its name, seed (metaheuristics), time limit (exact only, seconds) and objective.

    ``objective``: ``"leximin"`` (every dimension centred in turn, then the least norm; the exact
    optimiser's default) or ``"paper"`` (eqs. 8–9: the smallest margin, then the least norm).  None:
    the optimiser's own (leximin for exact; the metaheuristics optimise the paper's f1, so asking
    them for leximin is refused).

    Raises
    ------
    ParameterError
        An unknown optimiser or objective, a time limit or leximin for a metaheuristic, or a time
        limit that is not a positive number.
    """

    optimizer: str = "exact"
    seed: int | None = None
    time_limit: float | None = None
    objective: str | None = None

    def __post_init__(self) -> None:
        if self.optimizer not in OPTIMIZERS:
            raise ParameterError(f"unknown optimizer {self.optimizer!r} (known: {', '.join(sorted(OPTIMIZERS))})")
        if self.time_limit is not None and self.optimizer != "exact":
            raise ParameterError(f"--time-limit applies to the exact optimizer, not {self.optimizer!r}")
        if self.objective not in (None, "leximin", "paper"):
            raise ParameterError(f"unknown objective {self.objective!r} (known: leximin, paper)")
        if self.objective == "leximin" and self.optimizer != "exact":
            raise ParameterError(
                f"--objective leximin applies to the exact optimizer; {self.optimizer!r} "
                "optimises the paper's error budget f1 (use --objective paper or omit it)"
            )
        get_optimizer(self.optimizer, seed=self.seed, **self.params())  # the optimiser's declared constraints

    @property
    def resolved_objective(self) -> str:
        """The objective the optimiser pursues (its default when none was asked for)."""
        if self.objective is not None:
            return self.objective
        return "leximin" if self.optimizer == "exact" else "paper"

    def params(self) -> dict[str, Any]:
        """The optimiser's hyper-parameters (``time_limit`` and the exact optimiser's ``objective`` when given)."""
        out: dict[str, Any] = {} if self.time_limit is None else {"time_limit": float(self.time_limit)}
        if self.objective is not None and self.optimizer == "exact":
            out["objective"] = self.objective
        return out


@dataclass(frozen=True)
class ThermalInputs:
    """The thermal feed-forward's inputs, loaded once (``--thermal``, ``--temperatures``, ``--at``, dead band)."""

    saved: SavedModel
    log: TemperatureLog
    source: str = "thermal model"
    at: str | None = None
    dead_band: float | None = None


def load_thermal(
    thermal: str | Path, temperatures: str | Path, *, at: str | None = None, dead_band: float | None = None
) -> ThermalInputs:
    """Read the thermal model (``thermal fit``) and the temperature log once.

    Raises
    ------
    SetupfixError
        Either file unreadable or invalid (named with its place).
    """
    from parsers.temperature import read_temperature_log
    from setupfix.inputs.thermal_files import load_model

    saved = load_model(thermal)
    log = read_temperature_log(temperatures, interval=saved.sample_interval_s)
    return ThermalInputs(saved, log, str(thermal), at, dead_band)


@dataclass(frozen=True)
class CurrentOffsets(Mapping[str, float]):
    """The controller's current offsets: register ID → value, and where they came from (for messages)."""

    items_: tuple[tuple[str, float], ...]
    source: str = ""
    #: Read from a control (``--link``): the control's values as read, which the plan records.
    snapshot: ControlSnapshot | None = field(default=None, compare=False)

    @classmethod
    def of(
        cls, values: Mapping[str, float], source: str = "", snapshot: ControlSnapshot | None = None
    ) -> CurrentOffsets:
        return cls(tuple((str(k), float(v)) for k, v in values.items()), source, snapshot)

    @classmethod
    def read(cls, path: str | Path, model: ProcessModel) -> CurrentOffsets:
        """Read a ``register,value`` file (:func:`parsers.current.read_current`, the one reader)."""
        from parsers.current import read_current

        return cls.of(read_current(path, model), str(path))

    def __getitem__(self, key: str) -> float:
        for k, v in self.items_:
            if k == key:
                return v
        raise KeyError(key)

    def __iter__(self) -> Iterator[str]:
        return (k for k, _ in self.items_)

    def __len__(self) -> int:
        return len(self.items_)

    def wear_totals(self, model: ProcessModel) -> dict[str, float]:
        """Change applied since the last reset of each wear register: its current value.

        A wear offset is set to 0 when the tool (or the setup) is renewed, so its value
        is the total of the corrections since; geometry registers have no such total.
        """
        return {r.id: float(self[r.id]) for r in model.registers if r.offset == "wear" and r.id in self}


@dataclass(frozen=True)
class CorrectRequest:
    """Everything ``correct`` needs besides the report: the model and every option, loaded once."""

    model: ProcessModel
    read: ReadOptions = field(default_factory=ReadOptions)
    cycles: CycleOptions = field(default_factory=CycleOptions)
    solve: SolveOptions = field(default_factory=SolveOptions)
    current: CurrentOffsets | None = None
    history: History | None = None
    thermal: ThermalInputs | None = None


@dataclass(frozen=True, eq=False)
class CycleCorrection:
    """The recommendation for one measured cycle and everything needed to show or export it.

    ``result`` is the optimiser's answer restated for the changes recommended (on the
    real limits; the raw optimum is ``recommendation.result``); every number shown
    (predicted, margins, budgets) is for the applied changes on the real tolerance
    limits of ``posed.problem``.
    """

    model: ProcessModel
    part: PartMeasurement
    posed: PosedProblem
    result: OptimizeResult
    recommendation: Recommendation
    thermal: ThermalFeedForward | None = None
    notes: tuple[Note, ...] = ()

    @property
    def problem(self) -> CorrectionProblem:
        """The problem on the real limits (estimated deviations, costs)."""
        return self.posed.problem

    @property
    def verdict(self) -> str:
        return self.recommendation.verdict

    @property
    def solved(self) -> bool:
        """False when the solve was stopped and nothing is recommended ("not solved within the time limit")."""
        return self.recommendation.solved

    @property
    def x(self) -> Array:
        """Applied changes of every register (model order) in problem units, zero unless the verdict is apply.

        A rotation component is scaled onto the problem's grid (:attr:`CorrectionProblem.scale`);
        :attr:`values` holds the register values (degrees for a rotation).
        """
        return self.recommendation.x

    @property
    def values(self) -> Array:
        """Applied changes as register values (model unit; degrees for a rotation ``W1.C``)."""
        return self.problem.register_values(self.x)

    @property
    def measured(self) -> Array | None:
        """The report's own deviations when the problem holds an estimate (smoothed, forecast), else None."""
        return self.posed.measured if self.posed.estimated else None

    @property
    def corrections(self) -> dict[str, float]:
        """Correction of every correctable register by model ID, zero included (thermal feed-forward
        added unless the verdict is reject)."""
        out = {reg.id: float(v) for v, reg in zip(self.values, self.model.registers, strict=True) if not reg.fixed}
        if self.thermal is not None and self.verdict != "reject":
            for rid, shift in self.thermal.corrections().items():
                out[rid] = out.get(rid, 0.0) + shift
        return out

    @property
    def margin_before(self) -> float:
        """δ before, over the dimensions kept (the triage's given-up ones are reported apart; zones: circles)."""
        return self.problem.dimension_budget(np.zeros_like(self.x), self.recommendation.given_up)[0]

    @property
    def margin_after(self) -> float:
        """δ after, over the dimensions kept (see :attr:`margin_all_after` for every dimension)."""
        return self.problem.dimension_budget(self.x, self.recommendation.given_up)[0]

    @property
    def margin_all_before(self) -> float:
        """δ before over every dimension, the given-up ones included: the contract's ``margin_before``."""
        return self.problem.dimension_budget(np.zeros_like(self.x))[0]

    @property
    def margin_all_after(self) -> float:
        """δ after over every dimension, the given-up ones included: the contract's ``margin_after``.

        Negative whenever any dimension (given up or not) is predicted out of tolerance, so a
        script that reads ``margin_after >= 0`` as "every dimension in" is told the truth.
        """
        return self.problem.dimension_budget(self.x)[0]

    @property
    def norm(self) -> float:
        return float(np.linalg.norm(self.x))

    @property
    def given_up(self) -> tuple[str, ...]:
        """The model dimensions given up (a zone once, never its polygon's facets)."""
        return self.problem.dimension_of(self.recommendation.given_up)

    @property
    def rules(self) -> tuple[RuleEffect, ...]:
        """The recommendation's rules with a zone's facets named by the zone."""
        if self.problem.rows is None:
            return self.recommendation.rules
        return tuple(
            dataclasses.replace(r, dimensions=self.problem.dimension_of(r.dimensions)) if r.dimensions else r
            for r in self.recommendation.rules
        )

    @property
    def binding(self) -> tuple[str, ...]:
        """The dimensions that stop a better correction (none when rejected; a zone once)."""
        return self.problem.dimension_of(self.result.binding)

    def register_rows(self) -> list[dict[str, Any]]:
        """Every register, fixed ones included: id, register, kind, offset, delta, fixed, at_limit."""
        at = set(self.recommendation.at_limit)
        return [
            {
                "id": reg.id,
                "register": reg.register,
                "kind": reg.kind,
                "offset": reg.offset,
                "delta": float(delta),
                "fixed": reg.fixed,
                "at_limit": reg.id in at,
            }
            | ({"component": reg.component} if reg.component is not None else {})
            for reg, delta in zip(self.model.registers, self.values, strict=True)
        ]

    def dimension_rows(self) -> list[dict[str, Any]]:
        """Per measured dimension: id, name, station, deviation, limits, predicted, margin, flags.

        ``flags`` lists ``out`` (predicted out of tolerance after the changes),
        ``out_before`` (out of tolerance before), ``binding``, ``given_up``, ``rejected``
        and ``guard`` (predicted inside the limits but within U of one); ``uncertainty`` (U, k = 2),
        ``uncertainty_source`` and the ISO 14253-1 verdicts ``conformance_before`` / ``_after``
        (:func:`setupfix.correction.conformance.conformance_rows`).  When the
        problem holds an estimate, ``estimate`` is it and ``deviation`` the report's.  A position
        zone's row also gives ``zone_position`` and ``zone_position_predicted``, the diameters a CMM
        prints (2 × ``deviation`` and ``predicted``, the radial distances), and ``zone_diameter``.
        """
        dims = {d.id: d for d in self.model.dimensions}
        problem = self.problem
        ids, deviation, predicted, _, _, margins = problem.dimension_table(self.x)
        binding, given_up = set(self.binding), set(problem.dimension_of(self.recommendation.given_up))
        rejected = set(
            problem.dimension_of([d for r in self.recommendation.rules if r.rule == "reject" for d in r.dimensions])
        )
        _, _, _, guard_lower, guard_upper, _ = self.recommendation.problem.dimension_table(self.x)
        if self.measured is not None:  # the report's own deviations, per model dimension
            measured: Array | None = dataclasses.replace(problem, deviation=self.measured).dimension_table(self.x)[1]
        else:
            measured = None
        rows = []
        for i, did in enumerate(ids):
            d = dims[did]
            flags = []
            if not d.lower <= deviation[i] <= d.upper:
                flags.append("out_before")
            if margins[i] < -1e-12:
                flags.append("out")
            elif not guard_lower[i] - 1e-12 <= predicted[i] <= guard_upper[i] + 1e-12:
                flags.append("guard")
            if did in binding:
                flags.append("binding")
            if did in given_up:
                flags.append("given_up")
            if did in rejected:
                flags.append("rejected")
            row: dict[str, Any] = {
                "id": did,
                "name": d.name,
                "station": d.group,
                "deviation": float(deviation[i]),
                "predicted": float(predicted[i]),
                "lower": d.lower,
                "upper": d.upper,
                "margin": float(margins[i]),
                "flags": flags,
            }
            if measured is not None:  # smoothed or forecast: the estimate is what was corrected
                row["estimate"], row["deviation"] = row["deviation"], float(measured[i])
            if d.zone:  # a position as a CMM prints it: the diameter 2‖δ‖, beside the radial margin
                row["zone_position"] = float(cmm_position(row["deviation"]))
                row["zone_position_predicted"] = float(cmm_position(row["predicted"]))
                row["zone_diameter"] = d.diameter
            rows.append(row)
        return conformance_rows(self.model, self.part, rows)


@dataclass(frozen=True, eq=False)
class CorrectOutcome:
    """One report corrected: what was read (format, hash, canonical table, reader's notes) and every cycle."""

    report: str
    format: str
    sha256: str
    table: pd.DataFrame
    cycles: tuple[CycleCorrection, ...]
    notes: tuple[Note, ...] = ()

    @property
    def rejected(self) -> tuple[CycleCorrection, ...]:
        return tuple(c for c in self.cycles if c.verdict == "reject")

    @property
    def unsolved(self) -> tuple[CycleCorrection, ...]:
        """Cycles whose solve was stopped with nothing proven to recommend (:attr:`CycleCorrection.solved`)."""
        return tuple(c for c in self.cycles if not c.solved)
