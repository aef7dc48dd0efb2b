"""The correction problem one part poses, and the result every optimiser returns.

A multi-axis model (``../shared/spec/process-model.md``, *Multi-axis models*) enters the
problem in the same form as a one-axis one, so that every optimiser solves it unchanged:

* **rotation components** (``W1.C``, degrees, grid ``rotation_resolution`` ρ) are scaled onto the
  one register grid h: the problem's variable is u = θ·h/ρ (one rotation step = one grid step),
  its composite row C_θ·ρ/h, its bounds ±limit·h/ρ; :attr:`CorrectionProblem.scale` (ρ/h) turns
  a problem vector back into register values (:meth:`CorrectionProblem.register_values`), the one
  place corrections leave the problem;
* **circular position zones** (margin R − ‖δ + d‖) become k one-sided rows, the facets of the
  regular k-gon inscribed in the circle: n_j · (δ + d) / cos(π/k) ≤ R, j = 0 … k−1, with
  n_j = (cos 2πj/k, sin 2πj/k) in the zone's plane.  The polygon margin min_j (R − n_j·v/cos(π/k))
  is never above the circle's R − ‖v‖ and below it by at most ‖v‖ (1/cos(π/k) − 1)
  (:mod:`setupfix.correction.zones`); k is the least (≥ 8) keeping this ≤
  :data:`~setupfix.correction.zones.ZONE_TOLERANCE_MM` for every ‖v‖ ≤ R − min(0, f1),
  f1 the true error budget before the correction (every correction at least as good as none):
  :attr:`CorrectionProblem.polygon` is the bound, :attr:`CorrectionProblem.rows` maps facets to zones.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
import numpy.typing as npt

from setupfix.core.errors import Note, ParameterError
from setupfix.core.units import length_factor
from setupfix.correction.objective import correction_norm, error_budget, fitness, margins
from setupfix.correction.relation import predict_dimensions, relation_matrices
from setupfix.correction.zones import ZONE_TOLERANCE_MM, Circles, facet_rows, polygon_error, polygon_sides
from setupfix.model import PartMeasurement, ProcessModel

__all__ = ["CorrectionProblem", "OptimizeResult", "Status", "Stopped", "TriageRecord"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class CorrectionProblem:
    """Maximise the error budget of one part by register corrections.

    Only measured dimensions take part.  Fixed registers have bounds (0, 0).
    Corrections live on the grid ``resolution · k`` with integer k.

    Attributes
    ----------
    composite : ndarray of shape (n_registers, n_dimensions)
        Register → dimension matrix C restricted to the measured dimensions.
    deviation : ndarray of shape (n_dimensions,) [model unit]
        Measured deviations before correction.
    lower, upper : ndarray of shape (n_dimensions,) [model unit]
        Tolerance limits as signed deviations.
    lb, ub : ndarray of shape (n_registers,) [model unit]
        Bounds of each correction (both 0 for a fixed register).
    resolution : float [model unit]
        Register grid step.
    register_ids, dimension_ids : tuple of str
        Labels of rows and columns of ``composite``.
    cost : ndarray of shape (n_registers,), optional
        Weight of each register in the least-norm stage of the exact optimiser
        (minimise Σ cost_i·x_i² among equally good corrections; eq. 9 is all ones,
        the default).  Positive and finite: a larger cost moves that register less.
    floor : ndarray of shape (n_dimensions,), optional [model unit]
        No harm: the least margin each dimension must keep after any correction, −inf where
        none.  Default (None): 0 on the dimensions whose deviation is inside their limits,
        −inf on the others (:attr:`held_floor`).  Where the guard band shrinks the limits,
        :func:`setupfix.correction.pose.pose_policy` sets −(the shrink) on the dimensions measured inside
        the real limits, so "margin ≥ floor" keeps them inside those.  Only the exact optimiser's
        triage reads it (when every dimension can be brought in, no floor binds).
    scale : ndarray of shape (n_registers,), optional
        Register value per problem unit: ρ/h for a rotation component (degrees per grid step
        over h), 1 for everything else (module docstring); None: all ones.
    rows : tuple of str, optional
        The model dimension each column stands for (a position zone's facets all name the
        zone); None: ``dimension_ids``.
    polygon : float [model unit]
        Bound on the zones' polygon error (module docstring); 0 without zones.
    circles : Circles, optional
        The position zones themselves (true margins, :meth:`dimension_table`).
    """

    composite: Array
    deviation: Array
    lower: Array
    upper: Array
    lb: Array
    ub: Array
    resolution: float
    register_ids: tuple[str, ...]
    dimension_ids: tuple[str, ...]
    cost: Array = field(default=None)  # type: ignore[arg-type]  # set to ones in __post_init__
    floor: Array | None = None
    scale: Array | None = None
    rows: tuple[str, ...] | None = None
    polygon: float = 0.0
    circles: Circles | None = None

    def __post_init__(self) -> None:
        n = self.n_registers
        if self.floor is not None:
            floor = np.asarray(self.floor, dtype=float)
            if floor.shape != self.deviation.shape or np.any(np.isnan(floor)) or np.any(floor > 0):
                raise ParameterError(
                    f"no-harm floor must be {self.deviation.size} numbers ≤ 0 (−inf: none), got {self.floor!r}"
                )
            object.__setattr__(self, "floor", floor)
        cost = np.ones(n) if self.cost is None else np.asarray(self.cost, dtype=float)
        if cost.shape != (n,) or not np.all(np.isfinite(cost)) or not np.all(cost > 0):
            raise ParameterError(f"register cost must be {n} positive finite numbers, got {self.cost!r}")
        object.__setattr__(self, "cost", cost)

    @classmethod
    def from_part(cls, model: ProcessModel, part: PartMeasurement, composite: Array | None = None) -> CorrectionProblem:
        """The problem of one measured part of ``model``: eqs. 3–4 on its measured dimensions.

        Composite C of the model (or ``composite``, shape (n_registers, n_dimensions), in
        register units), the part's deviations, the tolerance limits, the register limits
        snapped onto the grid as bounds ((0, 0) for a fixed register) and the registers' costs
        (``[wks.ID] cost``: weights of f2, eq. 9); rotations scaled and zones as facets (module
        docstring).  Every safety step (smoothing, forecast, guard band …) is
        :func:`setupfix.correction.pose.pose_problem`'s.
        """
        rel = relation_matrices(model)
        comp = rel.composite if composite is None else np.asarray(composite, dtype=float)
        h = model.resolution
        scale = np.array([model.resolution_of(r) / h for r in model.registers])
        limits = np.array([[-r.limit, r.limit] if not r.fixed else [0.0, 0.0] for r in model.registers])
        limits = limits / scale[:, None]
        # Bounds are snapped inwards onto the grid so that every grid point inside is allowed.
        lb = np.ceil(limits[:, 0] / h - 1e-9) * h
        ub = np.floor(limits[:, 1] / h + 1e-9) * h
        comp = comp * scale[:, None] if np.any(scale != 1.0) else comp
        zone = part.zone
        is_zone = np.array([d.zone for d in model.dimensions], dtype=bool)
        keep = part.measured
        if zone is not None and is_zone.any():
            keep = keep & ~(is_zone & np.isnan(zone).any(axis=1))
        problem = cls(
            composite=comp[:, keep],
            deviation=part.deviation[keep].copy(),
            lower=np.array([d.lower for d, k in zip(model.dimensions, keep, strict=True) if k]),
            upper=np.array([d.upper for d, k in zip(model.dimensions, keep, strict=True) if k]),
            lb=lb,
            ub=ub,
            resolution=h,
            register_ids=tuple(model.register_ids),
            dimension_ids=tuple(d.id for d, k in zip(model.dimensions, keep, strict=True) if k),
            cost=np.array([r.policy.cost for r in model.registers], dtype=float),
            scale=scale if np.any(scale != 1.0) else None,
        )
        if not (is_zone & keep).any() or zone is None or rel.zones is None:
            return problem
        return problem._with_facets(model, zone, rel.zones * scale[:, None, None], keep)

    def _with_facets(
        self, model: ProcessModel, zone: Array, zones: Array, keep: npt.NDArray[np.bool_]
    ) -> CorrectionProblem:
        """Each kept zone column replaced by the rows of its inscribed polygon (module docstring)."""
        dims = [d for d, k in zip(model.dimensions, keep, strict=True) if k]
        index = np.flatnonzero(keep)
        is_zone = np.array([d.zone for d in dims], dtype=bool)
        radius = np.array([d.upper for d in dims])
        true = np.where(is_zone, radius - self.deviation, margins(self.deviation, self.lower, self.upper))
        before = min(0.0, float(np.min(true)))
        tolerance = ZONE_TOLERANCE_MM * length_factor("mm", model.unit)
        cols, devs, lows, ups, ids, rows = [], [], [], [], [], []
        sides_of: list[int] = []
        bound = 0.0
        for i, dim in enumerate(dims):
            if not dim.zone:
                cols.append(self.composite[:, i : i + 1])
                devs.append(self.deviation[i : i + 1])
                lows.append(self.lower[i : i + 1])
                ups.append(self.upper[i : i + 1])
                ids.append(dim.id)
                rows.append(dim.id)
                continue
            reach = radius[i] - before
            sides = polygon_sides(reach, tolerance)
            bound = max(bound, polygon_error(reach, sides))
            sides_of.append(sides)
            dev, col = facet_rows(zone[index[i]], zones[:, index[i], :], sides)
            cols.append(col)
            devs.append(dev)
            lows.append(np.full(sides, -np.inf))
            ups.append(np.full(sides, radius[i]))
            ids += [f"{dim.id}#{j}" for j in range(sides)]
            rows += [dim.id] * sides
        z = index[is_zone]
        circles = Circles(
            tuple(d.id for d in dims if d.zone), zone[z].copy(), zones[:, z, :].copy(), radius[is_zone], tuple(sides_of)
        )
        return replace(
            self,
            composite=np.hstack(cols),
            deviation=np.concatenate(devs),
            lower=np.concatenate(lows),
            upper=np.concatenate(ups),
            dimension_ids=tuple(ids),
            rows=tuple(rows),
            polygon=float(bound),
            circles=circles,
        )

    def dimension_of(self, ids: tuple[str, ...] | list[str]) -> tuple[str, ...]:
        """The model dimensions of problem columns (a zone's facets → the zone), each once, in order."""
        if self.rows is None:
            return tuple(ids)
        of = dict(zip(self.dimension_ids, self.rows, strict=True))
        return tuple(dict.fromkeys(of.get(i, i) for i in ids))

    def dimension_table(self, x: Array) -> tuple[tuple[str, ...], Array, Array, Array, Array, Array]:
        """Per model dimension (a zone once, as the circle): IDs, deviation, predicted, lower, upper, margin.

        A zone's deviation and predicted value are radial distances ‖δ‖, ‖δ + d‖ ≥ 0 with limits
        0 and its radius (``../shared/spec/cli-json.md``), its margin R − ‖δ + d‖ (the circle's,
        not the polygon's); other dimensions as :meth:`predicted` and :meth:`margins` give them.

        Returns
        -------
        ids : tuple of str
        deviation, predicted, lower, upper, margin : ndarrays of shape (n,) [unit]
        """
        predicted = self.predicted(x)
        if self.rows is None or self.circles is None:
            return (
                self.dimension_ids,
                self.deviation,
                predicted,
                self.lower,
                self.upper,
                margins(predicted, self.lower, self.upper),
            )
        ids = self.dimension_of(self.dimension_ids)
        first = {r: i for i, r in reversed(list(enumerate(self.rows)))}
        cols = np.array([first[d] for d in ids])
        dev, pred = self.deviation[cols].copy(), predicted[cols].copy()
        lower, upper = self.lower[cols].copy(), self.upper[cols].copy()
        where = {d: i for i, d in enumerate(ids)}
        at = np.array([where[z] for z in self.circles.ids])
        dev[at] = self.circles.distance(np.zeros(self.n_registers))
        pred[at] = self.circles.distance(x)
        lower[at] = 0.0
        margin = margins(pred, lower, upper)
        margin[at] = upper[at] - pred[at]
        return ids, dev, pred, lower, upper, margin

    def dimension_budget(self, x: Array, given_up: tuple[str, ...] = ()) -> tuple[float, Array]:
        """Error budget over the model dimensions not given up and every dimension's margin (zones: circles)."""
        ids, _, _, _, _, m = self.dimension_table(x)
        gone = set(self.dimension_of(list(given_up)))
        keep = np.array([d not in gone for d in ids], dtype=bool)
        return (float(m[keep].min()) if keep.any() else float("inf")), m

    def register_values(self, x: Array) -> Array:
        """Register values of problem vectors x (rotations back to degrees), shape of x."""
        x = np.asarray(x, dtype=float)
        return x if self.scale is None else x * self.scale

    @property
    def n_registers(self) -> int:
        return int(self.composite.shape[0])

    @property
    def free(self) -> npt.NDArray[np.bool_]:
        """Mask of the registers that may move, shape (n_registers,)."""
        return self.ub > self.lb

    @property
    def kmin(self) -> npt.NDArray[np.int64]:
        """Lower grid index of each register: lb = resolution · kmin."""
        return np.rint(self.lb / self.resolution).astype(np.int64)

    @property
    def kmax(self) -> npt.NDArray[np.int64]:
        return np.rint(self.ub / self.resolution).astype(np.int64)

    def predicted(self, x: Array) -> Array:
        """Deviations after corrections x: measured + x · C (eqs. 3–4).

        x : ndarray of shape (..., n_registers) → ndarray of shape (..., n_dimensions)
        """
        return self.deviation + predict_dimensions(x, self.composite)

    def margins(self, x: Array) -> Array:
        """Per-dimension margins after x, shape (..., n_dimensions)."""
        return margins(self.predicted(x), self.lower, self.upper)

    def evaluate(self, x: Array) -> tuple[Array, Array, Array]:
        """f1 (eq. 8), f2 (eq. 9) and f = 10·f1 − f2 (eq. 10) of corrections x.

        Parameters
        ----------
        x : ndarray of shape (..., n_registers) [model unit]

        Returns
        -------
        f1, f2, f : ndarrays of shape (...)
        """
        x = np.asarray(x, dtype=float)
        f1 = error_budget(self.predicted(x), self.lower, self.upper)
        f2 = correction_norm(x)
        return f1, f2, fitness(f1, f2)

    def snap(self, x: Array) -> Array:
        """Round corrections onto the register grid and clip them into bounds."""
        h = self.resolution
        return np.clip(np.rint(np.asarray(x, dtype=float) / h) * h, self.lb, self.ub)

    def sample(self, rng: np.random.Generator, count: int) -> Array:
        """``count`` start points drawn uniformly in the bounds and snapped to the grid.

        Returns
        -------
        ndarray of shape (count, n_registers) [model unit]
        """
        return self.snap(rng.uniform(self.lb, self.ub, size=(count, self.n_registers)))

    @property
    def held_floor(self) -> Array:
        """The no-harm floor of every dimension, shape (n_dimensions,) [model unit] (see ``floor``)."""
        if self.floor is not None:
            return self.floor
        inside = (self.deviation >= self.lower) & (self.deviation <= self.upper)
        return np.where(inside, 0.0, -np.inf)

    def kept_margin(self, x: Array, given_up: tuple[str, ...] = ()) -> float:
        """Error budget f1 (eq. 8) over the dimensions not in ``given_up`` (+inf when none is left)."""
        keep = np.array([d not in given_up for d in self.dimension_ids], dtype=bool)
        m = self.margins(np.asarray(x, dtype=float))
        return float(m[keep].min()) if keep.any() else float("inf")

    @property
    def margin_before(self) -> float:
        return float(error_budget(self.deviation, self.lower, self.upper))

    def binding(self, x: Array, tol: float | None = None) -> tuple[str, ...]:
        """IDs of the dimensions whose margin after x equals the budget (within tol).

        These are the constraints that stop a better correction; the default
        tolerance is a quarter of the register resolution.
        """
        tol = self.resolution / 4 if tol is None else tol
        m = self.margins(x)
        return tuple(d for d, v in zip(self.dimension_ids, m, strict=True) if v <= m.min() + tol)


#: What a result's ``status`` says (every value some result is built with):
#:
#: * ``"optimal"``: proved (the exact optimiser; also its refusals and its triage, proved);
#: * ``"time_limit"``: the exact optimiser stopped at a limit (``stopped`` says where and which: "work limit",
#:   the settings' work budget, the same under any load; "time limit", the wall-clock guard against a
#:   hang, and then x = 0: no correction);
#: * ``"solver_error"``: the exact optimiser stopped by a solver failure (``stopped`` says where);
#: * ``"budget"``: a metaheuristic spent its solution budget;
#: * ``"no_better_than_none"``: the search found nothing better than no correction (x = 0 returned,
#:   :func:`setupfix.optimize.base.make_result`);
#: * ``"draft"``, ``"rejected"``, ``"setup_error"``: nothing was solved (x = 0): a draft model holds,
#:   the part is beyond the reject band, or it shows a setup error
#:   (:mod:`setupfix.correction.recommend`).
Status = Literal[
    "optimal", "time_limit", "solver_error", "budget", "no_better_than_none", "draft", "rejected", "setup_error"
]


@dataclass(frozen=True)
class Stopped:
    """The stage that stopped a solve before its proof, and why (``correct --json``'s ``stopped``).

    Attributes
    ----------
    stage : str
        ``"lp bound"``, ``"grid optimum"``, ``"leximin"``, ``"least norm"`` or ``"triage"``.
    reason : str
        ``"work limit"`` (the settings' work budget: the same under any load), ``"time limit"`` (the
        wall-clock guard against a hang: then no correction is given) or what the solver said.
    detail : str, optional
        The triage's own words on what stopped (its step and reason); None for the other stages.
    """

    stage: str
    reason: str
    detail: str | None = None

    def to_json(self) -> dict[str, str]:
        """``{"stage", "reason"[, "detail"]}``, as ``correct --json`` writes it."""
        out = {"stage": self.stage, "reason": self.reason}
        if self.detail is not None:
            out["detail"] = self.detail
        return out


@dataclass(frozen=True)
class TriageRecord:
    """What the exact optimiser's triage decided (no correction brings every dimension in).

    Attributes
    ----------
    refused : bool
        Not even the dimensions measured in tolerance can all be kept: no correction.
    kept, held : int
        Model dimensions kept in tolerance, and those among them measured in tolerance (held).
    lp_bound_all : float [model unit]
        The LP bound of the whole problem, given-up dimensions included (the result's ``bound``
        is the kept dimensions').
    leximin_levels : int
        Leximin levels of the kept margins proved (0 when refused).
    leximin_complete : bool
        Every kept margin's level proved (False when refused).
    given_up : mapping of str to float [model unit]
        Each model dimension given up, once, with its margin after the correction (a position
        zone's: the circle's).
    """

    refused: bool
    kept: int
    held: int
    lp_bound_all: float
    leximin_levels: int = 0
    leximin_complete: bool = False
    given_up: Mapping[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class OptimizeResult:
    """What every optimiser returns (frozen: built once, by :func:`setupfix.optimize.base.make_result`).

    Attributes
    ----------
    x : ndarray of shape (n_registers,) [model unit]
        Corrections on the register grid.
    margin_before, margin_after : float
        Error budget δ = f1 before and after the correction; over the dimensions kept when some
        are given up (``given_up``: the triage's margins of those are in ``triage.given_up``).
    norm : float
        f2 = ‖x‖.
    optimizer : str
    evaluations : int
        Candidate solutions evaluated (metaheuristics) or solver calls (exact).
    seconds : float
        Wall time of the search.
    status : Status
        One of :data:`Status`: ``"optimal"`` (proved), ``"time_limit"`` or ``"solver_error"``
        (the exact optimiser stopped; ``stopped`` says where), ``"budget"`` (a metaheuristic spent
        its solution budget), ``"no_better_than_none"`` (nothing better than no correction found,
        x = 0), ``"draft"``, ``"rejected"`` or ``"setup_error"`` (nothing solved, x = 0).
    message : str
        One sentence for the operator.
    binding : tuple of str
        Dimensions at the minimum margin after correction.
    history : ndarray of shape (k, 4), optional
        Best-so-far [evaluations, f1, f2, f] for convergence plots.
    bound : float, optional
        Upper bound on f1 proved by the exact solver (continuous LP optimum; over the dimensions
        kept when some are given up).
    given_up : tuple of str
        Dimensions the exact optimiser gave up on because no correction brings every
        dimension into tolerance (it keeps as many as possible in tolerance first);
        they need the NC program or the process, not the setup.  Empty for the
        metaheuristics.
    notes : tuple of Note
        Warnings as data (solver retries, limits hit), never ``warnings.warn``.
    stopped : Stopped, optional
        The exact optimiser's stage that stopped before its proof and why (None: nothing stopped).
    norm_ratio_max : float, optional
        Certified bound on ‖x‖²_cost / least norm when the least-norm proof was stopped (may be
        inf: no bound); None when not stated.
    triage : TriageRecord, optional
        The exact optimiser's triage (None when it did not run).
    leximin : tuple of (float, int)
        The exact optimiser's leximin levels, lowest first: (margin [model unit], how many
        dimensions at it); empty for the paper's objective and the other optimisers.
    path : str
        The exact optimiser's steps, ``"; "``-separated (which proof decided each stage).
    stages : mapping of str to float
        The exact optimiser's wall time per stage [s].
    margin_all : float, optional
        ``compare``: a trial's error budget over every dimension, when ``margin_after`` is
        restated over the dimensions the exact optimum keeps.
    work : float
        The exact optimiser's work units spent (HiGHS iterations, nodes × ``node_work``:
        :mod:`setupfix.optimize.exact.work`); 0 for the other optimisers.
    """

    x: Array
    margin_before: float
    margin_after: float
    norm: float
    optimizer: str
    evaluations: int
    seconds: float
    status: Status
    message: str = ""
    binding: tuple[str, ...] = ()
    history: Array | None = None
    bound: float | None = None
    given_up: tuple[str, ...] = ()
    notes: tuple[Note, ...] = ()
    stopped: Stopped | None = None
    norm_ratio_max: float | None = None
    triage: TriageRecord | None = None
    leximin: tuple[tuple[float, int], ...] = ()
    path: str = ""
    stages: Mapping[str, float] = field(default_factory=dict)
    margin_all: float | None = None
    work: float = 0.0

    @property
    def bonus(self) -> float:
        """Bonus error budget b = δ after − δ before."""
        return self.margin_after - self.margin_before

    @property
    def fitness(self) -> float:
        """f = 10·f1 − f2 of the result (eq. 10)."""
        return float(fitness(self.margin_after, self.norm))

    @property
    def in_tolerance(self) -> bool:
        """True when every measured dimension is predicted inside its limits (none given up)."""
        return self.margin_after >= 0.0 and not self.given_up
