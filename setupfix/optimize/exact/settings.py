"""Settings of the exact optimiser: which proof is tried, how much it may list, how work is shared.

One frozen, validated :class:`ExactSettings` replaces the module constants the solver
used to read; an :class:`~setupfix.optimize.exact.solve.ExactOptimizer` takes one
(``settings=``), so a test or a bench that wants a fallback path (no listing, no NNLS …)
passes settings instead of patching globals.  None of these values changes *what* is
proved optimal — only which proof gets there and how fast; the defaults are the
measured ones (``bench/exact_per_report.py``, ``bench/exact_scaling.py``).

Units: counts are points, array elements, registers, rows or chords; shares are
fractions of the work budget in (0, 1]; ``quantum`` is a fraction of the register resolution.
The budget is work, not time (:mod:`setupfix.optimize.exact.work`): which stage ends, and where,
never depends on the machine's load; the wall-clock ``time_limit`` of the optimiser only guards
against a hang.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import ClassVar

from setupfix.core.params import Constraint, Interval, Predicate, validate_params

__all__ = ["ExactSettings"]

_COUNT: list[Constraint] = [Interval(int, 0, None)]
_SHARE: list[Constraint] = [Interval(float, 0.0, 1.0, closed="right")]
_FRACTION: list[Constraint] = [Interval(float, 0.0, 1.0, closed="left")]


@dataclass(frozen=True)
class ExactSettings:
    """How the exact optimiser chooses among its proofs (every field validated on creation).

    Attributes
    ----------
    work_limit : float
        Work units the whole solve may spend [HiGHS simplex/IPM/QP iterations; a MIP node counts
        ``node_work``]: the stages' shares (every ``*_share`` below, ``descent_reserve``) are of it.
        Generous: every bundled sample finishes on its proved optimum well within it
        (``bench/work_limits.py``).
    node_work : float
        Work units one branch-and-bound node counts (HiGHS's node limit is the allowance / this).
    quantum : float
        Deviations are rounded to this fraction of the register resolution before solving
        (1e-3: 1 nm on a 0.001 mm grid), so the answer does not depend on their last bits.
    ellipsoid_max_registers : int
        Most free registers for which the least-norm proof lists the grid points of the
        dual ellipsoid (eq. 9 by exhaustion).
    enumeration_limit, enumeration_work : int
        Largest list of (partial) integer points per coordinate, and most array elements
        touched in all, that the least-norm listing may use before the MILPs take over.
    box_proof_max_registers, box_proof_max_chords : int
        The least-norm proof in the Lagrangian box is one MILP with every chord up to these
        sizes; beyond, chords of k² are added lazily.
    nnls_max_rows : int
        Largest constraint count (rows + 2·registers) whose continuous least-norm point is
        found by NNLS on the whole system.
    working_set_nnls : bool
        Larger problems: NNLS on a working set of rows (False: HiGHS's QP solver at once).
    box_share, stopped_box_share : float
        Share of the work left that each box MILP around the rounded continuous point may
        use in the least-norm stage (the second when the grid-optimum stage was stopped).
    incumbent_gap : float
        Relative gap at which those box MILPs stop (they look for an incumbent).
    descent_reserve : float
        Share of the whole work limit kept back for coordinate descent when a least-norm
        proof stops at the limit.
    search_limit, search_work : int
        Limits of the grid-optimum stage's listing of the ellipsoids around the rounded
        rows' least-norm point (as ``enumeration_limit``/``enumeration_work``).
    ipm_min_rows : int
        An LP with more rows than this is solved by HiGHS's interior-point method (with
        crossover: the duals are a basis').
    milp_share : float
        Share of the grid-optimum stage's work that one feasibility MILP may use.
    leximin_norm_share : float
        Share of the whole work limit kept for the least-norm stage after the leximin levels
        (smaller than ``least_norm_share``: with every dimension at its floor the least norm is
        confined to a small region and usually listed at once).
    least_norm_share : float
        Share of the whole work limit kept for the least-norm stage.
    level_steps : int
        Levels the grid-optimum stage may descend by rounded rows before the bracketed MILP.
    network_lp : bool
        Least-norm stage: where the rows are a network matrix (every dimension one WKS and one
        tool), one LP over the chords first (integral, so exact); False: the listing and MILPs only.
    climb_max_registers : int
        Most free registers for which the leximin levels climb the grid from a level's point
        (small problems only; its two-register moves are 2·n·(n − 1) points).
    climb_scales : tuple of float
        Move sizes of that climb, largest first [steps, each ≥ 1]; each climbs until no move improves.
    max_branches : int
        Most branches the leximin levels open at discrete conflicts before the counts decide.
    max_pair_tests : int
        Most pairs of dimensions a discrete conflict tests before the counts decide (0: none).
    tight_slack : float
        The leximin point tests' first MILP holds only the rows within this many steps of the LP's
        vertex (a large value: every row at once).
    triage_list_points : int
        Most grid points × margin rows the triage lists (the whole box, or its least-norm box)
        instead of solving MILPs (0: never listed).
    forced_triage : bool
        The triage first tries the forced kept set before its MILPs (False: the MILPs decide).
    forced_share : float
        Share of the work left that proving the kept set forced may take.
    triage_leximin_share : float
        Share of the whole work limit the triage's leximin levels after the first may take (never
        the work reserved for the least norm; 0: level 1 only).
    link_count_blocks : bool
        The leximin count MILPs link their nested blocks' binaries (w_i,q ≤ w_(i−1),q;
        ``bench/leximin_counts.py`` compares without).
    """

    work_limit: float = 1_000_000.0
    node_work: float = 50.0
    quantum: float = 1e-3
    ellipsoid_max_registers: int = 120
    enumeration_limit: int = 20_000
    enumeration_work: int = 400_000
    box_proof_max_registers: int = 40
    box_proof_max_chords: int = 20_000
    nnls_max_rows: int = 600
    working_set_nnls: bool = True
    box_share: float = 0.25
    stopped_box_share: float = 0.8
    incumbent_gap: float = 1e-4
    descent_reserve: float = 0.03
    search_limit: int = 20_000
    search_work: int = 400_000
    ipm_min_rows: int = 2000
    milp_share: float = 0.5
    least_norm_share: float = 0.5
    leximin_norm_share: float = 0.15
    level_steps: int = 40
    network_lp: bool = True
    climb_max_registers: int = 24
    climb_scales: tuple[float, ...] = (4.0, 1.0)
    max_branches: int = 24
    max_pair_tests: int = 60
    tight_slack: float = 2.0
    triage_list_points: int = 4_000_000
    forced_triage: bool = True
    forced_share: float = 0.25
    triage_leximin_share: float = 0.45
    link_count_blocks: bool = True

    _constraints: ClassVar[dict[str, list[Constraint]]] = {
        "work_limit": [Interval(float, 0.0, None, closed="neither")],
        "node_work": [Interval(float, 0.0, None, closed="neither")],
        "quantum": [Interval(float, 0.0, 1.0, closed="right")],
        "ellipsoid_max_registers": _COUNT,
        "enumeration_limit": _COUNT,
        "enumeration_work": _COUNT,
        "box_proof_max_registers": _COUNT,
        "box_proof_max_chords": _COUNT,
        "nnls_max_rows": _COUNT,
        "working_set_nnls": [bool],
        "box_share": _SHARE,
        "stopped_box_share": _SHARE,
        "incumbent_gap": _FRACTION,
        "descent_reserve": _FRACTION,
        "search_limit": _COUNT,
        "search_work": _COUNT,
        "ipm_min_rows": _COUNT,
        "milp_share": _SHARE,
        "least_norm_share": _FRACTION,
        "leximin_norm_share": _FRACTION,
        "level_steps": _COUNT,
        "network_lp": [bool],
        "climb_max_registers": _COUNT,
        "climb_scales": [
            Predicate(
                lambda v: isinstance(v, tuple) and len(v) > 0 and all(math.isfinite(s) and s >= 1 for s in v),
                "a tuple of step sizes ≥ 1, largest first",
            )
        ],
        "max_branches": _COUNT,
        "max_pair_tests": _COUNT,
        "tight_slack": [Interval(float, 0.0, None)],
        "triage_list_points": _COUNT,
        "forced_triage": [bool],
        "forced_share": _SHARE,
        "triage_leximin_share": _FRACTION,
        "link_count_blocks": [bool],
    }

    def __post_init__(self) -> None:
        validate_params("ExactSettings", asdict(self), self._constraints)
