"""Exact optimum of the setup-correction problem with HiGHS (scipy ``linprog``/``milp``).

The max–min objective f1 (eq. 8) is linear in the corrections, so the problem is a
linear programme, and on the register grid a mixed-integer one.  Everything is
solved in grid units (k = x / resolution, margins in resolution steps), which
keeps the numbers near 1–100 where the solver's tolerances are meaningful.

Stages
------
1. **LP bound**: maximise t subject to every margin ≥ t and the register bounds.
   Its optimum t_LP bounds every correction, on or off the grid.
2. **Grid optimum** (MILP): the same with integer k.  The rounded LP point gives a
   lower bound; both bounds are handed to the MILP as bounds on t.
3. **Least norm**: among grid corrections with margin ≥ t*, the one of least
   Euclidean norm (eq. 9).  Minimising Σ k_i² over integers is an integer QP,
   which HiGHS does not solve; but on integers k² equals the upper envelope of
   the chords ``(2j+1)|k| − j(j+1)``, j = 0, 1, …, so the MILP "minimise Σ s_i,
   s_i ≥ chords" is exact.  Chords are added lazily where a solution violates
   s_i ≥ k_i², which ends after a few rounds.

Fallback: every MILP has a time limit.  If it is hit, the best incumbent is used
(status ``time_limit``); if there is none, the LP point rounded to the grid and
improved by greedy ±1 steps (status ``rounded``).  The LP bound is always
reported so the operator sees how far from provably optimal a fallback can be.
"""

from __future__ import annotations

import time
import warnings

import numpy as np
import numpy.typing as npt
from scipy.optimize import Bounds, LinearConstraint, linprog, milp
from scipy.sparse import csr_array, vstack

from setupfix.errors import ConvergenceWarning, SolverError
from setupfix.optimize._base import Optimizer, make_result
from setupfix.optimize._problem import CorrectionProblem, OptimizeResult

__all__ = ["ExactOptimizer", "margin_rows"]

Array = npt.NDArray[np.float64]


def margin_rows(problem: CorrectionProblem) -> tuple[Array, Array]:
    """Margin constraints in grid units: ``G·k + t ≤ g`` means every margin ≥ t.

    For dimension q with composite column a_q, measured deviation d_q and limits
    L_q < U_q the two margins are U_q − (d_q + h·a_qᵀk) and (d_q + h·a_qᵀk) − L_q
    (eqs. 5–6 per dimension); in steps of h they give the rows
    ``a_qᵀk + t ≤ (U_q − d_q)/h`` and ``−a_qᵀk + t ≤ (d_q − L_q)/h``.

    Returns
    -------
    G : ndarray of shape (n_rows, n_free)
        Rows over the free registers only.
    g : ndarray of shape (n_rows,)
    """
    h = problem.resolution
    a = problem.composite[problem.free].T  # (m, n_free)
    upper_ok = np.isfinite(problem.upper)
    lower_ok = np.isfinite(problem.lower)
    g_rows = np.vstack([a[upper_ok], -a[lower_ok]])
    g = np.concatenate([(problem.upper - problem.deviation)[upper_ok] / h,
                        (problem.deviation - problem.lower)[lower_ok] / h])
    return g_rows, g


def _rows_to_dimensions(problem: CorrectionProblem, rows: npt.NDArray[np.bool_]) -> tuple[str, ...]:
    """Dimension IDs of flagged margin rows (upper-limit rows first, as in :func:`margin_rows`)."""
    ids = np.array(problem.dimension_ids, dtype=object)
    upper_ids = ids[np.isfinite(problem.upper)]
    lower_ids = ids[np.isfinite(problem.lower)]
    flagged = set(upper_ids[rows[: upper_ids.size]]) | set(lower_ids[rows[upper_ids.size:]])
    return tuple(d for d in problem.dimension_ids if d in flagged)


def _grid_margin(g_rows: Array, g: Array, k: Array) -> float:
    """Smallest margin [steps] of integer point k (inf when there is no row)."""
    return float(np.min(g - g_rows @ k)) if g.size else np.inf


def _greedy_round(g_rows: Array, g: Array, k: Array, kmin: Array, kmax: Array) -> Array:
    """Round k and climb by single ±1 steps while the smallest margin grows."""
    k = np.clip(np.rint(k), kmin, kmax)
    best = _grid_margin(g_rows, g, k)
    improved = True
    while improved:
        improved = False
        for i in range(k.size):
            for step in (-1.0, 1.0):
                trial = k.copy()
                trial[i] += step
                if kmin[i] <= trial[i] <= kmax[i]:
                    value = _grid_margin(g_rows, g, trial)
                    if value > best + 1e-12:
                        k, best, improved = trial, value, True
    return k


class ExactOptimizer(Optimizer):
    """Provably optimal corrections on the register grid (the default optimiser).

    Parameters
    ----------
    grid : bool, default=True
        Solve on the register grid (MILP).  False returns the continuous LP
        optimum with the least Euclidean norm (not on the grid).
    time_limit : float, default=2.0
        Seconds allowed to each MILP before the documented fallback.
    seed : int, optional
        Accepted for interface symmetry; the solver is deterministic.
    """

    name = "exact"

    def __init__(self, *, grid: bool = True, time_limit: float = 2.0, seed: int | None = None) -> None:
        self.grid = grid
        self.time_limit = time_limit
        self.seed = seed

    # -- stages -------------------------------------------------------------------------------
    @staticmethod
    def _lp_bound(g_rows: Array, g: Array, kmin: Array, kmax: Array,
                  t_cap: float) -> tuple[float, Array, npt.NDArray[np.bool_]]:
        n = g_rows.shape[1]
        c = np.zeros(n + 1)
        c[-1] = -1.0
        a_ub = np.hstack([g_rows, np.ones((g_rows.shape[0], 1))])
        bounds = list(zip(kmin, kmax)) + [(None, t_cap)]
        res = linprog(c, A_ub=a_ub, b_ub=g, bounds=bounds, method="highs")
        if res.status != 0:
            raise SolverError(f"LP stage failed: {res.message}")
        # Rows with a non-zero dual price are the dimensions whose limits prove the bound:
        # the answer to "why can't it do better?".
        duals = np.abs(res.ineqlin.marginals)
        return float(res.x[-1]), res.x[:-1], duals > 1e-9

    def _milp_max_margin(self, g_rows: Array, g: Array, kmin: Array, kmax: Array,
                         t_lo: float, t_hi: float) -> tuple[Array | None, str]:
        n = g_rows.shape[1]
        c = np.zeros(n + 1)
        c[-1] = -1.0
        cons = LinearConstraint(np.hstack([g_rows, np.ones((g_rows.shape[0], 1))]), -np.inf, g)
        res = milp(c, constraints=cons, integrality=np.r_[np.ones(n), 0.0],
                   bounds=Bounds(np.r_[kmin, t_lo], np.r_[kmax, t_hi]),
                   options={"time_limit": self.time_limit, "mip_rel_gap": 0.0})
        if res.x is None:
            return None, "failed"
        return np.rint(res.x[:n]), ("optimal" if res.status == 0 else "time_limit")

    def _milp_least_norm(self, g_rows: Array, g: Array, kmin: Array, kmax: Array,
                         t_star: float, k_start: Array) -> Array:
        """Least Σk² among integer k with every margin ≥ t_star (exact chord MILP)."""
        n = g_rows.shape[1]
        margin_block = csr_array(np.hstack([g_rows, np.zeros((g_rows.shape[0], n))]))
        margin_rhs = g - t_star + 1e-7
        # Seed the chords around the continuous least-norm point at the same margin: the
        # integer optimum is almost always within a step of it, so the first MILP is
        # usually exact and the lazy loop ends at once.
        try:
            k_cont = ExactOptimizer._continuous_least_norm(g_rows, g, kmin, kmax, t_star)
        except SolverError:
            k_cont = k_start
        chords: list[set[int]] = []
        for vc, vs in zip(np.abs(k_cont), np.abs(k_start)):
            base = int(np.floor(vc))
            chords.append({max(base - 1, 0), base, base + 1, int(vs)})
        self._chord_rounds = 0
        deadline = time.perf_counter() + self.time_limit
        best = k_start
        for _ in range(50):
            rows, rhs = [], []
            for i, js in enumerate(chords):
                for j in sorted(js):
                    for sign in (1.0, -1.0):
                        # s_i >= (2j+1)·sign·k_i − j(j+1)
                        row = np.zeros(2 * n)
                        row[i] = sign * (2 * j + 1)
                        row[n + i] = -1.0
                        rows.append(row)
                        rhs.append(j * (j + 1))
            a = vstack([margin_block, csr_array(np.array(rows))])
            b = np.r_[margin_rhs, rhs]
            remaining = deadline - time.perf_counter()
            if remaining <= 0:
                break
            res = milp(np.r_[np.zeros(n), np.ones(n)], constraints=LinearConstraint(a, -np.inf, b),
                       integrality=np.r_[np.ones(n), np.zeros(n)],
                       bounds=Bounds(np.r_[kmin, np.zeros(n)], np.r_[kmax, np.full(n, np.inf)]),
                       options={"time_limit": remaining, "mip_rel_gap": 0.0})
            if res.x is None:
                break
            k = np.rint(res.x[:n])
            s = res.x[n:]
            if _grid_margin(g_rows, g, k) >= t_star - 1e-6:
                best = k
            short = [i for i in range(n) if s[i] < k[i] ** 2 - 1e-6]
            self._chord_rounds += 1
            if not short or res.status != 0:
                break
            for i in short:
                chords[i].add(int(abs(k[i])))
        return best

    # -- driver -------------------------------------------------------------------------------
    def solve(self, problem: CorrectionProblem) -> OptimizeResult:
        start = time.perf_counter()
        free = problem.free
        n_all = problem.n_registers
        g_rows, g = margin_rows(problem)
        kmin = problem.kmin[free].astype(float)
        kmax = problem.kmax[free].astype(float)
        # Only one-sided limits that corrections can move away from leave t unbounded; the
        # cap keeps the LP bounded then, and lies far above any two-sided margin otherwise.
        t_cap = 1e9
        x = np.zeros(n_all)
        calls = 0
        if free.sum() == 0 or g.size == 0:
            return make_result(problem, x, optimizer=self.name, evaluations=0,
                               seconds=time.perf_counter() - start, status="optimal",
                               bound=problem.margin_before,
                               message="nothing can be corrected: every register is fixed or no limit applies")
        t_lp, k_lp, active = self._lp_bound(g_rows, g, kmin, kmax, t_cap)
        calls += 1
        binding = _rows_to_dimensions(problem, active)
        bound = t_lp * problem.resolution
        if not self.grid:
            k = self._continuous_least_norm(g_rows, g, kmin, kmax, t_lp)
            x[free] = k * problem.resolution
            return make_result(problem, x, optimizer=self.name, evaluations=calls + 1,
                               seconds=time.perf_counter() - start, status="optimal", bound=bound,
                               binding=binding)
        k_round = _greedy_round(g_rows, g, k_lp, kmin, kmax)
        t_round = _grid_margin(g_rows, g, k_round)
        k_best, status = self._milp_max_margin(g_rows, g, kmin, kmax, min(t_round, t_lp), t_lp)
        calls += 1
        if k_best is None or _grid_margin(g_rows, g, k_best) < t_round:
            k_best, status = k_round, "rounded" if k_best is None else status
        t_star = _grid_margin(g_rows, g, k_best)
        if status == "optimal":
            k_best = self._milp_least_norm(g_rows, g, kmin, kmax, t_star, k_best)
            calls += 1
        else:
            warnings.warn(f"grid optimum not proved within {self.time_limit} s; using the best point found "
                          f"({status})", ConvergenceWarning, stacklevel=2)
        x[free] = k_best * problem.resolution
        message = None
        if status != "optimal":
            message = (f"grid optimum not proved within the time limit ({status}); "
                       f"the continuous bound is {bound:.4f}")
        return make_result(problem, x, optimizer=self.name, evaluations=calls,
                           seconds=time.perf_counter() - start, status=status, bound=bound, message=message,
                           binding=binding)

    @staticmethod
    def _continuous_least_norm(g_rows: Array, g: Array, kmin: Array, kmax: Array, t_star: float) -> Array:
        """Least Euclidean norm point with every margin ≥ t_star (convex QP via SLSQP-free NNLS dual).

        Solved as a least-distance problem min ‖k‖ s.t. M k ≥ m (Lawson & Hanson 1974,
        ch. 23): with E = [Mᵀ; mᵀ] and f = e_{n+1}, u = NNLS(E, f), r = E u − f gives
        k = −r[:n] / r[n].
        """
        n = g_rows.shape[1]
        # Constraints as M k >= m: margins (−G k >= t* − g) and bounds.
        m_mat = np.vstack([-g_rows, np.eye(n), -np.eye(n)])
        m_vec = np.r_[t_star - g - 1e-9, kmin, -kmax]
        from scipy.optimize import nnls

        e = np.vstack([m_mat.T, m_vec[None, :]])
        f = np.zeros(n + 1)
        f[-1] = 1.0
        u, _ = nnls(e, f, maxiter=50 * e.shape[1])
        r = e @ u - f
        if abs(r[-1]) < 1e-12:
            raise SolverError("least-norm stage found no feasible point")
        return -r[:n] / r[-1]
