"""setupfix: setup corrections for multi-part, multi-tool machining from CMM reports.

Layers, bottom to top (each imports only those below it):

1. :mod:`setupfix.model`, :mod:`setupfix.core.errors`, :mod:`setupfix.core.units` — plain data;
2. :mod:`parsers` — report readers producing the canonical measurement table;
3. engine — :mod:`setupfix.correction.relation`, :mod:`setupfix.correction.objective`, :mod:`setupfix.optimize`,
   :mod:`setupfix.thermal`, :mod:`setupfix.correction.offsets`;
4. :mod:`setupfix.pipeline` — the use cases shared by the CLI, batch and TUI;
5. :mod:`setupfix.cli`, :mod:`setupfix.tui`.
"""

__version__ = "0.1.0"
