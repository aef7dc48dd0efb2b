"""setupfix: setup corrections for multi-part, multi-tool machining from CMM reports.

Layers, bottom to top (each imports only those below it):

1. :mod:`setupfix.core`, :mod:`setupfix.model` — plain data;
2. :mod:`parsers` — report readers producing the canonical measurement table;
3. engine — :mod:`setupfix.correction`, :mod:`setupfix.optimize`, :mod:`setupfix.search`,
   :mod:`setupfix.thermal`, :mod:`setupfix.diagnose`, :mod:`setupfix.spc`;
4. :mod:`setupfix.store`, :mod:`setupfix.inputs`, :mod:`setupfix.outputs`; then :mod:`setupfix.usecases`,
   shared by the CLI, batch and TUI; then :mod:`setupfix.views`;
5. :mod:`setupfix.cli`, :mod:`setupfix.tui`.
"""

__version__ = "0.1.0"
