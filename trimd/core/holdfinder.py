"""Find the steady attitude holds in a recording with the live procedure's own test.

A log of a trim written by any tool (trimd, a ground station's tlog at the rates it asked
for, a DataFlash log), or of ordinary steady flying, holds no set-points. Its attitude
plateaus stand in for them: runs of attitude samples that stay within the attitude
tolerance of their own running mean for at least ``min_steady_s``. At each plateau the
live settling test (:class:`trimd.core.settling.HoldSettling`) runs over the samples in
their time order, each stream on its own samples (thruster effort is never tested on
values repeated onto the faster attitude stream), and collects what the live procedure
would: after ``min_steady_s`` of settled samples, every settled attitude sample with the
effort zero-order held onto it. Plateaus at the same attitude form one hold. So a replay
and a live run use one detector and find the same holds. Times [s] are the samples' own.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from trimd.core.decision import StopRule
from trimd.core.effort import MAX_THRUSTER_AGE_S
from trimd.core.estimate import HeldOutputs, HoldSamples
from trimd.core.profile import Profile
from trimd.core.samples import Attitude
from trimd.core.settling import UNSTEADY_GRACE_S, HoldSettling
from trimd.core.types import FloatArray

__all__ = ["FoundHold", "find_holds", "find_segments", "locate_holds"]



def _plateaus(attitude: Sequence[Attitude], tol_rad: float, min_s: float
              ) -> list[tuple[int, int, float, float]]:
    """Runs [start, stop) of attitude samples within ``tol_rad`` of their running mean
    for at least ``min_s`` [s], with that mean (φ, θ) [rad]."""
    out = []
    start, sum_phi, sum_theta = 0, 0.0, 0.0
    for i, a in enumerate(attitude):
        n = i - start
        if n and (abs(a.phi - sum_phi / n) > tol_rad or abs(a.theta - sum_theta / n) > tol_rad):
            if attitude[i - 1].t_s - attitude[start].t_s >= min_s:
                out.append((start, i, sum_phi / n, sum_theta / n))
            start, sum_phi, sum_theta = i, 0.0, 0.0
        sum_phi += a.phi
        sum_theta += a.theta
    n = len(attitude) - start
    if n and attitude[-1].t_s - attitude[start].t_s >= min_s:
        out.append((start, len(attitude), sum_phi / n, sum_theta / n))
    return out


def _collect(attitude: Sequence[Attitude], t_effort: FloatArray, tau_effort: FloatArray,
             phi: float, theta: float, profile: Profile, rule: StopRule
             ) -> list[tuple[Attitude, int]]:
    """Run the live settling test at set-point (phi, theta) over the samples in time
    order; return the attitude samples it collects with the index of their held effort."""
    proc = profile.procedure
    settling = HoldSettling(proc, phi, theta, rule.effort_floor(
        math.radians(proc.attitude_tol_deg), phi, theta))
    k = int(np.searchsorted(t_effort, attitude[0].t_s - MAX_THRUSTER_AGE_S))
    latest = -1
    collected = []
    for a in attitude:
        while k < len(t_effort) and t_effort[k] <= a.t_s:
            settling.effort(float(t_effort[k]), tau_effort[k])
            latest, k = k, k + 1
        fresh = latest >= 0 and a.t_s - t_effort[latest] <= MAX_THRUSTER_AGE_S
        if settling.attitude(a, fresh) and a.t_s - settling.steady_since >= proc.min_steady_s:
            collected.append((a, latest))
    # the live test notices a departure only after its grace time: leave out the last
    # moments before the attitude left this plateau (live, trimd ends the hold itself)
    end = attitude[-1].t_s - UNSTEADY_GRACE_S
    return [(a, k) for a, k in collected if a.t_s <= end]


def _trend_rad(got: list[tuple[Attitude, int]], min_s: float) -> float:
    """How far roll or pitch moves along its fitted straight line over the collected
    samples, or over ``min_s`` [s] if they span less [rad]: wander comes back, a slow ramp
    (which each short window may call steady) does not."""
    t = np.array([a.t_s for a, _ in got])
    if t[-1] <= t[0]:
        return 0.0
    att = np.array([[a.phi, a.theta] for a, _ in got])
    slope = np.polyfit(t - t[0], att, 1)[0]
    return float(np.max(np.abs(slope)) * max(t[-1] - t[0], min_s))


def _plateau_samples(attitude: Sequence[Attitude], t_effort: FloatArray,
                     tau_effort: FloatArray, profile: Profile
                     ) -> list[tuple[float, float, list[tuple[Attitude, int]], bool]]:
    """Per attitude plateau that passes the live test: its mean (φ, θ) [rad], the
    collected samples with their effort index, and whether it ended before the samples
    did (False: it may go on)."""
    proc = profile.procedure
    tol = math.radians(proc.attitude_tol_deg)
    rule = StopRule.for_profile(profile)
    out = []
    for i, j, phi, theta in _plateaus(attitude, tol, proc.min_steady_s):
        got = _collect(attitude[i:j], t_effort, tau_effort, phi, theta, profile, rule)
        if len(got) < 2 or _trend_rad(got, proc.min_steady_s) > tol / 2:
            continue
        out.append((phi, theta, got, j < len(attitude)))
    return out


def _hold(got: list[tuple[Attitude, int]], tau_effort: FloatArray,
          thrust: FloatArray | None, outputs: HeldOutputs | None, label: str) -> HoldSamples:
    idx = np.array([i for _, i in got])
    return HoldSamples(np.array([a.t_s for a, _ in got]), np.array([a.phi for a, _ in got]),
                       np.array([a.theta for a, _ in got]), tau_effort[idx], label,
                       thrust=None if thrust is None else thrust[idx],
                       outputs=None if outputs is None else outputs.take(idx))


def find_segments(attitude: Sequence[Attitude], t_effort: FloatArray, tau_effort: FloatArray,
                  profile: Profile, thrust: FloatArray | None = None,
                  outputs: HeldOutputs | None = None) -> list[tuple[HoldSamples, bool]]:
    """Each steady plateau on its own (as :func:`find_holds` finds them, not merged by
    attitude), in time order, with whether it ended before the samples did (a plateau
    still going on at the last sample is not finished)."""
    return [(_hold(got, tau_effort, thrust, outputs, f"segment {k + 1}"), ended)
            for k, (_, _, got, ended) in enumerate(
                _plateau_samples(attitude, t_effort, tau_effort, profile))]


@dataclass(frozen=True)
class FoundHold:
    """A hold and where it was collected: the first and last collected sample time [s]
    of each plateau it joins, in time order."""

    samples: HoldSamples
    plateaus_s: tuple[tuple[float, float], ...]


def locate_holds(attitude: Sequence[Attitude], t_effort: FloatArray, tau_effort: FloatArray,
                 profile: Profile, thrust: FloatArray | None = None,
                 outputs: HeldOutputs | None = None) -> list[FoundHold]:
    """:func:`find_holds` with the plateaus each hold joins."""
    tol = math.radians(profile.procedure.attitude_tol_deg)
    groups: list[tuple[float, float, list[tuple[Attitude, int]], list[tuple[float, float]]]] = []
    for phi, theta, got, _ in _plateau_samples(attitude, t_effort, tau_effort, profile):
        span = (got[0][0].t_s, got[-1][0].t_s)
        for g in groups:
            if abs(g[0] - phi) <= tol and abs(g[1] - theta) <= tol:
                g[2].extend(got)
                g[3].append(span)
                break
        else:
            groups.append((phi, theta, got, [span]))
    return [FoundHold(_hold(got, tau_effort, thrust, outputs, f"hold {k + 1}"), tuple(spans))
            for k, (_, _, got, spans) in enumerate(groups)]


def find_holds(attitude: Sequence[Attitude], t_effort: FloatArray, tau_effort: FloatArray,
               profile: Profile, thrust: FloatArray | None = None,
               outputs: HeldOutputs | None = None) -> list[HoldSamples]:
    """The steady holds in time-ordered ``attitude`` samples and thruster effort
    ``tau_effort`` (n, 6) [N, N·m] at its own times ``t_effort`` [s], labelled
    ``hold 1``, ``hold 2``, … in the order of their first sample; plateaus at the same
    attitude (within ``attitude_tol_deg``) are one hold. ``thrust`` (n, n_thrusters) [N],
    each thruster's thrust behind each effort sample, rides along into
    :attr:`HoldSamples.thrust` (the thrust curves' share of the ±), and ``outputs``, the
    outputs that thrust was read from, into :attr:`HoldSamples.outputs`."""
    return [h.samples for h in locate_holds(attitude, t_effort, tau_effort, profile, thrust,
                                            outputs)]
