"""QIF id lookup, within one document and across documents.

Results may name a characteristic item of another QIF document: the
``CharacteristicItemId`` then carries ``xId`` (the id in the other document) and its
text is the id of an ``ExternalQIFReferences/ExternalQIFDocument`` (QPId + URI).
The qif-community "exploded" samples (``QIF3_Exploded_Results1.QIF`` →
``./Exploded_Plan.QIF``) show that the URI need not match the file's current name,
so a plan beside the results is found by URI first, then by its QPId.  Only local
files beside the results are ever opened.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from lxml import etree

from parsers.qif.xmltree import parse_xml
from parsers.source import STDIN, read_bytes
from setupfix.core.errors import ParseError, SourceLocation

__all__ = ["IdIndex", "build_index", "resolve_external", "beside"]

#: Bytes of a sibling file searched for the referenced QPId (it is near the top).
_QPID_PEEK = 4096


@dataclass(frozen=True)
class IdIndex:
    """Elements of one QIF document by their ``id`` attribute."""

    local: dict[str, etree._Element]


#: Bulky containers of measured values: nothing in them is the target of an id reference
#: the reader follows, so they are left out of the index (half the elements of a
#: 20-part results file).
_NOT_INDEXED = frozenset({"MeasurementResultsSet", "MeasuredFeatures", "MeasuredCharacteristics"})


def build_index(root: etree._Element) -> IdIndex:
    """Index the elements carrying an ``id`` (the first one wins on duplicates)."""
    local: dict[str, etree._Element] = {}
    stack = [root]
    while stack:
        element = stack.pop()
        for child in element:
            if not isinstance(child.tag, str):
                continue
            name = child.tag.rpartition("}")[2]
            if name in _NOT_INDEXED and name != "MeasurementResultsSet":
                continue
            if name == "MeasurementResultsSet":
                # Only MeasurementResults themselves (ids of parts) and their components.
                stack.extend(child)
                continue
            ident = child.get("id")
            if ident is not None:
                local.setdefault(ident.strip(), child)
            stack.append(child)
    return IdIndex(local)


def _qpid(root: etree._Element) -> str:
    ns = etree.QName(root).namespace or ""
    return (root.findtext(f"{{{ns}}}QPId") or "").strip().lower()


def beside(folder: Path, uri: str) -> Path | None:
    """The file a plan URI names if it is a bare file name in ``folder``, else None.

    Only ``name.qif``, ``./name.qif`` or ``file://name.qif`` qualify: no absolute path,
    no ``..``, no other folder, no symbolic link out of the folder.  Whether a refused
    name exists is never looked at, so the error cannot reveal it.
    """
    rel = uri.removeprefix("file://").replace("\\", "/").removeprefix("./")
    if not rel or "/" in rel or rel in (".", "..") or ":" in rel:
        return None
    candidate = folder / rel
    try:
        return candidate if candidate.resolve().parent == folder else None
    except OSError:
        return None


def resolve_external(
    root: etree._Element, ns: str, path: str, doc_id: str, where: SourceLocation
) -> tuple[str, etree._Element]:
    """Find and parse the external QIF document ``doc_id`` of ``root``.

    Returns
    -------
    (path, root) of the external document.

    Raises
    ------
    ParseError
        If the reference is undeclared, not a local file, or no file beside ``path``
        holds the referenced document.
    """
    declared = None
    for ext in root.iterfind(f"{{{ns}}}ExternalQIFReferences/{{{ns}}}ExternalQIFDocument"):
        if (ext.get("id") or "").strip() == doc_id:
            declared = ext
            break
    if declared is None:
        raise ParseError(
            f"refers to external QIF document {doc_id}, which ExternalQIFReferences does not declare", location=where
        )
    uri = (declared.findtext(f"{{{ns}}}URI") or "").strip()
    qpid = (declared.findtext(f"{{{ns}}}QPId") or "").strip().lower()
    if "://" in uri and not uri.lower().startswith("file://"):
        raise ParseError(
            f"external plan {uri!r} is not a local file; setupfix does not fetch it",
            location=where,
            hint="download the plan and put it beside the results",
        )
    if path == STDIN:
        raise ParseError(
            "results read from standard input refer to an external plan; read them from their folder", location=where
        )
    folder = Path(path).parent.resolve()
    candidates: list[Path] = []
    named = beside(folder, uri) if uri else None
    if named is not None:
        candidates.append(named)
    try:
        siblings = sorted(p for p in folder.iterdir() if p.suffix.lower() == ".qif" and p.name != Path(path).name)
    except OSError:
        siblings = []
    candidates.extend(p for p in siblings if p.resolve().parent == folder)
    for candidate in candidates:
        try:
            if not candidate.is_file():
                continue
            if qpid and candidate in siblings:
                with open(candidate, "rb") as fh:
                    if qpid.encode() not in fh.read(_QPID_PEEK).lower():
                        continue
        except OSError:
            continue
        try:
            plan = parse_xml(read_bytes(candidate), str(candidate))
        except ParseError:
            if candidate in siblings:
                continue  # some other file beside: not the plan
            raise
        if not qpid or _qpid(plan) == qpid:
            return str(candidate), plan
    raise ParseError(
        f"results refer to characteristics in the external plan '{uri or qpid}', which is not beside the file",
        location=where,
        hint="put the QIF plan in the same folder as the results",
    )
