"""The one error hierarchy: messages name the place, and never carry terminal control characters."""

from __future__ import annotations

from setupfix.core.errors import ParseError, SourceLocation


def test_location_names_file_line_key_and_element() -> None:
    assert str(SourceLocation("r.csv", line=3)) == "r.csv:3"
    assert str(SourceLocation("m.toml", key="dimensions.D4")) == "m.toml: [dimensions.D4]"
    assert str(SourceLocation("r.qif", element="Value")) == "r.qif: <Value>"


def test_control_characters_in_a_file_name_do_not_reach_the_terminal() -> None:
    hostile = "evil\x1b[2J\x1b]0;pwned\x07.csv"
    text = str(ParseError("bad", location=SourceLocation(hostile, line=1)))
    assert "\x1b" not in text and "\x07" not in text
    assert text == "evil?[2J?]0;pwned?.csv:1: bad"
