"""Speed: GMC(1,N) cuckoo-search calibration on 500 samples × 9 sensors; streaming Kalman cost per sample.

    python -m bench.thermal_speed | tee bench/results/thermal_speed.txt

Reference in the same run: the GMC response by the direct O(n²) convolution sum (a
lower-triangular kernel matrix) instead of the O(n) recursion used by the library.
"""

from __future__ import annotations

import functools
import time

import numpy as np

from setupfix.thermal import grey
from setupfix.thermal.grey_model import GreyModel
from setupfix.thermal.kalman_model import KalmanFusionModel
from setupfix.thermal.simulator import simulate, speed_profile


def best_of(fn, repeat=5):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def _stream(model: KalmanFusionModel, T: np.ndarray, te: np.ndarray, sp: np.ndarray) -> None:
    """Feed the samples one at a time, as a machine's controller would."""
    s = model.stream()
    for j in range(len(T)):
        s.step(T[j], te[j], sp[j])


def direct_response(theta, y0, X1):
    """Eq. (2) by an explicit kernel matrix: O(n²) per parameter set (reference only)."""
    n = X1.shape[0]
    b1 = theta[0]
    f = X1 @ theta[1:-1] + theta[-1]
    k = np.arange(n)
    K = np.tril(np.exp(-b1 * (k[:, None] - k[None, :])))
    K[:, 0] *= 0.5
    K[k, k] *= 0.5
    K[0, 0] = 0.0
    return y0 * np.exp(-b1 * k) + K @ f


def main() -> None:
    rng = np.random.default_rng(0)
    n, p = 500, 9
    X = np.cumsum(rng.normal(0.02, 0.05, (n, p)), axis=0)
    truth = np.r_[0.2, rng.normal(0, 0.5, p), 0.1]
    y = grey.gmc_predict(truth, 0.0, X) + rng.normal(0, 0.01, n)
    X1 = grey.ago(X)
    theta = truth.copy()
    np.testing.assert_allclose(direct_response(theta, 0.0, X1), grey.gmc_response(theta, 0.0, X1), rtol=1e-9)
    t_rec = best_of(lambda: [grey.gmc_response(np.tile(theta, (25, 1)), 0.0, X1) for _ in range(20)]) / 500
    t_dir = best_of(lambda: [direct_response(theta, 0.0, X1) for _ in range(100)]) / 100
    t_cs = best_of(lambda: GreyModel(calibration="cs", seed=1).fit(X, y), repeat=3)
    t_pso = best_of(lambda: GreyModel(calibration="pso", seed=1).fit(X, y), repeat=3)
    t_ls = best_of(lambda: GreyModel(calibration="ls").fit(X, y), repeat=5)
    print(f"GMC(1,N) on {n} samples x {p} sensors (b1, 9 driving coefficients, u), paper budget 25 x 100")
    print(f"  response, recursion (lfilter), per evaluation : {t_rec * 1e6:8.1f} us")
    print(f"  response, direct O(n^2) sum, per evaluation   : {t_dir * 1e6:8.1f} us  ({t_dir / t_rec:.1f}x slower)")
    print(f"  cuckoo search calibration (5025 evaluations)  : {t_cs:8.3f} s   (requirement <= 1 s)")
    print(f"  PSO calibration (2525 evaluations)            : {t_pso:8.3f} s")
    print(f"  bounded least squares                         : {t_ls * 1e3:8.2f} ms  (CS/LS = {t_cs / t_ls:.0f}x)")
    print(f"  CS with the direct sum would take about       : {t_cs + 5025 * (t_dir - t_rec):8.2f} s")

    train = simulate(speed_profile("variable", 1440, rng=np.random.default_rng(1)), seed=1).frame
    cols = ["spindle_motor", "bearing"]
    model = KalmanFusionModel(seed=0).fit(
        train[cols].to_numpy(),
        train["error_z"].to_numpy(),
        ambient=train["ambient"].to_numpy(),
        speed=train["spindle_speed"].to_numpy(),
    )
    print()
    print("Kalman fusion prediction, 2 sensors")
    for length in (1_000, 10_000, 50_000):
        run = simulate(speed_profile("variable", length, rng=np.random.default_rng(2)), seed=2).frame
        T, te, sp = run[cols].to_numpy(), run["ambient"].to_numpy(), run["spindle_speed"].to_numpy()

        t_stream = best_of(functools.partial(_stream, model, T, te, sp), repeat=1) / length
        t_batch = best_of(functools.partial(model.predict, T, ambient=te, speed=sp), repeat=3) / length
        print(
            f"  {length:>6} samples: streaming {t_stream * 1e6:6.1f} us/sample, batch {t_batch * 1e6:5.1f} us/sample "
            f"(streaming/batch {t_stream / t_batch:.1f})"
        )


if __name__ == "__main__":
    main()
