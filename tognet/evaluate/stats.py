"""Confidence intervals for success rates and for paired differences of success rates.

- :func:`wilson`: the Wilson score interval of one proportion (Newcombe 1998, method 3): good coverage
  from a handful of trials on, never outside [0, 1], not degenerate at 0 or n successes.
- :func:`paired_difference`: the difference of two success rates measured on the same scenes, with
  Newcombe's square-and-add interval for paired data (Newcombe 1998, "Improved confidence intervals for
  the difference between binomial proportions based on paired data", method 10): the two Wilson
  intervals combined with the correlation of the pairs (the continuity-corrected phi).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

#: The standard normal quantile of a two-sided 95 % interval.
Z95 = 1.959963984540054


def wilson(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval (low, high) of ``successes`` out of ``n``; (0, 1) when n = 0."""
    if n < 0 or not 0 <= successes <= n:
        raise ValueError(f"need 0 <= successes <= n, got {successes} of {n}")
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    z2 = z * z
    centre = (p + z2 / (2 * n)) / (1 + z2 / n)
    half = z / (1 + z2 / n) * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n))
    lo, hi = centre - half, centre + half
    # Exact ends at 0 and n successes (the formula gives them up to rounding).
    return (0.0 if successes == 0 else max(0.0, lo)), (1.0 if successes == n else min(1.0, hi))


def paired_table(first: ArrayLike, second: ArrayLike) -> tuple[int, int, int, int]:
    """Counts (a, b, c, d) of paired 0/1 outcomes: both succeed, only the first, only the second, neither."""
    x = np.asarray(first, dtype=bool)
    y = np.asarray(second, dtype=bool)
    if x.shape != y.shape:
        raise ValueError(f"paired outcomes need equal lengths, got {x.shape} and {y.shape}")
    return int((x & y).sum()), int((x & ~y).sum()), int((~x & y).sum()), int((~x & ~y).sum())


def newcombe_paired(a: int, b: int, c: int, d: int, z: float = Z95) -> tuple[float, float, float]:
    """(difference, low, high) of p1 - p2 = (b - c) / n for the paired 2x2 table (a both, b first only,
    c second only, d neither), by Newcombe's method 10."""
    n = a + b + c + d
    if n == 0:
        return 0.0, -1.0, 1.0
    r1, r2 = a + b, a + c  # successes of the first and of the second
    p1, p2 = r1 / n, r2 / n
    l1, u1 = wilson(r1, n, z)
    l2, u2 = wilson(r2, n, z)
    phi = 0.0
    if min(r1, n - r1, r2, n - r2) > 0:
        det = a * d - b * c
        if det > n / 2:
            det_cc = det - n / 2
        elif det >= 0:
            det_cc = 0.0
        else:
            det_cc = float(det)
        phi = det_cc / math.sqrt(r1 * (n - r1) * r2 * (n - r2))
    diff = p1 - p2
    lo = diff - math.sqrt(max(0.0, (p1 - l1) ** 2 + (u2 - p2) ** 2 - 2 * phi * (p1 - l1) * (u2 - p2)))
    hi = diff + math.sqrt(max(0.0, (p2 - l2) ** 2 + (u1 - p1) ** 2 - 2 * phi * (p2 - l2) * (u1 - p1)))
    return diff, max(-1.0, lo), min(1.0, hi)


def paired_difference(first: ArrayLike, second: ArrayLike, z: float = Z95) -> dict[str, Any]:
    """Rate of ``first`` minus rate of ``second`` over the same scenes (0/1 outcomes, pairwise), with its
    95 % interval and the table behind it."""
    a, b, c, d = paired_table(first, second)
    diff, lo, hi = newcombe_paired(a, b, c, d, z)
    return {"pairs": a + b + c + d, "difference": diff, "ci": [lo, hi],
            "both": a, "first_only": b, "second_only": c, "neither": d}
