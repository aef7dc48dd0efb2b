"""``setupfix thermal fit|predict|evaluate``: thermal-drift models on temperature logs."""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Iterable
from typing import Any

from setupfix.cli.choices import THERMAL_METHODS
from setupfix.cli.common import positive_number, whole_number
from setupfix.cli.exit_codes import OK
from setupfix.core.errors import Note

__all__ = ["add_parser", "run"]


def _columns(text: str | None) -> list[str] | None:
    return [c.strip() for c in text.split(",") if c.strip()] if text else None


def _log_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--interval",
        type=positive_number(1e9),
        default=None,
        metavar="SECONDS",
        help="sampling interval of a log without a timestamp column",
    )
    p.add_argument("--sheet", default=None, metavar="NAME", help="worksheet of an .xlsx log (default: the first)")
    p.add_argument("--json", action="store_true", help="machine-readable output")


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--method", required=True, choices=THERMAL_METHODS, help="thermal model")
    p.add_argument("--target", required=True, metavar="COL", help="measured thermal-error column")
    p.add_argument(
        "--unit",
        choices=("um", "mm"),
        default=None,
        help="unit of the error column (stored with the model; needed by correct --thermal)",
    )
    p.add_argument(
        "--inputs",
        metavar="COL,COL",
        help="temperature columns (default: every numeric column "
        "but the target, spindle_speed and, for kalman, the ambient one)",
    )
    p.add_argument(
        "--ambient",
        metavar="COL",
        help="kalman: ambient temperature column (default: 'ambient' if present, else constant)",
    )
    p.add_argument(
        "--speed",
        metavar="COL",
        help="kalman: spindle speed column in rpm (default: 'spindle_speed' if "
        "present, else the ambient-only fallback)",
    )
    p.add_argument(
        "--seed",
        type=whole_number(0, 2**63 - 1, "a whole number >= 0"),
        default=None,
        help="seed of the stochastic calibrations (default 0)",
    )
    p.add_argument(
        "--iterations",
        type=whole_number(1, 100_000),
        default=None,
        help="grey-cs/grey-pso iterations (paper: 100); kalman GA generations (60)",
    )
    p.add_argument(
        "--bound",
        type=positive_number(1e9),
        default=None,
        help="grey-cs/grey-pso search box ±BOUND for every coefficient (paper: 100)",
    )
    p.add_argument(
        "--form",
        choices=("trapezoid", "tien"),
        default=None,
        help="grey: discretisation of the response (eq. 2 trapezoid, or Tien's form)",
    )
    _log_options(p)


def add_parser(subparsers: Any) -> None:
    """Register ``thermal`` and its sub-commands."""
    parser = subparsers.add_parser(
        "thermal",
        help="fit, apply and evaluate thermal-drift models",
        description="Thermal-drift models (MRA, Grey GMC(1,N), Kalman fusion) on temperature logs.",
    )
    sub = parser.add_subparsers(dest="thermal_command", metavar="ACTION", parser_class=type(parser))
    fit = sub.add_parser("fit", help="fit a model on a temperature log and save it as JSON")
    _common(fit)
    fit.add_argument("--axis", default="Z", choices=("X", "Y", "Z"), help="axis the error acts along (default Z)")
    fit.add_argument(
        "--registers",
        metavar="ID,ID",
        default=None,
        help="registers the drift moves (default: every tool-length register, spindle growth)",
    )
    fit.add_argument("data", metavar="DATA", help="temperature log (CSV or .xlsx)")
    fit.add_argument("-o", "--output", required=True, metavar="MODEL.json", help="model file to write")
    fit.set_defaults(run=run, action="fit")
    pred = sub.add_parser("predict", help="predict the thermal error over a temperature log")
    pred.add_argument("--model", required=True, metavar="MODEL.json")
    pred.add_argument("data", metavar="DATA", help="temperature log (CSV or .xlsx)")
    pred.add_argument("-o", "--output", metavar="CSV", help="write time,predicted[,measured] here ('-': stdout)")
    pred.add_argument(
        "--sensors-failed",
        action="store_true",
        help="kalman with a spindle speed only: ignore every reading (lumped-mass model alone)",
    )
    pred.add_argument(
        "--anchor",
        default=None,
        metavar="TIME=ERROR|first",
        help="re-base the prediction on a measured error (default: the model's reference state)",
    )
    _log_options(pred)
    pred.set_defaults(run=run, action="predict")
    ev = sub.add_parser("evaluate", help="fit on one log, report the prediction accuracy on another")
    _common(ev)
    ev.add_argument("--train", required=True, metavar="LOG")
    ev.add_argument("--test", required=True, metavar="LOG")
    ev.add_argument("--anchor", default=None, metavar="TIME=ERROR|first", help="re-base the test prediction")
    ev.set_defaults(run=run, action="evaluate")


def _params(args: argparse.Namespace) -> dict[str, Any]:
    from setupfix.thermal.registry import get_method

    spec = get_method(args.method)
    params: dict[str, Any] = {}
    if args.seed is not None:
        if spec.stochastic:
            params["seed"] = args.seed
        else:
            print(f"warning: --seed has no effect on the deterministic {args.method} method", file=sys.stderr)
    if args.method == "kalman" and args.iterations is not None:
        params["generations"] = args.iterations  # the GA's generations: kalman's search budget
        args.iterations = None
    for option, name in (("iterations", "iterations"), ("bound", "bound"), ("form", "form")):
        value = getattr(args, option)
        if value is not None:
            if not args.method.startswith("grey-") or (option != "form" and not spec.stochastic):
                from setupfix.core.errors import ParameterError

                raise ParameterError(f"--{option} does not apply to the {args.method} method")
            params[name] = value
    return params


def _fit_options(args: argparse.Namespace) -> dict[str, Any]:
    return {
        "inputs": _columns(args.inputs),
        "ambient": args.ambient,
        "speed": args.speed,
        "unit": args.unit,
        "params": _params(args),
        "interval": args.interval,
        "sheet": args.sheet,
    }


def _num(x: float | None) -> float | None:
    return x if x is not None and math.isfinite(x) else None


def _fmt(x: float) -> str:
    return f"{x:.4g}" if math.isfinite(x) else "undefined"


def _unit(unit: str | None) -> str:
    return f" {unit.replace('um', 'µm')}" if unit else " (unit not stated)"


def _warn(notes: Iterable[Note]) -> list[str]:
    texts = []
    for note in notes:
        print(f"warning: {note}", file=sys.stderr)
        texts.append(str(note))
    return texts


def run(args: argparse.Namespace) -> int:
    """Dispatch to :mod:`setupfix.thermal.prediction` and :mod:`setupfix.usecases.thermal_fit`; printing only."""
    from setupfix.inputs.thermal_files import check_target, predict_drift, prediction_csv, write_text
    from setupfix.thermal import prediction as pipe
    from setupfix.usecases import thermal_fit

    if getattr(args, "output", None):
        check_target(args.output)  # a folder, device, FIFO or link is refused before any work
    if args.action == "fit":
        result = thermal_fit.fit_file(
            args.data,
            args.method,
            target=args.target,
            out=args.output,
            axis=args.axis,
            registers=_columns(args.registers),
            **_fit_options(args),
        )
        saved, tr = result.saved, result.saved.train
        warnings = _warn(result.notes)
        if args.json:
            print(
                json.dumps(
                    {
                        "method": args.method,
                        "model": args.output,
                        "inputs": list(saved.inputs),
                        "unit": saved.unit,
                        "rmse": _num(tr["rmse"]),
                        "max_residual": _num(tr["max_residual"]),
                        "efficiency": _num(tr["efficiency"]),
                        "n_train": tr["n"],
                        "seed": tr.get("seed"),
                        "speed": saved.speed,
                        "ambient": saved.ambient,
                        "warnings": warnings,
                    }
                )
            )
        else:
            seed = f", seed {tr['seed']}" if tr.get("seed") is not None else ""
            print(
                f"{args.method} on {len(saved.inputs)} inputs ({', '.join(saved.inputs)}), {tr['n']} samples{seed}: "
                f"fit RMSE {_fmt(tr['rmse'])}{_unit(saved.unit)}, max residual {_fmt(tr['max_residual'])}, "
                f"E {_fmt(tr['efficiency'])}"
            )
            print(f"model written to {args.output}")
        return OK
    if args.action == "predict":
        anchor = pipe.parse_anchor(args.anchor) if args.anchor else None
        drift = predict_drift(
            args.model, args.data, sensors_failed=args.sensors_failed, anchor=anchor, interval=args.interval
        )
        if args.output:
            write_text(args.output, prediction_csv(drift))
        warnings = _warn(drift.notes)
        if args.json:
            out: dict[str, Any] = {
                "method": drift.method,
                "target": drift.target,
                "unit": drift.unit,
                "n": int(drift.drift.size),
                "latest": _num(drift.latest),
                "predicted": [_num(float(v)) for v in drift.drift],
                "warnings": warnings,
            }
            if drift.rmse is not None:
                out["rmse"] = _num(drift.rmse)
            print(json.dumps(out))
        elif args.output != "-":
            print(
                f"{drift.method}: predicted {drift.target} at the last sample "
                f"{_fmt(drift.latest)}{_unit(drift.unit)} "
                f"relative to the model's reference state ({drift.drift.size} samples)"
            )
        return OK
    anchor = pipe.parse_anchor(args.anchor) if args.anchor else None
    opts = _fit_options(args)
    ev = thermal_fit.evaluate_files(
        args.train,
        args.test,
        args.method,
        target=args.target,
        anchor=anchor,
        interval=opts.pop("interval"),
        sheet=opts.pop("sheet"),
        **opts,
    )
    _warn(ev.notes)
    if args.json:
        print(json.dumps({k: (_num(v) if isinstance(v, float) else v) for k, v in ev.as_json().items()}))
    else:
        t = ev.test
        seed = f", seed {ev.saved.train['seed']}" if ev.saved.train.get("seed") is not None else ""
        print(
            f"{ev.method}: test RMSE {_fmt(t.rmse)}{_unit(ev.saved.unit)}, max residual {_fmt(t.max_residual)}, "
            f"E {_fmt(t.efficiency)} on {t.n} samples (fit RMSE {_fmt(ev.train.rmse)}{seed})"
        )
    return OK
