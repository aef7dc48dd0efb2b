"""Mutated real samples: every registered reader returns a table or a ParseError — never
another exception, never a hang past 2 s, never runaway memory.

Covers every sample of every format (``../shared/cmm-samples`` when present, and the
project's own ``sample_reports``).  Mutations: truncation, byte flips, deleted and
duplicated lines, up to three at once.  Examples are derandomised (reproducible); the
count per sample keeps the whole file near 30 s on two cores.
"""

from __future__ import annotations

import hashlib
import resource
import signal
from pathlib import Path
from typing import Any

import pandas as pd
import pytest
from conftest import SHARED as SHARED_ROOT
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import parsers
from setupfix.core.errors import SetupfixError

ROOT = Path(__file__).resolve().parents[2]
SHARED_SAMPLES = SHARED_ROOT / "cmm-samples"
NOT_REPORTS = {".md", ".py", ".toml", ".pyc"}
#: Wall-clock limit of one parse [s].
HANG_SECONDS = 2.0
#: Allowed growth of the peak resident memory over one sample's examples [MiB].
MEMORY_GROWTH_MIB = 256
EXAMPLES = 100


def _samples() -> list[Path]:
    found: dict[str, Path] = {}
    roots = [ROOT / "sample_reports"] + ([SHARED_SAMPLES] if SHARED_SAMPLES.exists() else [])
    for root in roots:
        for path in sorted(root.rglob("*")):
            if not path.is_file() or path.suffix.lower() in NOT_REPORTS or "readme" in path.name.lower():
                continue
            found.setdefault(hashlib.sha1(path.read_bytes()).hexdigest(), path)
    return sorted(found.values(), key=lambda p: p.name)


SAMPLES = _samples()

_MUTATION = st.one_of(
    st.tuples(st.just("truncate"), st.floats(0.0, 1.0)),
    st.tuples(st.just("flip"), st.floats(0.0, 1.0), st.integers(0, 255)),
    st.tuples(st.just("delete_line"), st.floats(0.0, 1.0)),
    st.tuples(st.just("duplicate_line"), st.floats(0.0, 1.0)),
)


def mutate(data: bytes, mutations: list[tuple[Any, ...]]) -> bytes:
    """Apply the mutations in order; positions are fractions of the current length."""
    for mutation in mutations:
        kind, where = mutation[0], mutation[1]
        if kind == "truncate":
            data = data[: int(where * len(data))]
        elif kind == "flip" and data:
            i = min(int(where * len(data)), len(data) - 1)
            data = data[:i] + bytes([mutation[2]]) + data[i + 1 :]
        else:
            lines = data.splitlines(keepends=True)
            if not lines:
                continue
            i = min(int(where * len(lines)), len(lines) - 1)
            lines[i : i + 1] = [] if kind == "delete_line" else [lines[i], lines[i]]
            data = b"".join(lines)
    return data


class _Hang(Exception):
    pass


def _alarm(signum: int, frame: object) -> None:
    raise _Hang


def _peak_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def test_samples_were_found() -> None:
    assert any(p.suffix.lower() == ".qif" for p in SAMPLES)


@pytest.mark.slow
@pytest.mark.parametrize("sample", SAMPLES, ids=[p.name for p in SAMPLES])
def test_mutated_sample_reads_or_fails_cleanly(sample: Path, tmp_path: Path) -> None:
    original = sample.read_bytes()
    target = tmp_path / sample.name
    start_peak = _peak_mib()

    @settings(
        max_examples=EXAMPLES,
        deadline=None,
        derandomize=True,
        database=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow, HealthCheck.data_too_large],
    )
    @given(st.lists(_MUTATION, min_size=1, max_size=3))
    def check(mutations: list[tuple[Any, ...]]) -> None:
        target.write_bytes(mutate(original, mutations))
        previous = signal.signal(signal.SIGALRM, _alarm)
        signal.setitimer(signal.ITIMER_REAL, HANG_SECONDS)
        try:
            table = parsers.read_report(target).table
        except SetupfixError:
            return
        except _Hang:
            pytest.fail(f"{sample.name}: parsing {mutations} took more than {HANG_SECONDS} s")
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)
        assert isinstance(table, pd.DataFrame)
        assert {"characteristic", "nominal", "actual", "deviation"} <= set(table.columns)

    check()
    assert _peak_mib() - start_peak < MEMORY_GROWTH_MIB
