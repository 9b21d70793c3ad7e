"""MPPI's weighting step, compiled: exp(-(J - min J) / T) with T held in the effective-sample-size band, and
the weighted mean of the coefficient samples.

``FourierMPPI.weights`` is the readable NumPy definition (the reference backend uses it);
:func:`weigh_and_average` does the same in one pass on the fast path (tests/controller/test_averaging.py
checks they agree).
"""

from __future__ import annotations

import numba
import numpy as np

# No fastmath here: costs may be infinite (a sample with a non-finite cost), and fastmath assumes they are not.
_JIT_EXACT = {"error_model": "numpy", "cache": True, "nogil": True}


@numba.njit(**_JIT_EXACT)
def effective_samples(shifted_costs, temperature):
    """(sum w)^2 / sum w^2 with w = exp(-shifted / T); ``shifted_costs`` >= 0, inf for excluded samples."""
    total = 0.0
    squares = 0.0
    inverse = 1.0 / temperature
    for i in range(shifted_costs.shape[0]):
        w = np.exp(-shifted_costs[i] * inverse)
        total += w
        squares += w * w
    return total * total / squares


@numba.njit(**_JIT_EXACT)
def temperature_for_band(shifted_costs, temperature, low, high):
    """A temperature whose effective sample size lies in [low, high], starting from ``temperature``.

    ESS grows monotonically with T. If ``temperature`` already gives an ESS in the band it is kept (so the
    weighting changes only when it must); otherwise T is bracketed by factors of 4 and bisected in log T
    towards the band's geometric middle. Costs that cannot reach the band (all equal, or one finite
    sample) end at the bracket's limit. Returns (T, ESS).
    """
    ess = effective_samples(shifted_costs, temperature)
    if low <= ess <= high:
        return temperature, ess
    target = np.sqrt(low * high)
    lower, upper = temperature, temperature
    if ess < low:
        for _ in range(30):
            lower = upper
            upper *= 4.0
            ess = effective_samples(shifted_costs, upper)
            if ess >= target or upper > 1e12:
                break
        t = upper
    else:
        for _ in range(30):
            upper = lower
            lower *= 0.25
            ess = effective_samples(shifted_costs, lower)
            if ess <= target or lower < 1e-12:
                break
        t = lower
    for _ in range(20):
        if low <= ess <= high and abs(np.log(ess / target)) < 0.2:
            break
        t = np.sqrt(lower * upper)
        ess = effective_samples(shifted_costs, t)
        if ess < target:
            lower = t
        else:
            upper = t
    return t, ess


@numba.njit(**_JIT_EXACT)
def weigh_and_average(costs, z, temperature, low, high, use_band, weights, optimum):
    """Normalised weights of ``costs`` (S,) into ``weights`` and their mean of ``z`` (2, C, S) into ``optimum``
    (2, C). With ``use_band`` the temperature is searched from ``temperature`` so that the effective sample
    size lies in [low, high] (sample counts). Returns (any finite cost, min cost, temperature, ESS); with no
    finite cost nothing is written."""
    n = costs.shape[0]
    cost_min = np.inf
    for i in range(n):
        if np.isfinite(costs[i]) and costs[i] < cost_min:
            cost_min = costs[i]
    if not np.isfinite(cost_min):
        return False, np.inf, temperature, 0.0
    for i in range(n):  # the shifted costs, reusing ``weights`` as the buffer
        weights[i] = costs[i] - cost_min if np.isfinite(costs[i]) else np.inf
    if use_band:
        temperature, _ = temperature_for_band(weights, temperature, low, high)
    total = 0.0
    for i in range(n):
        weights[i] = np.exp(-weights[i] / temperature)
        total += weights[i]
    squares = 0.0
    for i in range(n):
        weights[i] /= total
        squares += weights[i] * weights[i]
    for a in range(z.shape[0]):
        for c in range(z.shape[1]):
            acc = 0.0
            for i in range(n):
                acc += weights[i] * z[a, c, i]
            optimum[a, c] = acc
    return True, cost_min, temperature, 1.0 / squares
