"""Use cases shared by the CLI, batch processing and the TUI.

Typed requests in, plain results out; nothing here prints or parses arguments.  Renderers of the
results are in :mod:`setupfix.views`.
"""
