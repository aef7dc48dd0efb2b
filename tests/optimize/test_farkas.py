"""Farkas weights by NNLS (setupfix.optimize.exact.farkas): a proof only where no grid point exists (brute force),
the same verdict and point whether the near rows are tried first or not, and every proof checked."""

from __future__ import annotations

import itertools
from collections.abc import Callable

import numpy as np
import numpy.typing as npt
import pytest

import setupfix.optimize.exact.farkas as farkas
from setupfix.optimize.exact.farkas import farkas_or_point
from setupfix.optimize.exact.session import GridRows

Array = npt.NDArray[np.float64]
Solver = Callable[[Array], tuple[Array, Array] | None]


def _rows(seed: int) -> tuple[GridRows, np.ndarray, np.ndarray]:
    """Random integer rows over a 3-register box [-3, 3]³, their right-hand sides rounded down, every grid point."""
    rng = np.random.default_rng(seed)
    g_rows = rng.integers(-2, 3, size=(10, 3)).astype(float)
    g = rng.uniform(-1.0, 5.0, 10)
    rows = GridRows(g_rows, g, np.full(3, -3.0), np.full(3, 3.0), rng.uniform(0.5, 2.0, 3))
    pts = np.array(list(itertools.product(range(-3, 4), repeat=3)), dtype=float)
    return rows, np.floor(g), pts


def _proves_empty(rows: GridRows, b: np.ndarray, y: np.ndarray) -> bool:
    """max over the box of Σ y_j (b_j − G_j k) < 0, recomputed by listing the box's corners."""
    corners = np.array(list(itertools.product(*zip(rows.kmin, rows.kmax, strict=True))), dtype=float)
    fin = np.isfinite(b)
    return bool(np.max((y[fin] @ b[fin]) - corners @ (y[fin] @ rows.g_rows[fin])) < 0)


@pytest.mark.parametrize("seed", range(40))
def test_near_rows_first_give_the_same_verdict_and_point(seed: int) -> None:
    rows, b, pts = _rows(seed)
    feasible = np.all(pts @ rows.g_rows.T <= b + 1e-9, axis=1)
    k = pts[np.random.default_rng(seed).integers(len(pts))]  # any grid point: only where to look first
    y_all, x_all = farkas_or_point(rows, b)
    y_near, x_near = farkas_or_point(rows, b, k)
    for y in (y_all, y_near):
        if y is not None:
            assert not feasible.any() and np.all(y >= 0) and y.sum() == pytest.approx(1.0)
            assert _proves_empty(rows, b, y)
    assert (y_all is None) == (y_near is None)  # a subsystem's proof, or the whole system's answer
    if x_all is not None:
        np.testing.assert_array_equal(x_near, x_all)  # the point always comes from the whole system
        assert np.all(rows.g_rows @ x_all <= b + 1e-6)


def counted(sizes: list[int], solve: Solver) -> Solver:
    """``solve``, recording the number of columns of every system it is given."""

    def run(e: Array) -> tuple[Array, Array] | None:
        sizes.append(e.shape[1])
        return solve(e)

    return run


def test_a_proof_from_the_near_rows_alone_is_found_and_kept(monkeypatch: pytest.MonkeyPatch) -> None:
    """Two opposite rows next to k that cannot both hold (x ≤ −1 and x ≥ 1): the near subsystem proves it,
    and the whole system is never solved."""
    g_rows = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
    rows = GridRows(g_rows, np.zeros(4), np.full(2, -50.0), np.full(2, 50.0), np.ones(2))
    b = np.array([-1.0, -1.0, 40.0, 40.0])
    sizes: list[int] = []
    solve = farkas.nnls_solve
    monkeypatch.setattr(farkas, "nnls_solve", counted(sizes, solve))
    y, x = farkas_or_point(rows, b, np.zeros(2))
    assert x is None and y is not None and _proves_empty(rows, b, y)
    assert sizes == [2]  # only the two rows within NEAR of k (the far rows and the box limits 50 away left out)
    np.testing.assert_allclose(y, [0.5, 0.5, 0.0, 0.0])


def test_weights_that_prove_nothing_are_refused() -> None:
    """The check is done in numpy on every answer: weights on a system with a point are never a proof."""
    rows, b, pts = _rows(3)
    b = np.full(b.size, 100.0)  # every grid point meets these rows
    keep = np.isfinite(b)
    assert farkas.checked_weights(rows, b, keep, np.ones(int(keep.sum()))) is None
    assert farkas_or_point(rows, b, pts[0])[0] is None


@pytest.mark.parametrize("seed", range(40))
def test_near_rows_only_prove_a_subset_of_the_cases_and_never_solve_the_whole(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``whole=False``: a proof only where the whole system has one (brute force), no point ever, and NNLS
    never on every column; where the near rows prove nothing the answer is (None, None), not the whole's."""
    rows, b, pts = _rows(seed)
    feasible = np.all(pts @ rows.g_rows.T <= b + 1e-9, axis=1)
    k = pts[np.random.default_rng(seed).integers(len(pts))]
    sizes: list[int] = []
    solve = farkas.nnls_solve
    monkeypatch.setattr(farkas, "nnls_solve", counted(sizes, solve))
    y, x = farkas_or_point(rows, b, k, whole=False)
    assert x is None
    if y is not None:
        assert not feasible.any() and _proves_empty(rows, b, y)
    n_cols = int(np.isfinite(b).sum()) + 2 * rows.n_free
    assert all(size < n_cols for size in sizes)
    g_rows = np.array([[1.0, 0.0], [-1.0, 0.0]])
    far = GridRows(g_rows, np.zeros(2), np.full(2, -50.0), np.full(2, 50.0), np.ones(2))
    b2, k2 = np.array([-1.0, -1.0]), np.array([30.0, 0.0])  # x ≤ −1 and x ≥ 1; only the first row near k2
    assert farkas_or_point(far, b2, k2, whole=False) == (None, None)
    y2 = farkas_or_point(far, b2, k2)[0]
    assert y2 is not None and _proves_empty(far, b2, y2)
