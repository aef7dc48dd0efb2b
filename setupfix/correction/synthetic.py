"""Synthetic measurement sets by the paper's validation recipe (Stryczek 2014, eqs. 12–13).

Setup-data errors E_i^sd = w1 · (1 − 2r) are drawn per register (eq. 12) and pushed
through the relation model; the remaining performance errors E_q = w2 · (1 − 2r)
are drawn per dimension (eq. 13) and added.  Used for the bundled sample, the
Fig. 18 benchmark and the tests.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from setupfix.correction.relation import relation_matrices

# The closed-loop shop simulator lives with the diagnosis it feeds (one definition of
# every effect term); it is re-exported here as the project's simulation entry point.
from setupfix.diagnose.shop import HiddenEffect, ShopSimulator, SimulatedSeries
from setupfix.model import ProcessModel
from setupfix.search import generator

__all__ = ["simulate_deviations", "HiddenEffect", "ShopSimulator", "SimulatedSeries"]


def simulate_deviations(
    model: ProcessModel,
    n_sets: int,
    *,
    w1: float = 0.03,
    w2: float = 0.02,
    seed: int | None = None,
    decimals: int | None = 4,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Draw measurement sets by eqs. 12–13.

    Parameters
    ----------
    model : ProcessModel
    n_sets : int
    w1 : float, default=0.03 [model unit]
        Weight of the setup-data errors (eq. 12).
    w2 : float, default=0.02 [model unit]
        Weight of the remaining performance errors (eq. 13).
    seed : int, optional
        Seed of the draw; None takes :data:`setupfix.search.DEFAULT_SEED`.
    decimals : int or None, default=4
        Round deviations as a CMM report prints them (None: no rounding).

    Returns
    -------
    deviations : ndarray of shape (n_sets, n_dimensions) [model unit]
    setup_errors : ndarray of shape (n_sets, n_registers) [model unit]
        The drawn E^sd; the ideal correction is −E^sd where the model is exact.
    """
    rng = generator(seed)  # None: setupfix.search.DEFAULT_SEED, never an unseeded draw
    comp = relation_matrices(model).composite
    # eq. 12: E_i^sd = w1 (1 - 2r)
    setup = w1 * (1.0 - 2.0 * rng.random((n_sets, comp.shape[0])))
    # eq. 13: E_q = w2 (1 - 2r)
    rest = w2 * (1.0 - 2.0 * rng.random((n_sets, comp.shape[1])))
    dev = setup @ comp + rest
    if decimals is not None:
        dev = np.round(dev, decimals)
    return dev, setup
