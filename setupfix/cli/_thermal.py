"""``setupfix thermal fit|predict|evaluate``: thermal-drift models on temperature logs."""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from setupfix.cli.exit_codes import OK

__all__ = ["add_parser", "run"]

_METHODS = ("mra", "grey-ls", "grey-cs", "grey-pso", "kalman")


def _columns(text: str | None) -> list[str] | None:
    return [c.strip() for c in text.split(",") if c.strip()] if text else None


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--method", required=True, choices=_METHODS, help="thermal model")
    p.add_argument("--target", required=True, metavar="COL", help="measured thermal-error column")
    p.add_argument("--inputs", metavar="COL,COL", help="temperature columns (default: every numeric column "
                   "but the target, spindle_speed and, for kalman, the ambient one)")
    p.add_argument("--ambient", metavar="COL", help="ambient temperature column for kalman (default: 'ambient')")
    p.add_argument("--seed", type=int, default=None, help="seed of the stochastic calibrations")
    p.add_argument("--iterations", type=int, default=None, help="grey-cs/grey-pso iterations (paper: 100)")
    p.add_argument("--bound", type=float, default=None,
                   help="grey-cs/grey-pso search box ±BOUND for every coefficient (paper: 100)")
    p.add_argument("--json", action="store_true", help="machine-readable output")


def add_parser(subparsers: Any) -> None:
    """Register ``thermal`` and its sub-commands."""
    parser = subparsers.add_parser("thermal", help="fit, apply and evaluate thermal-drift models",
                                   description="Thermal-drift models (MRA, Grey GMC(1,N), Kalman fusion) "
                                   "on temperature logs.")
    sub = parser.add_subparsers(dest="thermal_command", metavar="ACTION", parser_class=type(parser))
    fit = sub.add_parser("fit", help="fit a model on a temperature log and save it as JSON")
    _common(fit)
    fit.add_argument("data", metavar="DATA", help="temperature log CSV")
    fit.add_argument("-o", "--output", required=True, metavar="MODEL.json", help="model file to write")
    fit.set_defaults(run=run, action="fit")
    pred = sub.add_parser("predict", help="predict the thermal error over a temperature log")
    pred.add_argument("--model", required=True, metavar="MODEL.json")
    pred.add_argument("data", metavar="DATA", help="temperature log CSV")
    pred.add_argument("-o", "--output", metavar="CSV", help="write timestamp,predicted[,measured] here ('-': stdout)")
    pred.add_argument("--sensors-failed", action="store_true",
                      help="kalman only: ignore every reading (lumped-mass model alone)")
    pred.add_argument("--json", action="store_true", help="machine-readable output")
    pred.set_defaults(run=run, action="predict")
    ev = sub.add_parser("evaluate", help="fit on one log, report the prediction accuracy on another")
    _common(ev)
    ev.add_argument("--train", required=True, metavar="CSV")
    ev.add_argument("--test", required=True, metavar="CSV")
    ev.set_defaults(run=run, action="evaluate")


def _options(args: argparse.Namespace) -> dict[str, Any]:
    opts: dict[str, Any] = {"inputs": _columns(args.inputs), "ambient": args.ambient, "seed": args.seed}
    if args.iterations is not None and args.method in ("grey-cs", "grey-pso"):
        opts["iterations"] = args.iterations
    if args.bound is not None and args.method in ("grey-cs", "grey-pso"):
        opts["bound"] = args.bound
    return opts


def _num(x: float) -> float | None:
    return x if math.isfinite(x) else None


def run(args: argparse.Namespace) -> int:
    """Dispatch to :mod:`setupfix.pipeline.thermal`; printing only."""
    from setupfix.pipeline import thermal as pipe
    from setupfix.pipeline.writers import check_target

    if getattr(args, "output", None):
        check_target(args.output)  # a folder, device, FIFO or link is refused before any work
    if args.action == "fit":
        saved = pipe.fit_file(args.data, args.method, target=args.target, out=args.output, **_options(args))
        tr = saved.train
        if args.json:
            print(json.dumps({"method": args.method, "model": args.output, "inputs": list(saved.inputs),
                              "rmse": _num(tr["rmse"]), "max_residual": _num(tr["max_residual"]),
                              "efficiency": _num(tr["efficiency"]), "n_train": tr["n"]}))
        else:
            print(f"{args.method} on {len(saved.inputs)} inputs ({', '.join(saved.inputs)}), {tr['n']} samples: "
                  f"fit RMSE {tr['rmse']:.4g}, max residual {tr['max_residual']:.4g}, E {tr['efficiency']:.3f}")
            print(f"model written to {args.output}")
        return OK
    if args.action == "predict":
        drift = pipe.predict_drift(args.model, args.data, sensors_failed=args.sensors_failed)
        if args.output:
            _write_prediction(args.output, drift)
        if args.json:
            out: dict[str, Any] = {"method": drift.method, "target": drift.target, "n": int(drift.drift.size),
                                   "latest": _num(drift.latest),
                                   "predicted": [_num(float(v)) for v in drift.drift]}
            if drift.measured is not None:
                from setupfix.thermal.metrics import score

                out["rmse"] = _num(score(drift.measured, drift.drift).rmse)
            print(json.dumps(out))
        elif args.output != "-":
            print(f"{drift.method}: predicted {drift.target} at the last sample {drift.latest:.4g} "
                  f"({drift.drift.size} samples)")
        return OK
    ev = pipe.evaluate_files(args.train, args.test, args.method, target=args.target, **_options(args))
    if args.json:
        print(json.dumps({k: (_num(v) if isinstance(v, float) else v) for k, v in ev.as_json().items()}))
    else:
        t = ev.test
        print(f"{ev.method}: test RMSE {t.rmse:.4g}, max residual {t.max_residual:.4g}, E {t.efficiency:.3f} "
              f"on {t.n} samples (fit RMSE {ev.train.rmse:.4g})")
    return OK


def _write_prediction(target: str, drift: Any) -> None:
    import csv

    from setupfix.atomic import atomic_write

    with atomic_write(target) as stream:
        writer = csv.writer(stream, lineterminator="\n")
        header = ["timestamp", f"predicted_{drift.target}"] + ([drift.target] if drift.measured is not None else [])
        writer.writerow(header)
        for i, value in enumerate(drift.drift):
            row = [drift.timestamps[i] if i < len(drift.timestamps) else i, f"{value:.6g}"]
            if drift.measured is not None:
                row.append(f"{drift.measured[i]:.6g}")
            writer.writerow(row)
