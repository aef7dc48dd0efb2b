"""The drift a saved thermal model predicts over a temperature log, anchored where the user says.

Shared by ``setupfix thermal fit|predict|evaluate``, ``setupfix correct --thermal``,
the diagnosis and the operator TUI; the file-level entry (a model file and a log file) is
:func:`setupfix.inputs.thermal_files.predict_drift`.  Nothing here reads a file or prints:
notes (warnings) come back as data with each result.  Column roles and the plausibility of the
values are checked by :mod:`setupfix.thermal.columns` before the model runs; fitting and
evaluating a model (with its quality gates) is :mod:`setupfix.usecases.thermal_fit`.
"""

from dataclasses import dataclass
from datetime import datetime

import numpy as np
import numpy.typing as npt

from parsers.temperature import TemperatureLog
from setupfix.core.errors import Note, ParameterError, ParseError, SourceLocation
from setupfix.thermal.columns import Selection, drive_arrays
from setupfix.thermal.estimator import rebase
from setupfix.thermal.kalman_model import KalmanFusionModel
from setupfix.thermal.persist import SavedModel
from setupfix.thermal.registry import methods

__all__ = [
    "methods",
    "Anchor",
    "parse_anchor",
    "predict_log",
    "drive_notes",
    "far_from_reference",
    "sample_at",
    "DriftPrediction",
]

Array = npt.NDArray[np.float64]
#: Distance from the reference state (K) beyond which ``evaluate`` warns.
FAR_FROM_REFERENCE_K = 2.0


def drive_notes(saved: SavedModel, source: str) -> list[Note]:
    if not isinstance(saved.model, KalmanFusionModel):
        return []
    out = []
    if saved.speed is None:
        out.append(
            Note(
                "kalman without a spindle speed: lumped masses exchange heat with the ambient only "
                "(no heat input); give --speed COL when the log has one",
                SourceLocation(source),
                "fallback",
            )
        )
    if saved.ambient is None:
        out.append(
            Note(
                f"kalman without an ambient column: ambient taken as constant "
                f"{saved.model.ambient_const_:.4g} (median reference temperature)",
                SourceLocation(source),
                "fallback",
            )
        )
    return out


@dataclass(frozen=True)
class Anchor:
    """A measured error that re-bases a prediction: at ``time`` (ISO timestamp or sample number) or ``first``."""

    time: str
    error: float | None = None


def parse_anchor(text: str) -> Anchor:
    """``first`` or ``TIME=ERROR`` (``--anchor``); :class:`ParameterError` otherwise."""
    text = text.strip()
    if text == "first":
        return Anchor("first")
    time, sep, value = text.rpartition("=")
    from parsers.temperature.reader import strict_number

    number = strict_number(value) if sep else None
    if not time.strip() or number is None:
        raise ParameterError(
            f"--anchor must be 'first' or TIME=ERROR, got {text!r}", hint="e.g. --anchor 2026-01-05T08:00:00=0.004"
        )
    return Anchor(time.strip(), number)


def sample_at(log: TemperatureLog, time: str) -> int:
    """Index of the last sample at or before ``time`` (ISO timestamp, or a sample number without timestamps)."""
    if log.timestamps:
        try:
            when = datetime.fromisoformat(time.replace("Z", "+00:00"))
            stamps = [datetime.fromisoformat(s.replace("Z", "+00:00")) for s in log.timestamps]
            idx = (
                int(
                    np.searchsorted(
                        np.array([(s - stamps[0]).total_seconds() for s in stamps]),
                        (when - stamps[0]).total_seconds(),
                        side="right",
                    )
                )
                - 1
            )
        except (ValueError, TypeError):
            raise ParameterError(
                f"time {time!r} is not an ISO 8601 time comparable with the log's timestamps",
                hint="e.g. 2026-01-05T08:00:00",
            ) from None
    else:
        if not time.isdigit():
            raise ParameterError(f"the log has no timestamps: give a sample number, not {time!r}")
        idx = int(time)
    if idx < 0 or idx >= log.n:
        raise ParameterError(f"time {time} is outside the log ({log.source}: samples 0–{log.n - 1})")
    return idx


def predict_log(
    saved: SavedModel, log: TemperatureLog, *, anchor: Anchor | None = None, sensors_failed: bool = False
) -> tuple[Array, list[Note]]:
    """Predicted thermal error for every sample of ``log`` (the target's unit) and the notes.

    Relative to the model's reference state; ``anchor`` re-bases it on a measured
    error.  A sampling interval unlike the training one is noted: Grey and lumped-mass
    coefficients are per sample.
    """
    notes: list[Note] = []
    interval = log.sample_interval_s
    trained = saved.sample_interval_s
    if trained and interval and abs(interval - trained) > 0.05 * trained:
        notes.append(
            Note(
                f"sampled every {interval:g} s but the model was fitted on {trained:g} s; "
                "its time constants are per sample",
                log.location(),
                "thermal",
            )
        )
    sel = Selection(saved.inputs, None, saved.ambient, saved.speed)
    data = drive_arrays(log, sel, gaps=isinstance(saved.model, KalmanFusionModel))
    drives = {"ambient": data["ambient"], "speed": data["speed"]} if isinstance(saved.model, KalmanFusionModel) else {}
    with np.errstate(all="ignore"):
        pred = saved.model.predict(data["T"], sensors_failed=sensors_failed, **drives)
    if anchor is not None:
        if anchor.time == "first":
            measured = log.columns.get(saved.target)
            if measured is None or not np.isfinite(measured[0]):
                raise ParseError(
                    f"--anchor first needs the error column {saved.target!r} at the first sample",
                    location=log.location(0),
                )
            pred = rebase(pred, 0, float(measured[0]))
        else:
            pred = rebase(pred, sample_at(log, anchor.time), float(anchor.error))  # type: ignore[arg-type]  # anchor.time is a timestamp on this branch
    if not np.all(np.isfinite(pred)):
        raise ParseError(
            f"the {saved.model.name} model diverges on this log (non-finite prediction)",
            location=log.location(),
            hint="refit, or use mra",
        )
    return pred, notes


def far_from_reference(saved: SavedModel, log: TemperatureLog) -> Note | None:
    """A note when the log's first temperatures are more than :data:`FAR_FROM_REFERENCE_K` from the reference."""
    first = np.array([log.columns[c][0] if c in log.columns else np.nan for c in saved.inputs])
    gap = np.abs(first - saved.model.T_ref_)
    if np.any(np.isfinite(gap)) and np.nanmax(gap) > FAR_FROM_REFERENCE_K:
        j = int(np.nanargmax(gap))
        return Note(
            f"the log starts {gap[j]:.3g} K from the model's reference state ({saved.inputs[j]}): "
            "predicted relative to the reference; dynamic models start from these temperatures",
            log.location(0),
            "thermal",
        )
    return None


@dataclass(frozen=True)
class DriftPrediction:
    """Predicted thermal drift of one log, for display beside the corrections."""

    method: str
    target: str
    unit: str | None
    timestamps: list[str]
    seconds: Array | None
    drift: Array  #: (n,) predicted thermal error relative to the reference state, target unit
    measured: Array | None = None  #: (n,) the log's own target column when present
    notes: tuple[Note, ...] = ()

    @property
    def latest(self) -> float:
        """Predicted error at the last sample, relative to the model's reference state.

        Not what to add to a correction: the last correction already absorbed the
        drift up to the time its measured parts were cut (see
        :func:`setupfix.thermal.feedforward.drift_change`).
        """
        return float(self.drift[-1])

    @property
    def rmse(self) -> float | None:
        """RMS error of the prediction against the log's own target column (None without one)."""
        if self.measured is None:
            return None
        from setupfix.thermal.metrics import score

        return float(score(self.measured, self.drift).rmse)
