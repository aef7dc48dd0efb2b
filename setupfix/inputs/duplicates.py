"""Which measured parts are one measurement: the content identity every door's history uses.

A part is identified by what was measured as well as by its name, never by the bytes of the
file that brought it: the ``.csv``, ``.dmo`` and ``.qif`` of one measurement, a CRLF copy, a
copy whose part name differs in case or spacing, or one that lost a row, are one part.  Batch
corrects it once, the smoothing history and the diagnosis's series count it once, and ``spc``
counts its values once.

The rule (:func:`same_measurement`): two parts are one measurement when

1. their part names are equal up to case and runs of white space (:func:`setupfix.model.normalise_name`;
   an unnamed part has the name ``""``);
2. their times are the same instant where both give one (a part without a time is not told
   apart by time);
3. they share at least one characteristic, and at most one characteristic of either is missing
   from the other -- at least two shared when one is missing, or when the parts have no name
   and no time to compare (both give one) -- a single value alone is no identity;
4. every shared characteristic's value agrees to the reports' resolution: ``|a − b| ≤ r / 2``,
   ``r`` the coarser of the two parts' resolutions (:func:`resolution_of`: the finest decimal
   step every value of the part is written at, at most :data:`COARSEST` of the unit), so a
   value written with 4 decimals in one file and 6 in another is the same value, and two parts
   that differ by one step of the report are two parts.

The relation is tested pairwise; :class:`ContentIndex` keeps the parts seen so far and finds
the first one a new part repeats (a part is compared only with parts of its name whose first
values lie near its own).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from parsers.timestamps import instant
from setupfix.core.errors import ParseError, SourceLocation
from setupfix.model import PartMeasurement, normalise_name

__all__ = [
    "COARSEST",
    "FINEST_DECIMALS",
    "Content",
    "ContentIndex",
    "content_of",
    "first_copies",
    "part_content",
    "resolution_of",
    "same_measurement",
    "time_ns",
]

#: The most decimals a report's resolution is looked for at (finer values count as written at 1e-9).
FINEST_DECIMALS = 9
#: The coarsest resolution a report is taken to have [unit]: values that all happen to be whole
#: hundredths (or zeros) do not widen the agreement beyond half a thousandth.
COARSEST = 1e-3


#: The decimals a resolution is looked for at, finest last.
_DECIMALS = np.arange(-round(np.log10(COARSEST)), FINEST_DECIMALS + 1)


def resolution_of(values: npt.ArrayLike) -> float:
    """The coarsest decimal step every finite value is a multiple of: 10⁻ᵏ, k ≤ :data:`FINEST_DECIMALS`, at most
    :data:`COARSEST` (no finite value: :data:`COARSEST`).

    A value read from text and converted (``actual − nominal``) keeps its decimals to within
    float rounding, which is allowed for (10⁻⁶ of a step).
    """
    v = np.asarray(values, dtype=float).ravel()
    v = v[np.isfinite(v)]
    scaled = v[None, :] * 10.0 ** _DECIMALS[:, None]  # (decimals, values)
    fits = np.all(np.abs(scaled - np.round(scaled)) <= 1e-6 + 1e-12 * np.abs(scaled), axis=1)
    k = int(_DECIMALS[np.argmax(fits)]) if fits.any() else FINEST_DECIMALS
    return float(10.0**-k)


@dataclass(frozen=True, eq=False)
class Content:
    """What was measured on one part, as :func:`same_measurement` compares it.

    Attributes
    ----------
    name : str
        The part name, normalised (case and runs of blanks ignored; ``""`` unnamed).
    time : int or None
        When it was machined [ns since 1970, UTC-naive]; None when not given.
    values : mapping of str to float
        Each characteristic's measured value (a deviation) [unit], finite values only.
    resolution : float
        :func:`resolution_of` the values [unit].
    label, source : str
        The part name as written and where it came from (for messages only; not compared).
    """

    name: str
    time: int | None
    values: Mapping[str, float]
    resolution: float
    label: str = ""
    source: str = ""


def content_of(
    name: str, time: int | None, values: Mapping[str, float], *, source: str = "", resolution: float | None = None
) -> Content:
    """A part's :class:`Content`: the name normalised, non-finite values left out, the resolution found."""
    finite = {k: float(v) for k, v in values.items() if np.isfinite(v)}
    res = resolution_of(list(finite.values())) if resolution is None else resolution
    return Content(normalise_name(str(name)), time, finite, res, str(name), source)


def time_ns(value: object, where: str = "") -> int | None:
    """A timestamp (ISO text, datetime or datetime64) as ns since 1970, UTC-naive; None for none or empty.

    Raises
    ------
    ParseError
        Text that is not ISO 8601 (:func:`parsers.timestamps.instant`, at ``where``).
    """
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return None
    if isinstance(value, np.datetime64):
        return None if np.isnat(value) else int(value.astype("datetime64[ns]").astype(np.int64))
    if not str(value).strip():
        return None
    stamp = instant(value, SourceLocation(where))
    return int(np.datetime64(stamp, "ns").astype(np.int64))


def part_content(
    part: PartMeasurement, keys: Sequence[str], *, time: int | None = None, unreadable_time: bool = False
) -> Content:
    """The content of a part matched to a model: its deviations keyed by the model's dimensions ``keys``.

    ``time``: the part's instant when the caller has read it already (else its timestamp is read);
    ``unreadable_time``: a timestamp that cannot be read counts as none (the caller refuses it where
    the time is needed) instead of raising.

    Raises
    ------
    ParseError
        A timestamp that is not ISO 8601 (named with the report), unless ``unreadable_time``.
    """
    try:
        when = time if time is not None else time_ns(part.timestamp, part.report)
    except ParseError:
        if not unreadable_time:
            raise
        when = None
    dev = np.asarray(part.deviation, dtype=float)
    return content_of(part.part, when, dict(zip(keys, dev.tolist(), strict=True)), source=part.report)


def same_measurement(a: Content, b: Content) -> bool:
    """Whether ``a`` and ``b`` are one measurement (the module's rule, items 1–4)."""
    if a.name != b.name:
        return False
    if a.time is not None and b.time is not None and a.time != b.time:
        return False
    tol = max(a.resolution, b.resolution) / 2 * (1 + 1e-6)
    shared = missing = 0
    theirs = b.values
    for k, v in a.values.items():  # the first value that differs ends it (most pairs: the first one)
        w = theirs.get(k)
        if w is None:
            missing += 1
            if missing > 1:
                return False
        elif abs(v - w) > tol:
            return False
        else:
            shared += 1
    missing = max(missing, len(theirs) - shared)
    if not shared or missing > 1:
        return False
    anonymous = not a.name and (a.time is None or b.time is None)
    return not ((missing or anonymous) and shared < 2)


@dataclass
class ContentIndex:
    """The parts seen so far: :meth:`find` the first one a part repeats, :meth:`add` a new one.

    Each part is filed under its name and each of its first three characteristics (sorted by name)
    with the cell of :data:`COARSEST` its value falls in.  A part is compared only with the parts
    found under its own name and at least two of its first three characteristics in their cells or
    the neighbouring ones (one, for parts of fewer characteristics).  That finds every part it
    repeats: the two smallest characteristics two repeats share are among the first three of each
    (each lacks at most one of the other's), and their values, within half the coarsest resolution,
    lie in the same or neighbouring cells.  A store of thousands of parts is searched in near
    constant time per part.
    """

    #: (name, time, characteristic, cell) → parts, and the same without the time (for parts without one)
    cells: dict[tuple[str, int | None, str, int], list[tuple[Content, int]]] = field(default_factory=dict)
    anytime: dict[tuple[str, int | None, str, int], list[tuple[Content, int]]] = field(default_factory=dict)
    size: int = 0

    @staticmethod
    def _filed(c: Content) -> list[tuple[str, str, int]]:
        return [(c.name, k, int(np.floor(c.values[k] / COARSEST))) for k in sorted(c.values)[:3]]

    def _candidates(self, c: Content) -> list[tuple[Content, int]]:
        filed = self._filed(c)
        hits: dict[int, int] = {}
        seen_at: dict[int, Content] = {}
        # a part with a time: those of its time and those without; without: every part of its name
        tables = [(self.cells, c.time), (self.cells, None)] if c.time is not None else [(self.anytime, None)]
        for table, when in tables:
            for name, k, cell in filed:
                for near in (cell - 1, cell, cell + 1):
                    for seen, i in table.get((name, when, k, near), ()):
                        hits[i] = hits.get(i, 0) + 1
                        seen_at[i] = seen
        return [(seen_at[i], i) for i in sorted(hits) if hits[i] >= min(2, len(filed), len(seen_at[i].values))]

    def matches(self, c: Content) -> list[int]:
        """The positions (order of :meth:`add`) of every part seen that ``c`` repeats, first first."""
        return [i for seen, i in self._candidates(c) if same_measurement(seen, c)]

    def find(self, c: Content) -> int | None:
        """The position of the first part seen that ``c`` repeats; None if none."""
        return next((i for seen, i in self._candidates(c) if same_measurement(seen, c)), None)

    def add(self, c: Content) -> int:
        """Keep ``c``; its position."""
        for name, k, cell in self._filed(c):
            self.cells.setdefault((name, c.time, k, cell), []).append((c, self.size))
            self.anytime.setdefault((name, None, k, cell), []).append((c, self.size))
        self.size += 1
        return self.size - 1


def first_copies(items: Sequence[Content]) -> list[int | None]:
    """For each part, the index of the earlier part it repeats (the first one kept), or None: a part of its own.

    A repeat is not kept, so a chain of near values is not merged step by step beyond the rule.
    """
    index = ContentIndex()
    kept: list[int] = []
    out: list[int | None] = []
    for i, c in enumerate(items):
        j = index.find(c)
        if j is None:
            index.add(c)
            kept.append(i)
            out.append(None)
        else:
            out.append(kept[j])
    return out
