"""A long run in one process gives every report the answer it gets in a fresh process (issue 21, item 1).

HiGHS adds up the run time of every run of one solver object and compares its time limit
with that sum.  Solver models kept across reports therefore ran out of time after a few
thousand reports (at the default 2 s limit), and every later solve stopped at once.  Here
the limit is 0.3 s, so kept models would be spent after some 600 reports of the paper's
example; 1,200 reports must all come back optimal and equal to a fresh process's answers.
(``bench/exact_long_run.py`` runs 6,000 at the default limit.)
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from setupfix.correction.synthetic import simulate_deviations
from setupfix.model import PartMeasurement, ProcessModel
from setupfix.optimize import CorrectionProblem, get_optimizer

ROOT = Path(__file__).resolve().parents[2]
#: The wall-clock guard of these solves [s]: far above them (the stages end on work, never on it).
LIMIT = 60.0

#: Solves each pickled problem once in this fresh process and pickles (x, status, path) back.
FRESH = """
import pickle, sys
from setupfix.optimize import get_optimizer
problems = pickle.load(open(sys.argv[1], "rb"))
out = []
for p in problems:
    r = get_optimizer("exact", objective="paper", time_limit=float(sys.argv[3])).solve(p)
    out.append((r.x, r.status, r.path))
pickle.dump(out, open(sys.argv[2], "wb"))
"""


def fresh_process(problems: list[CorrectionProblem], tmp_path: Path) -> list[tuple[np.ndarray, str, str]]:
    src, dst = tmp_path / "problems.pkl", tmp_path / "answers.pkl"
    src.write_bytes(pickle.dumps(problems))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    subprocess.run([sys.executable, "-c", FRESH, str(src), str(dst), str(LIMIT)], check=True, env=env, cwd=ROOT)
    answers: list[tuple[np.ndarray, str, str]] = pickle.loads(dst.read_bytes())
    return answers


@pytest.mark.slow
def test_a_long_run_never_runs_out_of_time_and_equals_a_fresh_process(
    guide_pins_model: ProcessModel, tmp_path: Path
) -> None:
    devs, _ = simulate_deviations(guide_pins_model, 16, seed=3)
    problems = [
        CorrectionProblem.from_part(guide_pins_model, PartMeasurement("c", "r", None, d, ("",) * d.size)) for d in devs
    ]
    fresh = fresh_process(problems, tmp_path)
    # the reports a fresh process proves without a MILP (a few ms each: far from the limit on a busy machine)
    quick = [i for i, (_, status, path) in enumerate(fresh) if status == "optimal" and "MILP" not in path]
    assert len(quick) >= 8
    optimizer = get_optimizer("exact", objective="paper", time_limit=LIMIT)
    for n in range(1200):
        i = quick[n % len(quick)]
        result = optimizer.solve(problems[i])
        assert result.status == "optimal", (n, result.stopped)
        np.testing.assert_array_equal(result.x, fresh[i][0])


def test_each_run_of_one_highs_model_has_its_own_work_allowance() -> None:
    """Runs of one model within a solve (lazy cuts, levels) each get the allowance they are given, charged
    to the solve's meter run by run (HiGHS's own clock, summed over the runs, plays no part)."""
    from setupfix.optimize.exact import work
    from setupfix.optimize.exact.highs import INF, LinearModel

    model = LinearModel(
        np.array([0.0, -1.0]),
        np.array([[1.0, 1.0], [-1.0, 1.0]]),
        np.full(2, -INF),
        np.array([1.0, 1.0]),
        np.array([-5.0, -INF]),
        np.array([5.0, INF]),
    )
    token = work.CURRENT.set(work.Meter())
    try:
        runs = [model.solve(work.MIN_RUN) for _ in range(200)]
        spent = work.current().spent
    finally:
        work.CURRENT.reset(token)
    assert {r.status for r in runs} == {"optimal"}
    assert len({r.seconds for r in runs}) == 1 and 0 < runs[0].seconds <= work.MIN_RUN  # the same work each run
    assert spent == pytest.approx(sum(r.seconds for r in runs))


@pytest.mark.slow
def test_the_first_solve_of_a_process_imports_before_its_clock_starts() -> None:
    """scipy.optimize (NNLS, imported lazily by the stages) is loaded before the solve's clock starts."""
    import subprocess
    import sys
    from pathlib import Path

    code = """
import sys
import setupfix.optimize.exact.solve as exact
from setupfix.model import load_model
from setupfix.optimize import CorrectionProblem, get_optimizer
from setupfix.inputs.cycles import load_parts
seen = []
class Watched(exact.Clock):
    def __init__(self, limit, *args, **kwargs):
        seen.append("scipy.optimize" in sys.modules)
        super().__init__(limit, *args, **kwargs)
exact.Clock = Watched
m = load_model("sample_reports/guide_pins/model.toml")
p = load_parts(m, "sample_reports/guide_pins/cycle_01.csv")[0]
assert "scipy.optimize" not in sys.modules, "the test needs a process that has not loaded it yet"
get_optimizer("exact", objective="paper").solve(CorrectionProblem.from_part(m, p))
print(seen)
"""
    root = Path(__file__).resolve().parents[2]
    out = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[True]"
