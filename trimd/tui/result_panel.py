"""Result panel: the estimate (W, m_ext, CG ± 1σ), a top view of the vehicle with the
proposal, the predicted passive trim and net buoyancy, and the ballast method switch.

Proposals come from :func:`trimd.ballast.propose.propose_ballast` in a thread worker; each
method's proposal is kept, so switching back is instant.
"""

from __future__ import annotations

import textwrap

from rich.text import Text
from textual import on, work
from textual.reactive import reactive
from textual.widget import Widget

from trimd.ballast.propose import METHODS, Proposal, propose_ballast
from trimd.core.errors import TrimdError
from trimd.core.estimate import StaticEstimate
from trimd.core.profile import Profile
from trimd.tui.messages import ProposalReady
from trimd.tui.topview import BOTH, EMPTY, FLOAT, SLOT_LETTERS, WEIGHT, top_view

__all__ = ["ResultPanel"]

#: Fewest rows [lines] worth drawing the top view in.
_MIN_VIEW_H = 5


def _pieces(pieces: tuple[tuple[str, int], ...], removed: tuple[tuple[str, int], ...] = ()
            ) -> str:
    """Pieces added (``2×lead``) and taken out of the installed ballast (``−1×lead``)."""
    return ", ".join([*(f"{n}×{name}" for name, n in pieces),
                      *(f"−{n}×{name}" for name, n in removed)])


def _pack(chunks: list[Text], width: int, *, indent: int = 0) -> list[Text]:
    """Lines of the non-empty ``chunks``, as many to a line as fit in ``width``."""
    lines: list[Text] = []
    for chunk in (c for c in chunks if c.plain):
        if lines and len(lines[-1]) + 3 + len(chunk) <= width:
            lines[-1].append("   ").append_text(chunk)
        else:
            lines.append(Text(" " * indent if lines and indent else "").append_text(chunk))
    return lines


class ResultPanel(Widget):
    """Shows ``estimate`` and the proposal of ``method`` once computed."""

    estimate: reactive[StaticEstimate | None] = reactive(None)
    method: reactive[str] = reactive("milp")
    busy: reactive[bool] = reactive(False)

    def __init__(self, profile: Profile, *, truth: str | None = None,
                 id: str | None = None) -> None:
        super().__init__(id=id)
        self.profile = profile
        self.truth = truth
        self.proposals: dict[str, Proposal] = {}
        self.errors: dict[str, str] = {}
        self.border_title = "Result"
        self.border_subtitle = "± 1σ"

    @property
    def proposal(self) -> Proposal | None:
        """The proposal of the method shown, if computed."""
        return self.proposals.get(self.method)

    def show_result(self, estimate: StaticEstimate, proposal: Proposal | None) -> None:
        """The session's result: its proposal (if any) is the first method shown."""
        self.proposals.clear()
        self.errors.clear()
        if proposal is not None:
            self.proposals[proposal.method] = proposal
            self.set_reactive(ResultPanel.method, proposal.method)
        self.estimate = estimate
        self._ensure()

    def next_method(self) -> None:
        """Switch to the next ballast method (computing it if needed)."""
        self.method = METHODS[(METHODS.index(self.method) + 1) % len(METHODS)]

    def watch_method(self) -> None:
        self._ensure()

    def _ensure(self) -> None:
        m = self.method
        self.busy = (self.estimate is not None and m not in self.proposals
                     and m not in self.errors)
        if self.busy:
            self._propose(m)

    @work(thread=True, group="ballast")
    def _propose(self, method: str) -> None:
        assert self.estimate is not None
        try:
            self.post_message(ProposalReady(
                method, propose_ballast(self.estimate, self.profile, method=method)))
        except (ValueError, TrimdError) as exc:
            self.post_message(ProposalReady(method, None, f"{type(exc).__name__}: {exc}"))

    @on(ProposalReady)
    def _on_proposal(self, message: ProposalReady) -> None:
        if message.proposal is not None:
            self.proposals[message.method] = message.proposal
        else:
            self.errors[message.method] = message.error
        if message.method == self.method:
            self.busy = False
        self.refresh()

    # ---------------------------------------------------------------- drawing
    def render(self) -> Text:
        est, p = self.estimate, self.proposal
        width, height = self.content_size.width, self.content_size.height
        if est is None:
            return Text.assemble(("waiting for the estimate…\n", "dim"),
                                 top_view(self.profile, width=width, height=height - 1))
        mm, sd = est.r_g_m * 1e3, est.r_g_std_m * 1e3
        head = _pack([Text(f"m_ext {est.m_ext_kg:+.3f} ± {est.m_ext_std_kg:.3f} kg",
                           style="bold"),
                      Text(f"W {est.weight_N:.1f} ± {est.weight_std_N:.1f} N")], width)
        head += [Text("CG mm " + "".join(f"  {a} {v:+6.2f}" for a, v in
                                         zip("xyz", mm, strict=True)), style="bold"),
                 Text("  ±1σ " + "".join(f"    {s:6.2f}" for s in sd))]
        if self.truth:  # the simulator's, in the demo: two lines at most
            head += [Text(line, style="dim") for line in textwrap.wrap(self.truth, width)[:2]]
        switch = Text("method ")
        for m in METHODS:
            switch.append(f" {m} ", style="reverse bold" if m == self.method else "dim")
        head.append(switch.append("  (m)", style="dim"))
        foot = self._footer(p, width)
        view_h = height - len(head) - len(foot)
        if view_h < _MIN_VIEW_H:  # make room for the top view: slot letters only
            foot = self._footer(p, width, compact=True)
            view_h = height - len(head) - len(foot)
        view = ([top_view(self.profile, width=width, height=view_h,
                          cg_m=(float(est.r_g_m[0]), float(est.r_g_m[1])),
                          slot_styles=self._slot_styles(p))] if view_h >= _MIN_VIEW_H else [])
        return Text("\n", no_wrap=True, overflow="ellipsis").join(head + view + foot)

    def _slot_styles(self, p: Proposal | None) -> list[str]:
        if p is None:
            return [EMPTY] * len(self.profile.slots)
        return [BOTH if s.weight_kg and s.float_kg else WEIGHT if s.weight_kg
                else FLOAT if s.float_kg else EMPTY for s in p.slots]

    def _footer(self, p: Proposal | None, width: int, *, compact: bool = False
                ) -> list[Text]:
        """The proposal below the top view: per slot its name, load and pieces, or with
        ``compact`` only the slot's letter (as in the top view) and load, several a line."""
        if self.method in self.errors:
            return [Text(f"{self.method}: {self.errors[self.method]}", style="bold red")]
        if p is None:
            return [Text(f"computing {self.method}…" if self.busy else "no proposal",
                         style="dim")]
        lines: list[Text] = []
        loads: list[Text] = []
        styles = self._slot_styles(p)
        for i, s in enumerate(p.slots):
            if not (s.mass_kg or s.buoyancy_N):
                continue
            load = Text(SLOT_LETTERS[i % 26], style=styles[i])
            if not compact:
                load.append(f" {s.name}", style="")
            if s.weight_kg:
                load.append(f" {s.weight_kg:+.2f} kg", style=WEIGHT)
            if s.float_kg:
                load.append(f" {s.float_kg:+.2f} kgf", style=FLOAT)
            if compact:
                loads.append(load)
            else:
                lines += _pack([load, Text(_pieces(s.pieces, s.removed), style="dim")], width,
                               indent=2)
        lines += _pack(loads, width)
        if not lines:
            lines.append(Text("no ballast needed", style="green"))
        t = p.trim
        trim_style = "bold green" if p.feasible else "bold red"
        lines += _pack([
            Text(f"added {p.added_mass_kg:.2f} kg"),
            Text(f"net buoyancy {t.net_buoyancy_N:+.1f} ± {t.net_buoyancy_std_N:.1f} N "
                 f"({t.net_buoyancy_pct:+.2f} %)"),
            *((Text(f"passive roll {t.roll_deg:+.2f} ± {t.roll_std_deg:.2f}°", style=trim_style),
               Text(f"pitch {t.pitch_deg:+.2f} ± {t.pitch_std_deg:.2f}°", style=trim_style))
              if t.stable else
              (Text("passive trim undefined: no static stability", style="bold red"),)),
        ], width)
        if not p.feasible:
            lines += [Text(line, style="bold red") for line in
                      textwrap.wrap(f"NOT FEASIBLE: {'; '.join(p.binding)}", width)]
        return lines
