"""``setupfix model show``: the relation matrices of a process model."""

from __future__ import annotations

import argparse
import json
import sys

from setupfix.pipeline.present import format_relations
from setupfix.pipeline.model import describe_model

MATRICES = ("R_MW", "R_WF", "R_TF", "R_FD", "C")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("model", help="inspect a process model")
    msub = p.add_subparsers(dest="model_command", metavar="ACTION", parser_class=type(p))
    show = msub.add_parser("show", help="print R_MW, R_WF, R_TF, R_FD, the composite, its rank and null space")
    show.add_argument("model", metavar="MODEL", help="process model TOML")
    show.add_argument("--matrix", action="append", choices=MATRICES, default=None,
                      help="only this matrix (repeatable; default all)")
    show.add_argument("--json", action="store_true", help="matrices, rank and null space as JSON")
    show.set_defaults(run=run_show)


def run_show(args: argparse.Namespace) -> int:
    desc = describe_model(args.model)
    if args.json:
        json.dump(desc.to_json(), sys.stdout, indent=1)
        sys.stdout.write("\n")
        return 0
    which = args.matrix or [m for m in MATRICES if m != "R_MW" or desc.matrices.R_MW.size]
    sys.stdout.write(f"{desc.model.name}  (axis {desc.model.axis}, unit {desc.model.unit}, "
                     f"resolution {desc.model.resolution:g})\n\n")
    sys.stdout.write(format_relations(desc.matrices, which, desc.null_space, desc.rank) + "\n")
    return 0
