"""JSON of the calibration's records (what the trim history and a recording store):
holds, experiments, gains and the posterior (:mod:`trimd.core.calibration`; units in the
key names, radians and N, N·m)."""

from __future__ import annotations

import math

import numpy as np

from trimd.core.calibration import (
    CalibrationHold,
    Experiment,
    FloatReference,
    PieceChange,
    ThrustMapPosterior,
    posterior,
)
from trimd.core.errors import DataError
from trimd.core.output_hist import OutputHistogram
from trimd.core.types import FloatArray, JsonObject

__all__ = ["experiment_from_dict", "experiment_to_dict", "hold_from_dict",
           "hold_to_dict", "posterior_from_dict", "posterior_to_dict"]


def hold_to_dict(h: CalibrationHold) -> JsonObject:
    """JSON-ready dict of a calibration hold (what the trim history stores); its outputs,
    when it kept them, as each thruster's distinct PWM [µs] and their sample counts."""
    out = h.outputs
    return {"label": h.label, "roll_rad": h.phi_rad, "pitch_rad": h.theta_rad,
            "tau_N_Nm": h.tau.tolist(), "tau_cov": h.tau_cov.tolist(),
            "exposure_N": h.exposure.tolist()} | ({} if out is None else {"outputs": {
                "pwm_us": [p.astype(int).tolist() for p in out.pwm_us],
                "counts": [c.astype(int).tolist() for c in out.counts],
                "voltage_V": out.voltage_V}})


def _array(d: JsonObject, key: str, shape: tuple[int, ...], source: str) -> FloatArray:
    try:
        a = np.asarray(d[key], float)
    except (KeyError, TypeError, ValueError):
        raise DataError(f"{source}: {key}: missing or not numbers") from None
    if (shape and a.shape != shape) or not np.all(np.isfinite(a)):
        raise DataError(f"{source}: {key}: shape {a.shape}, {shape} of finite numbers expected")
    return a


def _outputs(d: JsonObject, n: int, source: str) -> OutputHistogram | None:
    """The output histogram of a hold's dict (None when it kept none); DataError naming
    ``source`` when it is malformed."""
    if "outputs" not in d:
        return None
    o = d["outputs"]
    where = f"{source}: outputs"
    try:
        pwm = tuple(np.asarray(p, float).reshape(-1) for p in o["pwm_us"])
        counts = tuple(np.asarray(c, float).reshape(-1) for c in o["counts"])
        voltage = float(o["voltage_V"])
    except (KeyError, TypeError, ValueError) as exc:
        raise DataError(f"{where}: not an output histogram ({exc})") from None
    if (len(pwm) != n or len(counts) != n or not math.isfinite(voltage)
            or any(p.shape != c.shape or not p.size or not np.all(np.isfinite(p))
                   or not np.all(c > 0) for p, c in zip(pwm, counts, strict=True))):
        raise DataError(f"{where}: {n} thrusters' PWM and positive counts of one length "
                        "each expected")
    return OutputHistogram(pwm, counts, voltage)


def hold_from_dict(d: JsonObject, source: str) -> CalibrationHold:
    """The hold of :func:`hold_to_dict`'s dict; DataError naming ``source``."""
    exposure = _array(d, "exposure_N", (), source).reshape(-1)
    return CalibrationHold(str(d.get("label", "")), float(_array(d, "roll_rad", (), source)),
                           float(_array(d, "pitch_rad", (), source)),
                           _array(d, "tau_N_Nm", (6,), source),
                           _array(d, "tau_cov", (6, 6), source), exposure,
                           _outputs(d, len(exposure) // 4, source))


def experiment_to_dict(exp: Experiment | FloatReference) -> JsonObject:
    """JSON-ready dict of ``exp`` (what the trim history stores); a float reference's has
    ``"kind": "float"``."""
    if isinstance(exp, FloatReference):
        return {"kind": "float", "label": exp.label, "hold": hold_to_dict(exp.hold),
                "float_roll_rad": exp.phi_rad, "float_pitch_rad": exp.theta_rad,
                "float_angle_cov": exp.angle_cov.tolist(), "q_z_Nm": exp.q_z,
                "q_z_var": exp.q_z_var}
    return {"label": exp.label, "before": hold_to_dict(exp.before),
            "after": hold_to_dict(exp.after),
            "change": [{"slot": c.slot, "piece": c.piece, "count": c.count}
                       | ({} if c.net_down_N is None else {
                           "net_down_N": c.net_down_N, "uncertainty_pct": c.uncertainty_pct})
                       for c in exp.change],
            "q_before_N_Nm": exp.q_before.tolist(), "q_before_cov": exp.q_before_cov.tolist()}


def experiment_from_dict(d: JsonObject, source: str) -> Experiment | FloatReference:
    """The experiment of :func:`experiment_to_dict`'s dict; DataError naming ``source``."""
    try:
        if d.get("kind") == "float":
            return FloatReference(str(d["label"]), hold_from_dict(d["hold"], source),
                                  float(_array(d, "float_roll_rad", (), source)),
                                  float(_array(d, "float_pitch_rad", (), source)),
                                  _array(d, "float_angle_cov", (2, 2), source),
                                  float(_array(d, "q_z_Nm", (), source)),
                                  float(_array(d, "q_z_var", (), source)))
        change = tuple(PieceChange(str(c["slot"]), str(c["piece"]), int(c["count"]),
                                   None if c.get("net_down_N") is None
                                   else float(c["net_down_N"]),
                                   float(c.get("uncertainty_pct", 1.0)))
                       for c in d["change"])
        return Experiment(str(d["label"]), hold_from_dict(d["before"], source),
                          hold_from_dict(d["after"], source), change,
                          _array(d, "q_before_N_Nm", (4,), source),
                          _array(d, "q_before_cov", (4, 4), source))
    except (KeyError, TypeError, ValueError) as exc:
        raise DataError(f"{source}: not a calibration experiment ({exc})") from None


def posterior_to_dict(post: ThrustMapPosterior) -> JsonObject:
    """JSON-ready dict of a posterior (mean and covariance in units of the prior σ)."""
    return {"mean": post.mean.tolist(), "cov": post.cov.tolist(),
            "experiments": post.experiments}


def posterior_from_dict(d: JsonObject, source: str) -> ThrustMapPosterior:
    """The posterior of :func:`posterior_to_dict`'s dict; DataError naming ``source``."""
    mean = _array(d, "mean", (), source).reshape(-1)
    cov = _array(d, "cov", (len(mean), len(mean)), source)
    try:
        return posterior(mean, cov, int(d["experiments"]))
    except (KeyError, TypeError, ValueError) as exc:
        raise DataError(f"{source}: not a thrust-map calibration ({exc})") from None
