"""``model show`` on a model of thousands of dimensions (issue 21, item 11): linear output, bounded memory.

Before the fix a 10,000-dimension model took 87 s and 3.5 GB: every matrix was printed
as a dense grid (|F| × |D| cells) and the null space came from an SVD with a
|D| × |D| factor.  The bench is ``bench/model_show_large.py``.
"""

from __future__ import annotations

import io
import tracemalloc
from contextlib import redirect_stdout
from pathlib import Path

import numpy as np
import pytest

from setupfix.cli import main
from setupfix.correction.relation import composite_matrix, null_space_directions
from setupfix.model import load_model
from setupfix.usecases.model_check import describe_model
from setupfix.views.present import DENSE_CELLS

N = 3000


def model_text(n: int, n_wks: int = 10, n_tools: int = 40) -> str:
    """``n`` features and dimensions, dimension j = F_j − F_(j+1)."""
    out = ["[process]", 'name = "generated"', 'axis = "Z"', 'unit = "mm"', "resolution = 0.001", "limit = 0.1"]
    out += [f'[wks.W{i}]\nregister = "G54.1 P{i}"' for i in range(1, n_wks + 1)]
    out += [f'[tools.T{i}]\nregister = "H{i}"' for i in range(1, n_tools + 1)]
    out += [
        f"[features.F{j}]\nwks = {{ W{j % n_wks + 1} = 1 }}\ntools = {{ T{j % n_tools + 1} = 1 }}"
        for j in range(1, n + 1)
    ]
    out += [
        f'[dimensions.D{j}]\nname = "dim {j}"\nfeatures = {{ F{j} = 1, F{j % n + 1} = -1 }}\n'
        f"nominal = 10.0\nlower = -0.1\nupper = 0.1"
        for j in range(1, n + 1)
    ]
    return "\n".join(out) + "\n"


@pytest.fixture(scope="module")
def large(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("large") / "model.toml"
    path.write_text(model_text(N), encoding="utf-8")
    return path


@pytest.mark.slow
def test_model_show_output_grows_with_the_entries_not_the_grid(large: Path) -> None:
    out = io.StringIO()
    with redirect_stdout(out):
        assert main(["model", "show", str(large)]) == 0
    text = out.getvalue()
    # A dense R_FD alone is N² = 9,000,000 cells; the entries are 2 per dimension.
    assert len(text) < 200 * N, len(text)
    assert f"R_FD: {N} × {N}, {2 * N} non-zero entries" in text
    assert "\n  D17: +F17 −F18\n" in text and f"\n  D{N}: −F1 +F{N}\n" in text  # rows in order
    # C = [R_WF·R_FD ; R_TF·R_FD]: D17 = F17 − F18, F17 on W8 and T18, F18 on W9 and T19.
    assert "\n  D17: +W8 −W9 +T18 −T19\n" in text
    assert f"\n  D{N}: +W1 −W2 +T1 −T2\n" in text  # F3000 on W1, T1; F1 on W2, T2


def test_small_models_keep_the_grid(tmp_path: Path) -> None:
    path = tmp_path / "model.toml"
    path.write_text(model_text(20), encoding="utf-8")
    out = io.StringIO()
    with redirect_stdout(out):
        assert main(["model", "show", str(path)]) == 0
    assert DENSE_CELLS >= 20 * 20 and "\nR_FD " in out.getvalue() and "non-zero entries" not in out.getvalue()


@pytest.mark.slow
def test_null_space_of_many_dimensions_needs_no_square_factor(large: Path) -> None:
    desc = describe_model(load_model(large))
    C = np.array(desc.matrices.composite)
    tracemalloc.start()
    try:
        null = null_space_directions(C)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 8 * N * N / 4, peak  # an N × N float factor is 72 MB; C itself is 1.2 MB
    assert null.shape[0] == C.shape[0] - desc.rank
    assert np.abs(null @ C).max() < 1e-9


def test_sparse_product_equals_the_dense_one() -> None:
    rng = np.random.default_rng(21)
    for _ in range(300):
        w, t, f, d = rng.integers(0, 7, 4)
        r_wf = rng.normal(size=(w, f)) * (rng.random((w, f)) < 0.5)
        r_tf = rng.normal(size=(t, f)) * (rng.random((t, f)) < 0.5)
        r_fd = rng.normal(size=(f, d)) * (rng.random((f, d)) < 0.4)
        got = composite_matrix(r_wf, r_tf, r_fd)
        np.testing.assert_allclose(got, np.vstack([r_wf @ r_fd, r_tf @ r_fd]), rtol=1e-12, atol=1e-14)


def test_null_space_agrees_with_the_full_svd_on_tall_and_wide_matrices() -> None:
    import scipy.linalg

    rng = np.random.default_rng(5)
    for n_reg, n_dim in [(6, 40), (6, 3), (5, 5), (8, 2)]:
        C = rng.normal(size=(n_reg, n_dim))
        C[-1] = C[0] - C[1]  # one more dependent row
        null = null_space_directions(C)
        full = scipy.linalg.null_space(C.T, rcond=1e-9)
        assert null.shape[0] == full.shape[1]
        if null.size:  # same subspace: projecting one basis on the other keeps it
            proj = full @ (full.T @ null.T)
            np.testing.assert_allclose(proj, null.T, atol=1e-9)
