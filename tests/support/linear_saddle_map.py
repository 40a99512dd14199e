"""The linear saddle map x -> l x, y -> y / l (l > 1) and its discrete LD in closed form.

Its inverse is x -> x / l, y -> l y; the orbit of (x0, y0) is x_n = l^n x0, y_n = l^-n y0, so
|x_{n+1} - x_n| = |x0| l^n (l - 1) and |y_{n+1} - y_n| = |y0| l^-(n+1) (l - 1). With
S(r, N) = sum_{n=0}^{N-1} r^n = (r^N - 1) / (r - 1), the discrete LD's halves
(M_p = sum_{n=-N}^{N-1} sum_i |x^i_{n+1} - x^i_n|^p) are

    forward  = (l - 1)^p (|x0|^p S(l^p, N) + |y0|^p l^-p S(l^-p, N)),
    backward = (l - 1)^p (|y0|^p S(l^p, N) + |x0|^p l^-p S(l^-p, N))

(backward: n = -m, m = 1 .. N: |x_{n+1} - x_n| = |x0| (l - 1) l^-m and |y_{n+1} - y_n| =
|y0| (l - 1) l^(m-1)).
"""

from __future__ import annotations

LAMBDA = 1.5
#: The map's ``systems:`` entry (less its name), at l = :data:`LAMBDA`.
SPEC = {"map": {"x": "l*x", "y": "y/l"}, "inverse": {"x": "x/l", "y": "l*y"}, "coordinates": ["x", "y"],
        "parameters": {"l": LAMBDA}}


def geometric(r: float, n: int) -> float:
    """sum_{k=0}^{n-1} r^k."""
    return n if r == 1 else (r**n - 1) / (r - 1)


def saddle_halves(x0: float, y0: float, n: int, p: float, lam: float = LAMBDA) -> tuple[float, float]:
    """The forward and backward halves of the LD of (x0, y0) over n iterations each way."""
    grow, shrink = geometric(lam**p, n), lam**-p * geometric(lam**-p, n)
    scale = (lam - 1) ** p
    return (scale * (abs(x0) ** p * grow + abs(y0) ** p * shrink),
            scale * (abs(y0) ** p * grow + abs(x0) ** p * shrink))
