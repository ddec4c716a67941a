"""``trimd history --plot``: W − B and the centre of gravity of a vehicle's trims over time.

Four panels sharing the time axis (UTC): the net vertical force W − B [N] and x_g, y_g,
z_g [mm] (body FRD, origin CG0), each trim a point with a ±1σ error bar; watch segments
that carry ``net_force_N`` (and ``net_force_std_N``) are grey points on the W − B panel,
watch alerts red dashed lines, recorded ballast changes grey dotted ones. Drawn off screen on
matplotlib's Agg canvas (as :mod:`trimd.app.plots`).
"""

from __future__ import annotations

import datetime as dt
import math
from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from trimd.app.history.store import History

__all__ = ["write_history_plot"]


def _when(t_unix: float) -> dt.datetime:
    return dt.datetime.fromtimestamp(t_unix, dt.UTC)


def write_history_plot(history: History, vehicle: str, path: Path) -> int:
    """Write the PNG of ``vehicle``'s trims to ``path``; the number of trims plotted."""
    trims = history.trims(vehicle)
    t = [_when(r.t_unix) for r in trims]
    fig = Figure(figsize=(10, 9))
    FigureCanvasAgg(fig)
    axes = fig.subplots(4, 1, sharex=True)
    net = [r.estimate["net_force_N"] for r in trims]
    net_std = [math.sqrt(max(r.estimate["cov_net"][0][0], 0.0)) for r in trims]
    axes[0].errorbar(t, net, yerr=net_std, fmt="o-", capsize=3, label="trim")
    segments = [r for r in history.watch_segments(vehicle)
                if isinstance(r.values.get("net_force_N"), int | float)]
    if segments:
        axes[0].errorbar([_when(r.t_unix) for r in segments],
                         [r.values["net_force_N"] for r in segments],
                         yerr=[r.values.get("net_force_std_N") or 0.0 for r in segments],
                         fmt=".", color="0.5", capsize=2, label="watch segment")
        axes[0].legend(loc="best", fontsize=8)
    axes[0].set_ylabel("W − B [N]")
    for k, name in enumerate(("x_g", "y_g", "z_g")):
        cg = [1e3 * r.estimate["cg_m"][k] for r in trims]
        cg_std = [1e3 * r.estimate["cg_std_m"][k] for r in trims]
        axes[k + 1].errorbar(t, cg, yerr=cg_std, fmt="o-", capsize=3, color=f"C{k + 1}")
        axes[k + 1].set_ylabel(f"{name} [mm]")
    for ax in axes:
        for a in history.alerts(vehicle):
            ax.axvline(_when(a.t_unix), color="tab:red", ls="--", lw=0.8)
        for i in history.installs(vehicle):
            ax.axvline(_when(i.t_unix), color="0.5", ls=":", lw=0.8)
        ax.grid(True, lw=0.3)
    axes[-1].set_xlabel("time [UTC]")
    fig.suptitle(f"trim history of {vehicle}: W − B and centre of gravity (±1σ)\n"
                 "red dashed: watch alerts; grey dotted: ballast recorded", fontsize=10)
    fig.autofmt_xdate()
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    return len(trims)
