"""The help screen: every key and every symbol."""

from __future__ import annotations

from typing import ClassVar

from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import VerticalScroll
from textual.screen import ModalScreen
from textual.widgets import Markdown

__all__ = ["HelpScreen", "HELP"]

HELP = """\
# setupfix — keys

| key | does |
|---|---|
| `o` | open a report (file picker; a folder watches it for the newest report) |
| `m` | open a process model |
| `r` | run the correction again |
| `x` | cancel the running work |
| `f` | filter the dimensions by station (all → P1 → P2 …) |
| `s` | sort the dimensions: model order (below 120×30: what needs you first, see below), margin after, … |
| click | a column header sorts by it |
| `[` `]` | previous / next part (cycle) of the report |
| `Home` `End` | the first / the latest part (cycle) of a multi-cycle report |
| `e` | export the offsets: choose the controller format (the file's suffix follows it), see the text, confirm |
| `w` | send to the machine (`--link`): the dry-run diff, a second question, then the read-back or refusal |
| `d` | diagnose the history (one key) |
| `k` | capability of the history store (`--db`): Cpk per dimension, individuals sparkline, Nelson rule flags |
| `1` `3` `4` `5` | correction · thermal · history · match tabs |
| `?` | this help |
| `q` | quit |

# Engineer keys

Hidden from the operator: start with `setupfix tui --engineer`, or press `ctrl+e` (again: hidden).

| key | does |
|---|---|
| `ctrl+e` | show (or hide) the engineer keys and the compare tab |
| `p` | next optimiser (exact, cripso, pso, ga, coa, cs) — runs at once |
| `c` | compare every optimiser on this part (progress; `x` cancels) |
| `2` | the compare tab |

# Symbols

| symbol | meaning |
|---|---|
| `✓` | in tolerance (first column: measured; second: predicted after the correction) |
| `✗` | measured out of tolerance |
| `▲` | predicted **out** of tolerance after the correction |
| `◇` | predicted inside the guard band: in tolerance, but nearer a limit than the measuring uncertainty |
| `●` | binding: one of the dimensions that stop a better correction |
| `⚑` | given up: no setup correction brings it in (the NC program or the process must) |
| `├──●──┼──┤` | the tolerance zone: limits, nominal, the value; `◀` `▶` beyond a limit |
| `◆limit` | the register is at its limit |
| `W1.X` `W1.C` `T5.R` | register components of a multi-axis model: WKS axis, WKS rotation (degrees, °), tool radius |

Below 120×30 the dimensions that need you come first: out of tolerance (`✗` or `▲`), then binding
(`●`) or at a limit (`◇`, in the guard band), then the least margin after the correction.

The next export offers the controller format and the file of the last one; a file that exists is
overwritten only when you answer yes (`y`) to the question that names it.

δ is the error budget: the smallest distance of any dimension to its nearer limit
(negative when one is out). The bonus is δ after − δ before.
"""


class HelpScreen(ModalScreen[None]):
    """Keys and symbols; any of escape, q, ? closes it."""

    BINDINGS: ClassVar[list[BindingType]] = [Binding("escape,q,question_mark", "dismiss", "Close")]

    def compose(self) -> ComposeResult:
        with VerticalScroll(id="help-box"):
            yield Markdown(HELP)

    def action_dismiss(self, result: None = None) -> None:  # type: ignore[override]  # the help screen returns nothing
        self.dismiss(None)
