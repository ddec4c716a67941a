"""The covariance of a mean of serially correlated samples (long-run covariance).

A hold's samples are not independent: thruster outputs held onto the faster attitude
stream repeat, a controller's limit cycle lasts seconds, the attitude estimate and the
depth wander for tens of seconds. The mean of n such samples has covariance S/n, where S
is the *long-run* covariance Σ_h Γ(h) (Γ(h) the lag-h autocovariance), not Γ(0).

Two estimates, and the larger variance of each channel is kept (the correlations
between channels come from the first):

- the Bartlett kernel (Newey & West 1987; positive semi-definite) over a window chosen
  from the data by Sokal's rule (A. Sokal, "Monte Carlo methods in statistical
  mechanics", 1997): the smallest window M with M ≥ 5·τ_int(M), where
  τ_int(M) = 1 + 2·Σ_{h=1..M} ρ(h) is the integrated autocorrelation time of the slowest
  channel, capped at a third of the samples;
- a model of fast noise plus one slow first-order component (ARMA(1, 1)), fitted to
  lags 1 and 2 of the series averaged over blocks of 1, 4 and 16 samples. The kernel
  alone misses a slow component under fast noise (attitude wander of 0.1° with a 5 s
  correlation under thruster noise held at half the attitude rate: its σ came out 1.5×
  too small); the block fit sees it, and the ratio of lags is immune to the bias that
  removing the mean puts into every lag.

Measured on synthetic series (`tests/core/test_longrun.py`): white, zero-order-held and
AR(1) series with correlation times up to a tenth of the record give intervals covering
92–98 % at a nominal 95 %. A mean worth fewer than ``MIN_EFFECTIVE`` independent
samples is flagged as not ``resolved``; for one worth fewer than ``SMALL_SAMPLE`` the
covariance an interval is read from (:attr:`MeanCovariance.interval_cov`, what the
estimates use) is widened by the Student-t quantile of its few effective samples
(:func:`small_sample_factor`), so that a ± read at the normal 95 % quantile spans the
t one. A hold that never gathers seven independent samples (attitude wander of 0.2° with
a 20 s correlation over a 3 min hold: 1–10 of them) then says how little it knows: on
such synthetic holds (`tests/core/test_estimate.py`) the intervals of W − B and the net
moments covered 88–96 % without the widening and 93–98.5 % with it. On the simulated
Sabertooth whose disturbance torques leave that wander (`bench/bench_wander.py`, 40
seeds), W·y_g − B·y_b covered 85 % with the widening below five samples and 92 % below
seven, where the synthetic holds barely change (error/σ RMS 0.80–1.09 at 0.1° with a 5 s
correlation); below ten made the synthetic ones too wide (RMS 0.77 there, 99.5 %
coverage at 0.2° and 20 s) and the simulated Sabertooth no better than seven.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import ndtri, stdtrit

from trimd.core.types import FloatArray

__all__ = ["MeanCovariance", "mean_covariance", "small_sample_factor"]

#: Sokal's window factor: M ≥ SOKAL_C·τ_int(M).
SOKAL_C = 5.0
#: The window may span at most this share of the samples.
MAX_WINDOW_SHARE = 1 / 3
#: The slow component's AR coefficient is capped here (a correlation of ~200 samples).
MAX_PHI = 0.995
#: Block lengths [samples] at which the slow component is looked for, and the fewest
#: blocks that make a fit.
BLOCKS = (1, 4, 16)
MIN_BLOCKS = 40
#: A mean worth fewer independent samples than this is not resolved.
MIN_EFFECTIVE = 10.0
#: A mean worth fewer independent samples than this has its covariance widened by the
#: Student-t quantile (:func:`small_sample_factor`).
SMALL_SAMPLE = 7.0


@dataclass(frozen=True)
class MeanCovariance:
    """The mean of n samples and its covariance.

    Attributes
    ----------
    mean : shape (p,), in the samples' units.
    cov : covariance of ``mean``, shape (p, p), in squared units.
    n : the number of samples.
    window : the kernel window M [samples].
    tau_int : integrated autocorrelation time of the slowest channel [samples]: the
        samples count as about n/tau_int independent ones.
    resolved : False when the samples are worth fewer than ``MIN_EFFECTIVE``
        independent ones (too few for their own correlation time; below
        ``SMALL_SAMPLE`` of them :attr:`interval_cov` is wider than ``cov``).
    """

    mean: FloatArray
    cov: FloatArray
    n: int
    window: int
    tau_int: float
    resolved: bool

    @property
    def effective_samples(self) -> float:
        """About how many independent samples the n correlated ones are worth."""
        return self.n / self.tau_int

    @property
    def interval_cov(self) -> FloatArray:
        """``cov`` to read an interval from: times :func:`small_sample_factor` when the
        samples are worth fewer than ``SMALL_SAMPLE`` independent ones."""
        n_eff = self.effective_samples
        return self.cov * small_sample_factor(n_eff) if n_eff < SMALL_SAMPLE else self.cov


def small_sample_factor(effective_samples: float) -> float:
    """The factor on the variance of a mean worth ``effective_samples`` independent
    samples that makes its normal 95 % interval the Student-t one: (t₀.₉₇₅(ν)/z₀.₉₇₅)²
    with ν = ``effective_samples``, at least 1. (Not n − 1: the effective samples are
    counted from the slower of two estimates of the correlation time, low by design;
    with ν = n − 1 the synthetic holds of the module docstring came out too wide.)

    >>> round(small_sample_factor(4.0), 2), round(small_sample_factor(0.5), 1)
    (2.01, 42.0)
    """
    nu = max(effective_samples, 1.0)
    return float((stdtrit(nu, 0.975) / ndtri(0.975)) ** 2)


def _autocorrelation(x: FloatArray) -> FloatArray:
    """Normalised autocorrelation ρ(h), h = 0…n−1, of each column (FFT, biased estimator)."""
    n = x.shape[0]
    f = np.fft.rfft(x, n=2 * n, axis=0)
    acov = np.fft.irfft(f * np.conj(f), axis=0)[:n]
    var = acov[0]
    with np.errstate(invalid="ignore", divide="ignore"):
        rho = np.where(var > 0, acov / np.where(var > 0, var, 1.0), 0.0)
    rho[0] = 1.0
    return np.asarray(rho, dtype=float)


def _arma_tau(rho: FloatArray, n: int) -> FloatArray:
    """Integrated autocorrelation time [samples] per column, for white noise plus one
    first-order (AR(1)) component: ρ(h) = a·φ^h for h ≥ 1, so φ = ρ(2)/ρ(1) and
    τ = 1 + 2·ρ(1)/(1 − φ). The ratio is immune to the common bias that removing the
    mean puts into every lag. A lag-1 correlation within noise of zero (2/√n) is none."""
    if rho.shape[0] < 3:
        return np.ones(rho.shape[1])
    r1, r2 = np.where(rho[1] > 2 / np.sqrt(n), rho[1], 0.0), rho[2]
    phi = np.clip(np.where(r1 > 0, r2 / np.where(r1 > 0, r1, 1.0), 0.0), 0.0, MAX_PHI)
    return np.asarray(1 + 2 * np.maximum(r1, 0.0) / (1 - phi), dtype=float)


def _sokal_window(rho: FloatArray, cap: int) -> tuple[int, float]:
    """Smallest M ≤ cap with M ≥ SOKAL_C·τ_int(M) over the slowest column."""
    tau = 1 + 2 * np.cumsum(rho[1:cap + 1], axis=0)      # τ_int(M), M = 1…cap, per column
    tau_max = tau.max(axis=1) if tau.ndim == 2 else tau
    m = np.arange(1, len(tau_max) + 1)
    ok = np.nonzero(m >= SOKAL_C * tau_max)[0]
    if len(ok) == 0:
        return cap, float(max(tau_max[-1], 1.0)) if len(tau_max) else 1.0
    k = int(ok[0])
    return int(m[k]), float(max(tau_max[k], 1.0))


def mean_covariance(x: FloatArray) -> MeanCovariance:
    """Mean of the rows of ``x`` (n, p) and its covariance, for serially correlated rows.

    >>> rng = np.random.default_rng(1)
    >>> e = rng.normal(size=(4000, 1))
    >>> ar = np.empty_like(e); ar[0] = e[0]
    >>> for i in range(1, len(e)): ar[i] = 0.9 * ar[i - 1] + e[i]
    >>> mc = mean_covariance(ar)     # true variance of the mean: 100/4000 = 0.025
    >>> 0.015 < float(mc.cov[0, 0]) < 0.035, mc.resolved
    (True, True)
    """
    x = np.asarray(x, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    n = x.shape[0]
    mean = x.mean(axis=0)
    c = x - mean
    if n < 3:   # too few to see any correlation: as if independent, and say so
        return MeanCovariance(mean, c.T @ c / max(n - 1, 1) / n, n, 0, 1.0, False)
    cap = max(1, int(n * MAX_WINDOW_SHARE))
    rho = _autocorrelation(c)
    window, tau_sokal = _sokal_window(rho, cap)
    S = c.T @ c / n
    for h in range(1, window + 1):
        gamma = c[h:].T @ c[:-h] / n
        S += (1 - h / (window + 1)) * (gamma + gamma.T)
    # the kernel misses a correlation slower than its window sees. A model of fast noise
    # plus one slow first-order component, fitted to lags 1 and 2 of the series averaged
    # over blocks of b samples (which removes what repeats within a block: zero-order
    # held samples), does not; keep the largest variance either finds
    variance = np.diag(S).copy()
    tau_int = tau_sokal
    for b in BLOCKS:
        m = n // b
        if m < MIN_BLOCKS:
            break
        y = c[:m * b].reshape(m, b, -1).mean(axis=1)
        tau_b = _arma_tau(_autocorrelation(y - y.mean(axis=0)), m)
        var_b = b * np.mean((y - y.mean(axis=0)) ** 2, axis=0) * tau_b
        variance = np.maximum(variance, var_b / np.maximum(1 - tau_b / m, 0.5))
        tau_int = max(tau_int, b * float(tau_b.max()))
    raise_to = np.sqrt(variance / np.maximum(np.diag(S), 1e-300))
    S = S * np.outer(raise_to, raise_to)
    resolved = n / tau_int >= MIN_EFFECTIVE
    return MeanCovariance(mean, S / n, n, window, tau_int, resolved)
