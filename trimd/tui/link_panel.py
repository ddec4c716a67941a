"""Link panel: transport, profile and vehicle id/type, mode, armed, message rates, bad
frames, heartbeat age."""

from __future__ import annotations

from rich.text import Text
from textual.reactive import reactive
from textual.widgets import Static

from trimd.tui.telemetry import LiveState

__all__ = ["HEARTBEAT_STALE_S", "LinkPanel"]

#: Every so often [s, wall clock] the heartbeat age is redrawn, samples or not.
_AGE_REFRESH_S = 0.5
#: Heartbeats (MAVLink HEARTBEAT, serial VHSTA) come at 1 Hz: one missed is worth a red.
HEARTBEAT_STALE_S = 1.5


class LinkPanel(Static):
    """What the link carries; the vehicle's id and type (as the link names it) in the
    title, the profile's name in the text (a replay's pace goes in the bottom border).
    The heartbeat turns red (class ``-stale``) once ``stale_after_s`` pass without one
    (:data:`HEARTBEAT_STALE_S`: one missed 1 Hz heartbeat). The procedure does not wait
    for it: it releases on ``link_timeout_s`` without any telemetry."""

    stale: reactive[bool] = reactive(False)
    closed: reactive[bool] = reactive(False)

    def __init__(self, state: LiveState, *, link_description: str, vehicle: str,
                 stale_after_s: float, id: str | None = None) -> None:
        super().__init__(id=id)
        self.state = state
        self.link_description = link_description
        self.vehicle = vehicle
        self.stale_after_s = stale_after_s
        self.border_title = "Link"

    def on_mount(self) -> None:
        self.set_interval(_AGE_REFRESH_S, self.show)
        self.show()

    def watch_stale(self, stale: bool) -> None:
        self.set_class(stale, "-stale")

    def watch_closed(self) -> None:
        self.show()

    def show(self) -> None:
        s = self.state
        h = s.health
        text = Text(no_wrap=True, overflow="ellipsis")
        text.append(f"{self.link_description}\n", style="bold")
        text.append(f"{self.vehicle}  ")
        if h is not None and h.vehicle:
            self.border_title = f"Link · {h.vehicle}"
        if h is None:
            text.append("no heartbeat yet\n", style="dim")
        else:
            text.append(h.mode or "?", style="bold")
            text.append("  ")
            text.append("ARMED" if h.armed else "arming unknown" if h.armed is None
                        else "disarmed", style="bold green" if h.armed else "bold yellow")
            if not h.connected:
                text.append("  LOST", style="bold red")
            text.append("\n")
        rates = "  ".join(f"{k} {s.rate_hz(k):.0f}" for k in ("att", "thr", "depth", "hb"))
        text.append(f"Hz {rates}\n", style="")
        age = s.heartbeat_age_s()
        self.stale = not self.closed and (age is None or age > self.stale_after_s)
        if self.closed:
            text.append("link closed", style="dim")
        else:
            text.append(f"heartbeat {'—' if age is None else f'{age:.1f} s'} ago",
                        style="bold red" if self.stale else "")
        text.append(f"  bad {h.bad_frames if h else 0}")
        if s.battery is not None:
            text.append(f"  {s.battery.voltage_V:.1f} V")
        self.update(text, layout=False)  # a fixed height (trimd.tcss): no layout pass
