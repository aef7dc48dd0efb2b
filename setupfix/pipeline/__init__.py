"""Use cases shared by the CLI, batch processing and the TUI.

Each module holds one family of use cases and returns plain result objects;
nothing here prints or parses arguments.
"""
