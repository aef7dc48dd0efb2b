"""Renderers of the use cases' results: text tables, the JSON contract, what the TUI shows, HTML pages."""
