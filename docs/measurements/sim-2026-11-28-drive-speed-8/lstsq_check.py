"""Does numba's np.linalg.lstsq give numpy's bits on systems like the impact solver's (_solve_small: symmetric positive
semidefinite, 2-6 unknowns, half of them singular: two contacts with the same normal)? numba calls scipy's LAPACK
(gelsd), numpy its own; numba's rcond defaults to -1 (machine precision), numpy's None to eps * max(m, n).

  python lstsq_check.py [matched|default]   # matched: numba given numpy's rcond
"""
from __future__ import annotations

import sys

import numba
import numpy as np
import scipy
from numba import njit


@njit(cache=False)
def numba_lstsq(a, b, rcond):
    return np.linalg.lstsq(a, b, rcond)[0]


def main(matched: bool) -> None:
    print(f"numpy {np.__version__}, scipy {scipy.__version__}, numba {numba.__version__}; rcond {'matched' if matched else 'default'}")
    rng = np.random.default_rng(0)
    differ, worst, trials = 0, 0.0, 20000
    for _ in range(trials):
        n = int(rng.integers(2, 7))
        k = int(rng.integers(1, n + 1))
        jac = rng.normal(size=(k, n)) * rng.uniform(0.1, 10.0)
        if k > 1 and rng.random() < 0.5:
            jac[1] = jac[0] * rng.uniform(0.5, 2.0)  # a repeated normal: singular
        a = jac.T @ jac
        a = 0.5 * (a + a.T)
        b = rng.normal(size=n)
        expected = np.linalg.lstsq(a, b, rcond=None)[0]
        got = numba_lstsq(a, b, np.finfo(np.float64).eps * n if matched else -1.0)
        if not np.array_equal(expected, got):
            differ += 1
            worst = max(worst, float(np.abs(expected - got).max() / max(1e-300, np.abs(expected).max())))
    print(f"{differ} of {trials} solutions differ in some bit; largest relative difference {worst:.3g}")


if __name__ == "__main__":
    if len(sys.argv) > 2 or (len(sys.argv) == 2 and sys.argv[1] not in ("matched", "default")):
        sys.exit("usage: lstsq_check.py [matched|default]")
    main(len(sys.argv) == 1 or sys.argv[1] == "matched")
