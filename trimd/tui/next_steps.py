"""Next-steps panel: after a trim that ended with a proposal, what the operator can do —
``p`` apply (record the milp proposal as the installed ballast in the trim history), then,
once the ballast is on the vehicle, ``y`` verify (one level hold that measures what the
ballast left) or ``f`` float (the thrusters at neutral: the attitude it floats at); after
a check that found the vehicle not level (or not as predicted), its correction: ``p``
apply it, then check again; and how each went."""

from __future__ import annotations

from rich.text import Text
from textual.widgets import Static

from trimd.app.apply import Applied
from trimd.app.report import undecided_advice
from trimd.ballast.correct import Correction
from trimd.ballast.verify import Verification
from trimd.core.floating import FloatResult, Verdict

__all__ = ["NextSteps"]


def _checks(style: str) -> tuple[Text, Text]:
    """The two checks offered once the ballast is on (``style`` "dim" before apply)."""
    key = "dim reverse" if style else "bold reverse"
    return (Text.assemble(("y", key), (" verify: one level hold, measured vs predicted",
                                       style)),
            Text.assemble(("f", key), (" float: let go, see how it floats", style)))


class NextSteps(Static):
    """Hidden until :meth:`offer`; each later call replaces what it says."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.border_title = "Next steps"

    def _say(self, *lines: Text) -> None:
        self.add_class("-shown")
        self.update(Text("\n").join(lines))

    def offer(self, method: str, vehicle: str) -> None:
        """The trim is done: apply, then verify."""
        self._say(Text.assemble(("p", "bold reverse"), f" apply: record the {method} "
                                f"proposal as installed on {vehicle}"),
                  Text("  then fit that ballast on the vehicle", style="dim"),
                  *_checks("dim"))

    def unavailable(self, why: str) -> None:
        self._say(Text(why, style="dim"))

    def applied(self, a: Applied) -> None:
        """Recorded: what changed; verify is next."""
        self._say(Text(f"recorded ({a.source}): " + ("; ".join(a.changes) or "no change"),
                       style="green"),
                  Text("fit that ballast on the vehicle, then", style="dim"),
                  *_checks(""))

    def checking(self, what: str, link: str) -> None:
        """A check (``what``: verify hold, float check) runs, or its link opens."""
        self._say(Text(f"{what} on {link}"),
                  Text("s confirm · a ABORT · trimd commands only after confirmation",
                       style="dim"))

    def checked(self, v: Verification | FloatResult | None, reason: str,
                correction: Correction | None = None) -> None:
        """The check ended: its verdict, or why it has none; its ``correction`` offered
        (apply, then check again) when there is one."""
        if isinstance(v, FloatResult):
            first = Text(f"float check: {v.verdict.value}",
                         style="bold green" if v.verdict is Verdict.LEVEL else "bold red")
        elif v is None:
            first = Text(f"check ended: {reason}", style="bold red")
        elif v.as_predicted:
            first = Text("verified: as predicted", style="bold green")
        else:
            first = Text("verified: NOT as predicted", style="bold red")
        if correction is None:
            advice = undecided_advice(v) if isinstance(v, Verification) else None
            self._say(first, Text.assemble(("y", "bold reverse"), " verify again · ",
                                           ("f", "bold reverse"), " float again"),
                      *([Text(advice, style="yellow")] if advice else []))
            return
        p = correction.proposal
        self._say(first, Text("correction: " + ("; ".join(c.text for c in p.changes)
                                                or "no change"), style="yellow"),
                  Text(f"  leaves roll {p.trim.roll_deg:+.2f}° ± {p.trim.roll_std_deg:.2f}°, "
                       f"pitch {p.trim.pitch_deg:+.2f}° ± {p.trim.pitch_std_deg:.2f}°",
                       style="dim"),
                  Text.assemble(("p", "bold reverse"), " apply the correction"),
                  Text("  then fit it on the vehicle", style="dim"),
                  Text.assemble(("y", "dim reverse"), (" verify again · ", "dim"),
                                ("f", "dim reverse"), (" float again", "dim")))

    def failed(self, text: str, key: str, again: str) -> None:
        """``text`` went wrong; ``key`` does it ``again``."""
        self._say(Text(text, style="bold red"), Text.assemble((key, "bold reverse"),
                                                              f" {again}"))
