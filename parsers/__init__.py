"""Postprocessors: CMM reports in their many formats → the canonical measurement table.

``read_report(path)`` returns a :class:`ReadResult`: the table and the reader's notes.
The table is a :class:`pandas.DataFrame` with the columns of
:data:`setupfix.model.CANONICAL_COLUMNS` (lengths in mm, ``deviation`` = actual −
nominal, limits as signed deviations, ``source`` = provenance of each row).  Each
format registers a :class:`FormatSpec`; importing this package registers the
built-in readers.
"""

from __future__ import annotations

from parsers import canonical as _canonical
from parsers.folders import FoundFile, Inputs, Listing, expand_inputs, list_reports
from parsers.registry import FormatSpec, ReadResult, find_format, formats, never_a_report, read, read_report, register
from parsers.source import STDIN, Source, final_line_break, load_source

__all__ = [
    "FormatSpec",
    "ReadResult",
    "Source",
    "STDIN",
    "find_format",
    "formats",
    "list_reports",
    "Listing",
    "FoundFile",
    "expand_inputs",
    "Inputs",
    "load_source",
    "never_a_report",
    "read",
    "read_report",
    "register",
]

register(
    FormatSpec(
        name="canonical",
        description="setupfix canonical measurement CSV (shared/spec/measurements.md)",
        extensions=(".csv",),
        sniff=lambda peek: _canonical.sniff_canonical(peek.text),
        read=_canonical.read_canonical,
        priority=10,
        complete=final_line_break,
    )
)
# Built-in readers register themselves on import; add one line per format package here.
from parsers import calypso as _calypso  # noqa: E402,F401 - registers its reader
from parsers import dmis as _dmis  # noqa: E402,F401 - registers its reader
from parsers import korean as _korean  # noqa: E402,F401 - registers its reader (issue 3: Korean CMM text, CP949)
from parsers import mitutoyo as _mitutoyo  # noqa: E402,F401 - registers its reader (issue 3: Mitutoyo QVPAK)
from parsers import ogp as _ogp  # noqa: E402,F401 - registers its reader (issue 3: OGP step report / run table)
from parsers import pcdmis as _pcdmis  # noqa: E402,F401 - registers its reader (issue 3: PC-DMIS text + CSV)
from parsers import piweb as _piweb  # noqa: E402,F401 - registers its reader (issue 3: PiWeb REST JSON)
from parsers import qdas as _qdas  # noqa: E402,F401 - registers its reader (issue 3: Q-DAS AQDEF)
from parsers import qif as _qif  # noqa: E402,F401 - registers its reader
from parsers import table as _table  # noqa: E402,F401 - registers its reader
