"""The real gooddash runs (../shared only; skipped when absent)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pandas as pd
from conftest import shared_path

from setupfix.thermal.estimator import MRAModel
from setupfix.thermal.grey import gmc_least_squares
from setupfix.thermal.grey_model import GreyModel
from setupfix.thermal.metrics import score

SENSITIVE = [2, 6, 9, 12, 19, 20]  # the repo's own temperature-sensitive points (SOURCES.md)


def run(i: int, cols: list[int] = SENSITIVE) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    frame = pd.read_csv(shared_path("thermal-data", "gooddash", f"data_ex{i}.csv"))
    return frame.iloc[:, cols].to_numpy(), frame["E"].to_numpy()


def test_unconstrained_ls_diverges_and_the_bound_prevents_it() -> None:
    """Notes §4.3 pitfall 1: two sensors, ex1 -> ex2, LS gives b1 < 0 and a useless response."""
    Xtr, ytr = run(1, [2, 6])
    Xte, yte = run(2, [2, 6])
    assert gmc_least_squares(ytr, Xtr)[0] < 0
    model = GreyModel(calibration="ls").fit(Xtr, ytr)
    assert model.theta_[0] > 0
    pred = model.predict(Xte, y0=yte[0])
    assert np.all(np.isfinite(pred)) and np.abs(pred).max() < 1e3


def test_mra_and_grey_cs_on_real_runs() -> None:
    Xtr, ytr = run(1)
    Xte, yte = run(2)
    mra = score(yte, MRAModel().fit(Xtr, ytr).predict(Xte))
    assert mra.rmse < 2.0 and mra.efficiency > 0.7  # µm; the error spans 0–14 µm
    cs = GreyModel(calibration="cs", iterations=100, seed=0).fit(Xtr, ytr)
    assert np.isfinite(cs.train_rmse_) and cs.theta_[0] > 0
