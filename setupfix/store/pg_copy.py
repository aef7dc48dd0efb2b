"""One machine's measurement rows read from PostgreSQL through the driver's ``COPY … TO STDOUT``.

Building the history frame from row tuples (``fetchall`` then ``DataFrame.from_records``) costs
Python one object per cell: about 5 million for a machine-year (245,280 rows × 21 columns).
Here the server writes the rows as one CSV stream, and pandas' C parser turns it into columns;
the result is the same frame, cell for cell and dtype for dtype, as
:meth:`setupfix.store.sql.SQLStore.measurements` builds (``tests/store/test_pg_copy.py``).

At plant scale (16 M rows, ``bench/results/store_scale_read.txt``) the stream's query is what
costs: joined to ``report`` and filtered by machine, PostgreSQL plans a parallel scan of every
report with a sort, and compiles it (JIT).  So the machine's report ids are read first (through
the ``report(machine, id)`` index), and the rows are taken from ``measurement``'s primary key by
``report_id = ANY(ids)``, already in import order, with JIT off for that one statement.  Server-side
arrays (``string_agg(float8send(x))``, ``json_agg(text)``) were measured too: no faster than the
stream, so not used.

Exactness:

* numbers: PostgreSQL (12 and later) writes a ``double precision`` as its shortest round-trip
  text, and the parser reads it back to the same double; a NULL is NaN, as before;
* text: NULL is written as ``\\N`` and read as missing (``None``), an empty text stays ``""``;
  a stored text that *is* ``\\N`` would be indistinguishable in the stream, so the query
  flags such rows and the caller falls back to the row read (:func:`read_rows` returns ``None``).
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

__all__ = ["read_rows"]

#: The text a NULL is written as in the stream.
NULL_MARK = "\\N"


def read_rows(
    conn: Any, machine: str, *, include_excluded: bool, columns: Sequence[str], numeric: Sequence[str]
) -> pd.DataFrame | None:
    """``machine``'s rows as the history frame, or ``None`` when the stream cannot carry them exactly.

    ``conn`` is a psycopg 3 connection; ``columns`` the canonical columns (their order kept),
    ``numeric`` those stored as ``double precision``.  The frame has ``columns`` then
    ``reference`` (bool) and ``report_sha256``, rows in import order (report id, then row), the
    excluded reports left out unless ``include_excluded``.  ``None`` also for no rows (the caller's
    empty frame keeps its own dtypes).
    """
    text = [c for c in columns if c not in numeric]
    flag = " OR ".join(f"m.{c} = '{NULL_MARK}'" for c in text) or "false"
    where = "" if include_excluded else "AND excluded IS NULL"
    shas = dict(
        conn.execute(f"SELECT id, sha256 FROM report WHERE machine = %s {where} ORDER BY id", (machine,)).fetchall()
    )
    if not shas:
        return None
    sql = (
        f"COPY (SELECT {', '.join(f'm.{c}' for c in columns)}, m.reference, m.report_id, "
        f"CASE WHEN {flag} THEN 1 ELSE 0 END FROM measurement m WHERE m.report_id = ANY(%s) "
        f"ORDER BY m.report_id, m.row) TO STDOUT (FORMAT CSV, NULL '{NULL_MARK}')"
    )
    with conn.transaction(), conn.cursor() as cur:
        cur.execute("SET LOCAL jit = off")  # compiling the scan costs more than it saves (a machine-year)
        with cur.copy(sql, (list(shas),)) as copy:
            stream = b"".join([bytes(chunk) for chunk in copy])
    if not stream:
        return None
    names = [*columns, "reference", "report_id", "marked"]
    dtypes: dict[str, Any] = {c: (np.float64 if c in numeric else object) for c in columns}
    dtypes.update(reference=np.int64, report_id=np.int64, marked=np.int64)
    raw = pd.read_csv(
        io.BytesIO(stream),
        names=names,
        header=None,
        dtype=dtypes,
        keep_default_na=False,
        na_values={c: [NULL_MARK] for c in columns},
        encoding="utf-8",
    )
    if bool(raw["marked"].to_numpy().any()):
        return None
    ids, inverse = np.unique(raw["report_id"].to_numpy(), return_inverse=True)
    data: dict[str, Any] = {}
    for c in columns:
        if c in numeric:
            data[c] = raw[c].to_numpy(dtype=np.float64)
        else:
            values = raw[c].to_numpy(dtype=object, copy=True)
            values[pd.isna(values)] = None
            data[c] = values
    data["reference"] = raw["reference"].to_numpy() != 0
    data["report_sha256"] = np.array([shas[int(i)] for i in ids], dtype=object)[inverse]
    return pd.DataFrame(data)
