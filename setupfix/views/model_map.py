"""What ``model map`` shows: a scaffold's open questions with their features, and what an answer wrote.

:func:`question_rows` is the one presenter of a question (its cells); the CLI prints them
as a text table (:func:`format_listing`) and the TUI screen shows them in its table.
"""

from __future__ import annotations

from setupfix.usecases.model_map import MapListing, MapResult, Question

__all__ = ["question_rows", "format_listing", "format_result", "COLUMNS"]

#: The cells of a question row, in order.
COLUMNS = ("question", "feature", "at", "callouts", "asks", "group")


def _safe(text: str) -> str:
    return "".join(c if c.isprintable() else "?" for c in text)


def _at(question: Question) -> str:
    where = next((f.position for f in question.features if f.position is not None), None)
    return ", ".join(f"{v:.6g}" for v in where) if where is not None else "—"


def question_rows(listing: MapListing) -> list[tuple[str, ...]]:
    """One row of :data:`COLUMNS` per open question: name, the report's feature and its model features, its
    nominal position, the callouts it enters, what it asks, the stations of its dimensions."""
    rows: list[tuple[str, ...]] = []
    for q in listing.questions:
        ids = ", ".join(f.id for f in q.features)
        asks = "WKS + tool" if q.needs_wks else "tool (radius)"
        groups = ", ".join(dict.fromkeys(g for f in q.features for g in f.groups)) or "—"
        rows.append(
            (q.name, _safe(f"{q.label} ({ids})"), _at(q), _safe(", ".join(q.callouts)) or "—", asks, _safe(groups))
        )
    return rows


def format_listing(listing: MapListing) -> str:
    """The open questions as a text table, with the registers declared and how to answer."""
    registers = ", ".join(f"{k} {v}" for k, v in (*listing.wks.items(), *listing.tools.items())) or "none"
    head = [
        _safe(f"{listing.source}: {len(listing.features)} feature(s), registers {registers}"),
    ]
    if not listing.questions:
        state = "a draft (remove draft = true once checked)" if listing.draft else "not a draft"
        return "\n".join([*head, f"no open question; the model is {state}"])
    rows = question_rows(listing)
    widths = [min(34, max(len(c), *(len(r[i]) for r in rows))) for i, c in enumerate(COLUMNS)]

    def line(cells: tuple[str, ...]) -> str:
        out = []
        for cell, width in zip(cells, widths, strict=True):
            out.append(cell if len(cell) <= width else cell[: width - 1] + "…")
        return "  ".join(c.ljust(w) for c, w in zip(out, widths, strict=True)).rstrip()

    return "\n".join(
        [
            *head,
            f"{len(listing.questions)} open question(s): which work offset (WKS) and which tool made each feature; "
            "'correct' holds until each is answered",
            "",
            line(COLUMNS),
            line(tuple("-" * w for w in widths)),
            *(line(r) for r in rows),
            "",
            "answer: setupfix model map MODEL --answer 'Q1,Q4=G54,T3' (a size: 'Q2=,T5'; groups: 'DIAMETER5*=,T2', "
            "'group:P1=G55,T1', '*=G54,T1'), or --answers CSV (feature,wks,tool)",
        ]
    )


def format_result(result: MapResult, target: str) -> str:
    """What an answer wrote: the questions answered, the registers added, what is left, the draft state."""
    answered = ", ".join(f"{q} {w}/{t}" for q, w, t in result.answered)
    lines = [_safe(f"wrote {target}: {len(result.answered)} question(s) answered ({answered})")]
    if result.added:
        lines.append(f"registers added: {', '.join(result.added)}")
    if result.remaining:
        lines.append(f"{len(result.remaining)} question(s) open: {', '.join(result.remaining)}; 'correct' holds")
    elif result.draft_lifted:
        lines.append(
            "every question answered: draft = true removed; check with 'setupfix model show' and "
            "'setupfix model check', then 'setupfix correct'"
        )
    elif result.draft:
        lines.append("every question answered; the model is still a draft (remove draft = true once checked)")
    return "\n".join(lines)
