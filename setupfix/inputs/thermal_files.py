"""Thermal files at the edge: the model JSON (read and write), a prediction over a log file, the prediction CSV.

Reading goes through the size-limited reader of :mod:`parsers.source`; every problem
of a model file (not UTF-8, not JSON, a missing or mistyped entry, coefficients that
do not fit together) is one :class:`~setupfix.core.errors.ParseError` naming the file and
the entry.  Writing goes through :mod:`setupfix.outputs.writers` (only ``-`` or a
regular file; atomic).
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path
from typing import Any

from parsers.source import read_bytes
from parsers.temperature import TemperatureLog, read_temperature_log
from setupfix.core.errors import ExportError, Note, ParameterError, ParseError, SourceLocation
from setupfix.outputs.writers import check_target, write_text
from setupfix.thermal.persist import SavedModel, saved_from_dict
from setupfix.thermal.prediction import Anchor, DriftPrediction, drive_notes, predict_log

__all__ = ["save_model", "load_model", "predict_drift", "prediction_csv", "check_target", "write_text"]


def save_model(saved: SavedModel, path: str | Path) -> None:
    """Write ``saved`` as JSON; refuse non-finite coefficients (nothing written)."""
    check_target(path)
    try:
        text = json.dumps(saved.to_dict(), indent=2, allow_nan=False, default=_plain)
    except ValueError:
        raise ExportError(
            "the fitted model has non-finite coefficients and is not saved",
            location=SourceLocation(str(path)),
            hint="the calibration diverged; try grey-ls or mra",
        ) from None
    write_text(path, text + "\n", newline="\n")


def _plain(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"cannot store {type(value).__name__}")


def _no_constant(name: str) -> float:
    raise ValueError(f"{name} is not a number a model file may hold")


def load_model(path: str | Path) -> SavedModel:
    """Read a model written by :func:`save_model`.

    Raises
    ------
    ParseError
        Unreadable, not UTF-8, not JSON, another format or version, or a missing,
        mistyped or inconsistent entry — naming the file and the entry.
    """
    source = str(path)
    data = read_bytes(path)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ParseError(
            "not UTF-8 text: not a setupfix thermal model",
            location=SourceLocation(source, line=data[: exc.start].count(b"\n") + 1),
        ) from None
    try:
        doc = json.loads(text, parse_constant=_no_constant)
    except json.JSONDecodeError as exc:
        raise ParseError(f"not JSON: {exc.msg}", location=SourceLocation(source, line=exc.lineno)) from None
    except (ValueError, RecursionError) as exc:
        raise ParseError(f"not a setupfix thermal model: {str(exc)[:80]}", location=SourceLocation(source)) from None
    try:
        return saved_from_dict(doc)
    except ValueError as exc:
        key, reason = exc.args if len(exc.args) == 2 else ("model", str(exc))
        raise ParseError(
            str(reason), location=SourceLocation(source, key=str(key)), hint="write one with 'setupfix thermal fit'"
        ) from None
    except ParameterError as exc:
        raise ParseError(exc.message, location=SourceLocation(source, key="model")) from None


def prediction_csv(drift: Any) -> str:
    """The prediction as CSV text: time, predicted error[, measured error], unit in the header."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    unit = f" [{drift.unit}]" if drift.unit else ""
    header = ["timestamp" if drift.timestamps else "sample", f"predicted_{drift.target}{unit}"]
    if drift.measured is not None:
        header.append(f"{drift.target}{unit}")
    writer.writerow(header)
    for i, value in enumerate(drift.drift):
        row = [drift.timestamps[i] if i < len(drift.timestamps) else i, f"{value:.6g}"]
        if drift.measured is not None:
            row.append(f"{drift.measured[i]:.6g}")
        writer.writerow(row)
    return buf.getvalue()


def predict_drift(
    model: str | Path | SavedModel,
    log: str | Path | TemperatureLog,
    *,
    sensors_failed: bool = False,
    anchor: Anchor | None = None,
    interval: float | None = None,
) -> DriftPrediction:
    """Load a saved model (or take one) and predict the drift over a temperature log."""
    saved = model if isinstance(model, SavedModel) else load_model(model)
    data = (
        log
        if isinstance(log, TemperatureLog)
        else read_temperature_log(
            log, interval=interval if interval is not None else saved.sample_interval_s, require_time=False
        )
    )
    drift, notes = predict_log(saved, data, sensors_failed=sensors_failed, anchor=anchor)
    notes = list(data.notes) + drive_notes(saved, data.source) + notes
    if not data.timestamps and interval is None and saved.sample_interval_s is not None:
        notes.append(
            Note(
                f"no timestamp: samples taken {saved.sample_interval_s:g} s apart, as in training",
                data.location(),
                "thermal",
            )
        )
    measured = data.columns.get(saved.target)
    return DriftPrediction(
        saved.model.name, saved.target, saved.unit, list(data.timestamps), data.seconds, drift, measured, tuple(notes)
    )
