"""The correction problem one part poses, and the result every optimiser returns."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from setupfix.errors import Note, ParameterError
from setupfix.model import PartMeasurement, ProcessModel
from setupfix.objective import correction_norm, error_budget, fitness, margins
from setupfix.relation import predict_dimensions, relation_matrices

__all__ = ["CorrectionProblem", "OptimizeResult"]

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
        :func:`setupfix.pose.pose_policy` sets −(the shrink) on the dimensions measured inside
        the real limits, so "margin ≥ floor" keeps them inside those.  Only the exact optimiser's
        triage reads it (when every dimension can be brought in, no floor binds).
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

    def __post_init__(self) -> None:
        n = self.n_registers
        if self.floor is not None:
            floor = np.asarray(self.floor, dtype=float)
            if floor.shape != self.deviation.shape or np.any(np.isnan(floor)) or np.any(floor > 0):
                raise ParameterError(f"no-harm floor must be {self.deviation.size} numbers ≤ 0 (−inf: none), "
                                     f"got {self.floor!r}")
            object.__setattr__(self, "floor", floor)
        cost = np.ones(n) if self.cost is None else np.asarray(self.cost, dtype=float)
        if cost.shape != (n,) or not np.all(np.isfinite(cost)) or not np.all(cost > 0):
            raise ParameterError(f"register cost must be {n} positive finite numbers, got {self.cost!r}")
        object.__setattr__(self, "cost", cost)

    @classmethod
    def from_part(cls, model: ProcessModel, part: PartMeasurement) -> CorrectionProblem:
        """The problem of one measured part of ``model``: eqs. 3–4 on its measured dimensions.

        Composite C of the model, the part's deviations, the tolerance limits, the
        register limits snapped onto the grid as bounds ((0, 0) for a fixed register)
        and the registers' costs (``[wks.ID] cost``: weights of f2, eq. 9).  Every
        safety step (smoothing, forecast, guard band …) is
        :func:`setupfix.pose.pose_problem`'s.
        """
        comp = relation_matrices(model).composite
        keep = part.measured
        dims = [d for d, k in zip(model.dimensions, keep, strict=True) if k]
        limits = np.array([[-r.limit, r.limit] if not r.fixed else [0.0, 0.0] for r in model.registers])
        # Bounds are snapped inwards onto the grid so that every grid point inside is allowed.
        h = model.resolution
        lb = np.ceil(limits[:, 0] / h - 1e-9) * h
        ub = np.floor(limits[:, 1] / h + 1e-9) * h
        return cls(
            composite=comp[:, keep],
            deviation=part.deviation[keep].copy(),
            lower=np.array([d.lower for d in dims]),
            upper=np.array([d.upper for d in dims]),
            lb=lb,
            ub=ub,
            resolution=h,
            register_ids=tuple(model.register_ids),
            dimension_ids=tuple(d.id for d in dims),
            cost=np.array([r.policy.cost for r in model.registers], dtype=float),
        )

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


@dataclass
class OptimizeResult:
    """What every optimiser returns.

    Attributes
    ----------
    x : ndarray of shape (n_registers,) [model unit]
        Corrections on the register grid.
    margin_before, margin_after : float
        Error budget δ = f1 before and after the correction; over the dimensions kept when some
        are given up (``given_up``: the triage's margins of those are in ``extra["given_up"]``).
    norm : float
        f2 = ‖x‖.
    optimizer : str
    evaluations : int
        Candidate solutions evaluated (metaheuristics) or solver calls (exact).
    seconds : float
        Wall time of the search.
    status : str
        ``"optimal"`` (proved), ``"time_limit"``, ``"rounded"`` (exact fallback) or
        ``"budget"`` (metaheuristic spent its solution budget).
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
    """

    x: Array
    margin_before: float
    margin_after: float
    norm: float
    optimizer: str
    evaluations: int
    seconds: float
    status: str
    message: str = ""
    binding: tuple[str, ...] = ()
    history: Array | None = None
    bound: float | None = None
    extra: dict[str, object] = field(default_factory=dict)
    given_up: tuple[str, ...] = ()
    notes: tuple[Note, ...] = ()

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
