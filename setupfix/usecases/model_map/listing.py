"""The questions of a ``model init`` scaffold, read from the model file (:mod:`setupfix.usecases.model_map`)."""

from __future__ import annotations

import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from setupfix.core.errors import ModelError, SourceLocation
from setupfix.model import model_from_dict
from setupfix.model.axes import AXIS_NAMES
from setupfix.outputs.model_toml import QUESTION_KEY

__all__ = [
    "MapFeature",
    "Question",
    "MapListing",
    "map_listing",
    "listing_of",
    "read_model_text",
    "model_document",
    "QUESTION",
    "HEADER",
    "TABLE_KEY",
]

#: A feature's open question in its ``note``: its name, text and (a size) the radius weight its tool gets.
QUESTION = re.compile(r"^question (Q\d+): (.*?)(?: \(radius weight (-?\d+(?:\.\d+)?)\))?$")
#: A table header ``[features.F3]`` (``[features."F 3"]``): the section and the ID.
HEADER = re.compile(r'^\s*\[\s*([A-Za-z_]+)\s*\.\s*(?:"([^"]+)"|([A-Za-z0-9_-]+))\s*\]')
#: A ``key = value`` line of a table: the key.
TABLE_KEY = re.compile(r"^\s*([A-Za-z_]+)\s*=")


@dataclass(frozen=True)
class MapFeature:
    """One model feature as ``model map`` shows it."""

    id: str
    label: str
    position: tuple[float, ...] | None
    role: str  # "location" or "size"
    radius_weight: float | None
    callouts: tuple[str, ...]
    groups: tuple[str, ...]
    wks: Mapping[str, Any]
    tools: Mapping[str, Any]
    radius: Mapping[str, Any]
    question: str
    #: A dimension it enters sees it along the spindle axis: its tool's length offset moves that dimension.
    along_spindle: bool = False


@dataclass(frozen=True)
class Question:
    """One open question and the features it is asked of (a part feature's location and sizes)."""

    name: str
    text: str
    features: tuple[MapFeature, ...]

    @property
    def needs_wks(self) -> bool:
        """True when a located feature asks for its work offset (a size only asks for the tool)."""
        return any(f.role == "location" for f in self.features)

    @property
    def label(self) -> str:
        return self.features[0].label

    @property
    def callouts(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(c for f in self.features for c in f.callouts))


@dataclass(frozen=True)
class MapListing:
    """A model's features, its open questions and the registers it declares."""

    source: str
    features: tuple[MapFeature, ...]
    questions: tuple[Question, ...]
    wks: Mapping[str, str]  # ID → register
    tools: Mapping[str, str]
    draft: bool

    def to_json(self) -> dict[str, Any]:
        """The listing as JSON (``model map --json``)."""
        return {
            "model": self.source,
            "draft": self.draft,
            "wks": dict(self.wks),
            "tools": dict(self.tools),
            "questions": [
                {
                    "name": q.name,
                    "text": q.text,
                    "label": q.label,
                    "callouts": list(q.callouts),
                    "features": [
                        {
                            "id": f.id,
                            "role": f.role,
                            "position": list(f.position) if f.position is not None else None,
                            "radius_weight": f.radius_weight,
                            "groups": list(f.groups),
                        }
                        for f in q.features
                    ],
                }
                for q in self.questions
            ],
        }


def read_model_text(path: str | Path) -> str:
    try:
        return Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ModelError("no such model file", location=SourceLocation(str(path))) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelError(f"cannot read the model: {exc}", location=SourceLocation(str(path))) from None


def model_document(text: str, source: str) -> dict[str, Any]:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ModelError(f"not TOML: {exc}", location=SourceLocation(source)) from None


def listing_of(text: str, source: str) -> MapListing:
    doc = model_document(text, source)
    model = model_from_dict(doc, source, text)  # refuse a model that does not load, as every command does
    k = AXIS_NAMES.index(model.spindle)
    spindle_seen: set[str] = set()  # features a dimension sees along the spindle: a tool length moves those
    for dim in model.dimensions:
        if dim.kind == "size":
            continue
        n = dim.direction if dim.direction is not None else tuple(float(a == model.axis) for a in AXIS_NAMES)
        if (model.spindle in dim.plane) if dim.zone else abs(n[k]) > 1e-9:
            spindle_seen.update(dim.features)
    raw_features = doc.get("features", {})
    callouts: dict[str, list[str]] = {}
    groups: dict[str, list[str]] = {}
    for dim in doc.get("dimensions", {}).values():
        for fid in dim.get("features", {}):
            callouts.setdefault(fid, []).append(str(dim.get("name", "")))
            if dim.get("group"):
                groups.setdefault(fid, []).append(str(dim["group"]))
    features = []
    labels = _labels(text)
    for fid, table in raw_features.items():
        note = table.get(QUESTION_KEY)
        match = QUESTION.match(note) if isinstance(note, str) else None
        comment_label = fid
        position = table.get("position")
        radius_weight = float(match.group(3)) if match and match.group(3) else None
        role = "size" if ("radius" in table and "wks" not in table) or radius_weight is not None else "location"
        features.append(
            MapFeature(
                fid,
                labels.get(fid) or comment_label,
                tuple(float(v) for v in position) if isinstance(position, list) else None,
                role,
                radius_weight,
                tuple(dict.fromkeys(callouts.get(fid, []))),
                tuple(dict.fromkeys(groups.get(fid, []))),
                table.get("wks", {}) if isinstance(table.get("wks"), dict) else {},
                table.get("tools", {}) if isinstance(table.get("tools"), dict) else {},
                table.get("radius", {}) if isinstance(table.get("radius"), dict) else {},
                match.group(1) if match else "",
                fid in spindle_seen,
            )
        )
    asked: dict[str, list[MapFeature]] = {}
    texts: dict[str, str] = {}
    for f in features:
        if f.question:
            asked.setdefault(f.question, []).append(f)
            if f.role == "location" or f.question not in texts:
                texts[f.question] = _ask(f)
    questions = tuple(Question(q, texts[q], tuple(fs)) for q, fs in asked.items())
    return MapListing(
        source,
        tuple(features),
        questions,
        {k: str(v.get("register", k)) for k, v in doc.get("wks", {}).items()},
        {k: str(v.get("register", k)) for k, v in doc.get("tools", {}).items()},
        bool(doc.get("process", {}).get("draft", False)),
    )


def _ask(f: MapFeature) -> str:
    return "which tool cut it?" if f.role == "size" else "which work offset (WKS) and which tool made it?"


def _labels(text: str) -> dict[str, str]:
    """Feature ID → the report's feature name the scaffold wrote after its header (``# CYLINDER2 (a …)``)."""
    out = {}
    for line in text.splitlines():
        m = HEADER.match(line)
        if m and m.group(1) == "features" and "#" in line:
            after = line.split("#", 1)[1].strip()
            out[m.group(2) or m.group(3)] = after.split(" (")[0].split(";")[0].strip()
    return out


def map_listing(model: str | Path) -> MapListing:
    """The model's features and open questions.

    Raises
    ------
    ModelError
        If the file cannot be read or does not load.
    """
    return listing_of(read_model_text(model), str(model))
