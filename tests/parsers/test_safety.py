"""Hostile XML: entity bombs, external entities and DTDs, deep nesting — all refused, fast,
without touching the file system or the network."""

from __future__ import annotations

import socket
from collections.abc import Iterator
from pathlib import Path

import pytest

import parsers
from parsers.qif.xmltree import parse_xml, safe_parser
from setupfix.core.errors import ParseError

BILLION_LAUGHS = """<?xml version="1.0"?>
<!DOCTYPE lolz [
 <!ENTITY lol "lol">
 <!ENTITY lol1 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">
 <!ENTITY lol2 "&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;">
 <!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;">
 <!ENTITY lol4 "&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;">
 <!ENTITY lol5 "&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;">
 <!ENTITY lol6 "&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;">
 <!ENTITY lol7 "&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;">
 <!ENTITY lol8 "&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;">
 <!ENTITY lol9 "&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;">
]>
<QIFDocument xmlns="http://qifstandards.org/xsd/qif3"><QPId>&lol9;</QPId></QIFDocument>
"""

EXTERNAL_FILE = """<?xml version="1.0"?>
<!DOCTYPE QIFDocument [<!ENTITY secret SYSTEM "file://{target}">]>
<QIFDocument xmlns="http://qifstandards.org/xsd/qif3"><QPId>&secret;</QPId></QIFDocument>
"""

EXTERNAL_DTD = """<?xml version="1.0"?>
<!DOCTYPE QIFDocument SYSTEM "http://127.0.0.1:{port}/evil.dtd">
<QIFDocument xmlns="http://qifstandards.org/xsd/qif3"/>
"""

PARAMETER_ENTITY = """<?xml version="1.0"?>
<!DOCTYPE r [<!ENTITY % remote SYSTEM "http://127.0.0.1:{port}/x.dtd"> %remote;]>
<QIFDocument xmlns="http://qifstandards.org/xsd/qif3"/>
"""


@pytest.fixture
def listener() -> Iterator[socket.socket]:
    """A local TCP socket that records whether anything connected to it."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(1)
    server.settimeout(0.2)
    yield server
    server.close()


def _connected(server: socket.socket) -> bool:
    try:
        conn, _ = server.accept()
    except TimeoutError:
        return False
    conn.close()
    return True


def _refused(path: Path) -> str:
    """The refusal's message (how long it takes is ``bench/work_limits.py``'s: tests never time)."""
    with pytest.raises(ParseError) as info:
        parsers.read_report(path).table
    return str(info.value)


def test_billion_laughs_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "bomb.qif"
    path.write_text(BILLION_LAUGHS, encoding="utf-8")
    message = _refused(path)
    assert "entity declarations are not accepted" in message and message.startswith(f"{path}:2")


def test_external_entity_is_refused_and_never_read(tmp_path: Path) -> None:
    secret = tmp_path / "secret.txt"
    secret.write_text("TOP-SECRET", encoding="utf-8")
    path = tmp_path / "xxe.qif"
    path.write_text(EXTERNAL_FILE.format(target=secret), encoding="utf-8")
    message = _refused(path)
    assert "TOP-SECRET" not in message and "not accepted" in message


@pytest.mark.parametrize("template", [EXTERNAL_DTD, PARAMETER_ENTITY], ids=["dtd", "parameter-entity"])
def test_external_dtd_is_refused_without_network(tmp_path: Path, listener: socket.socket, template: str) -> None:
    path = tmp_path / "dtd.qif"
    path.write_text(template.format(port=listener.getsockname()[1]), encoding="utf-8")
    _refused(path)
    assert not _connected(listener)


def test_utf16_doctype_is_refused_too(tmp_path: Path) -> None:
    path = tmp_path / "u16.qif"
    path.write_bytes(BILLION_LAUGHS.replace('version="1.0"?', 'version="1.0" encoding="UTF-16"?').encode("utf-16"))
    assert "not accepted" in _refused(path)


def test_parser_itself_resolves_nothing_even_past_the_byte_check(tmp_path: Path, listener: socket.socket) -> None:
    """Defence in depth: the lxml parser is configured to expand no entity and fetch nothing."""
    from lxml import etree

    secret = tmp_path / "secret.txt"
    secret.write_text("TOP-SECRET", encoding="utf-8")
    doc = (
        f'<!DOCTYPE r [<!ENTITY s SYSTEM "file://{secret}">'
        f'<!ENTITY % p SYSTEM "http://127.0.0.1:{listener.getsockname()[1]}/x"> %p;]><r>&s;</r>'
    ).encode()
    try:
        root = etree.fromstring(doc, safe_parser())
        text = etree.tostring(root).decode()
    except etree.XMLSyntaxError:
        text = ""
    assert "TOP-SECRET" not in text
    assert not _connected(listener)


def test_deep_nesting_is_refused_not_recursed(tmp_path: Path) -> None:
    depth = 100_000
    path = tmp_path / "deep.qif"
    path.write_text(
        '<QIFDocument xmlns="http://qifstandards.org/xsd/qif3">' + "<a>" * depth + "</a>" * depth + "</QIFDocument>",
        encoding="utf-8",
    )
    assert "not well-formed XML" in _refused(path)


def test_parse_xml_reports_the_line_of_a_syntax_error() -> None:
    with pytest.raises(ParseError, match=r"x\.qif:3: not well-formed XML"):
        parse_xml(b"<a>\n<b>\n</c>\n</a>", "x.qif")
