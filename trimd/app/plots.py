"""Plots of an identification: measured against simulated outputs, and the residuals, as PNG.

One figure per free-run simulation (:class:`trimd.identify.validation.Validation`), one row per
output: on the left the measured and the simulated series with the NRMSE fit in the title,
on the right the residual measured − simulated. Rates and angles are shown in degrees
(per second), velocities in m/s. Figures are drawn off screen on matplotlib's Agg canvas
(no pyplot, no display, no global backend state).
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from trimd.identify.validation import Validation

__all__ = ["write_plots"]

_ANGULAR = {"p", "q", "r", "phi", "theta"}


def _unit(output: str) -> tuple[float, str]:
    """Display scale and unit of an output."""
    if output in _ANGULAR:
        return math.degrees(1.0), "°/s" if output in "pqr" else "°"
    return 1.0, "m/s"


def write_plots(validations: Sequence[Validation], out_dir: Path, stage: str) -> list[Path]:
    """Write ``<stage>-<k>-<label>.png`` in ``out_dir`` for each validation; their paths."""
    paths = []
    for k, v in enumerate(validations):
        n = len(v.outputs)
        fig = Figure(figsize=(12, 2.2 * n))
        FigureCanvasAgg(fig)
        axes = fig.subplots(n, 2, sharex=True, squeeze=False)
        t = v.t_s - v.t_s[0]
        judged = v.judged()
        for row, name in enumerate(v.outputs):
            scale, unit = _unit(name)
            fit = judged[name]
            left, right = axes[row]
            left.plot(t, scale * v.measured[:, row], lw=0.8, label="measured")
            left.plot(t, scale * v.simulated[:, row], lw=0.8, label="simulated")
            left.set_ylabel(f"{name} [{unit}]")
            left.set_title(f"{name}: " + ("not excited" if fit is None
                                          else f"NRMSE fit {fit:.1f} %"), fontsize=9)
            right.plot(t, scale * (v.measured[:, row] - v.simulated[:, row]), lw=0.8,
                       color="tab:red")
            right.set_title(f"{name}: residual measured − simulated [{unit}]", fontsize=9)
            for ax in (left, right):
                ax.grid(True, lw=0.3)
        axes[0, 0].legend(loc="upper right", fontsize=8)
        for ax in axes[-1]:
            ax.set_xlabel("time [s]")
        fig.suptitle(f"stage {stage}: {v.label}")
        fig.tight_layout()
        slug = re.sub(r"[^A-Za-z0-9._-]+", "_", v.label).strip("_")
        path = out_dir / f"{stage}-{k}-{slug}.png"
        fig.savefig(path, dpi=90)
        paths.append(path)
    return paths
