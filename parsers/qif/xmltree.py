"""Parsing untrusted XML safely.

A QIF document is defined by an XML schema and never needs a DTD, so any document
type declaration is refused before lxml sees the bytes: that stops entity expansion
bombs ("billion laughs") and external entities (local files, network) outright.
The lxml parser is configured defensively as well, in case a declaration slips past
the byte check: no entity resolution, no DTD loading, no network, no huge-tree mode.
"""

from __future__ import annotations

import re

from lxml import etree

from setupfix.core.errors import ParseError, SourceLocation

__all__ = ["parse_xml"]

#: ``<!DOCTYPE`` or ``<!ENTITY`` anywhere: QIF has no use for either.
_DTD = re.compile(rb"<!(?:DOCTYPE|ENTITY)", re.IGNORECASE)
#: ", line 12, column 3" that libxml2 appends; the location already says the line.
_POSITION = re.compile(r",? line \d+, column \d+.*$|\s*\(line \d+.*$")


def safe_parser() -> etree.XMLParser:
    return etree.XMLParser(
        resolve_entities=False,
        no_network=True,
        load_dtd=False,
        dtd_validation=False,
        huge_tree=False,
        remove_comments=True,
        remove_pis=True,
    )


def parse_xml(data: bytes, path: str) -> etree._Element:
    """Parse XML bytes into the root element, refusing DTDs and entities.

    Parameters
    ----------
    data : bytes
        The whole file; lxml reads the encoding from the XML declaration or BOM.
    path : str
        Used in error messages.

    Raises
    ------
    ParseError
        If the document declares a DTD or entities, or is not well-formed XML
        (with the line libxml2 reports).
    """
    if data[:2] in (b"\xff\xfe", b"\xfe\xff") or b"\x00" in data[:4]:
        # UTF-16/UTF-32, either byte order, with or without BOM (XML 1.0 appendix F): look
        # for the declarations in every wide decoding; a wrong one only yields noise.
        match, line = None, 0
        for codec in ("utf-16-le", "utf-16-be", "utf-32-le", "utf-32-be"):
            width = 4 if "32" in codec else 2
            text = data[: len(data) - len(data) % width].decode(codec, errors="replace").encode("utf-8", "replace")
            match = _DTD.search(text)
            if match:
                line = text[: match.start()].count(b"\n") + 1
                break
    else:
        start = data.find(b"<!")  # memchr-fast; the regex only runs from the first "<!" on
        match = _DTD.search(data, start) if start >= 0 else None
        line = data[: match.start()].count(b"\n") + 1 if match else 0
    if match:
        raise ParseError(
            "document type or entity declarations are not accepted in a report",
            location=SourceLocation(path, line=line),
            hint="entity expansion and external entities are refused for safety",
        )
    try:
        root = etree.fromstring(data, safe_parser())
    except etree.XMLSyntaxError as exc:
        error_line = exc.lineno if exc.lineno and exc.lineno > 0 else None
        message = _POSITION.sub("", str(exc.msg or exc)).strip() or "not well-formed XML"
        raise ParseError(f"not well-formed XML: {message}", location=SourceLocation(path, line=error_line)) from None
    except ValueError as exc:  # lxml raises ValueError for e.g. unsupported encodings
        raise ParseError(f"not well-formed XML: {exc}", location=SourceLocation(path)) from None
    docinfo = root.getroottree().docinfo
    if docinfo.doctype or docinfo.internalDTD is not None:
        # A declaration in an encoding the byte check cannot see (EBCDIC, …): refuse all the same.
        raise ParseError(
            "document type or entity declarations are not accepted in a report",
            location=SourceLocation(path),
            hint="entity expansion and external entities are refused for safety",
        )
    return root
