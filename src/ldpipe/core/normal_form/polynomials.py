"""Polynomials in the 2n canonical variables (q_1..q_n, p_1..p_n) as dense arrays, degree by degree.

A polynomial truncated at degree N is a list ``f`` of N + 1 complex arrays, ``f[d]`` holding the
coefficients of the homogeneous part of degree d over the monomials of :class:`MonomialBasis`
(``basis.exponents[d][i]`` is the exponent tuple of coefficient ``f[d][i]``). All arithmetic is
numpy on these arrays: no symbolic algebra in the loops. A monomial is found from its exponents
by its key, the exponents read as digits in base N + 1, looked up by binary search in the degree's
sorted keys; the Poisson bracket of two homogeneous parts is then one outer product of their
nonzero coefficients and a scatter-add per degree of freedom.

The Poisson bracket is {f, g} = Σ_k ∂f/∂q_k ∂g/∂p_k − ∂f/∂p_k ∂g/∂q_k, so q̇ = {q, H} = ∂H/∂p.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import scipy.linalg


LOOKUP_LIMIT = 30_000_000


class MonomialBasis:
    """The monomials of degree 0..``max_degree`` in ``2 n_dof`` variables, ordered by key per degree."""

    def __init__(self, n_dof: int, max_degree: int):
        self.n_dof = int(n_dof)
        self.max_degree = int(max_degree)
        self.n_variables = 2 * self.n_dof
        self.radix = self.max_degree + 1
        self.place = self.radix ** np.arange(self.n_variables, dtype=np.int64)
        self.exponents: list[np.ndarray] = []
        self.keys: list[np.ndarray] = []
        for degree in range(self.max_degree + 1):
            exponents = np.zeros((math.comb(degree + self.n_variables - 1, degree), self.n_variables), dtype=np.int64)
            for row, combination in enumerate(itertools.combinations_with_replacement(range(self.n_variables), degree)):
                for variable in combination:
                    exponents[row, variable] += 1
            keys = exponents @ self.place
            order = np.argsort(keys)
            self.exponents.append(exponents[order])
            self.keys.append(keys[order])
        # Each monomial of degree d ≥ 1 is its parent of degree d − 1 times one variable (its first):
        # evaluation builds every degree from the one below with one product per monomial.
        self.parent: list[np.ndarray] = [np.zeros(0, dtype=np.int64)]
        self.factor: list[np.ndarray] = [np.zeros(0, dtype=np.int64)]
        for degree in range(1, self.max_degree + 1):
            exponents = self.exponents[degree]
            first = np.argmax(exponents > 0, axis=1)
            parents = exponents.copy()
            parents[np.arange(len(parents)), first] -= 1
            self.factor.append(first)
            self.parent.append(np.searchsorted(self.keys[degree - 1], parents @ self.place))
        # A dense table from key to position is faster than binary search, where it fits (13⁶ entries
        # for 3 DoF at degree 12).
        self.table = None
        if self.radix**self.n_variables <= LOOKUP_LIMIT:
            self.table = np.zeros(self.radix**self.n_variables, dtype=np.int32)
            for keys in self.keys:
                self.table[keys] = np.arange(len(keys), dtype=np.int32)

    def position(self, degree: int, keys: np.ndarray) -> np.ndarray:
        """Positions in degree ``degree`` of monomials given by their keys."""
        if self.table is not None:
            return self.table[keys]
        return np.searchsorted(self.keys[degree], keys)

    def size(self, degree: int) -> int:
        return len(self.keys[degree])

    def index(self, degree: int, exponents) -> np.ndarray:
        """Positions in degree ``degree`` of exponent rows (shape ``(..., 2n)``)."""
        return self.position(degree, np.asarray(exponents, dtype=np.int64) @ self.place)

    def zero(self, degree: int) -> np.ndarray:
        return np.zeros(self.size(degree), dtype=np.complex128)

    def zeros(self, max_degree: int | None = None) -> list[np.ndarray]:
        top = self.max_degree if max_degree is None else max_degree
        return [self.zero(d) for d in range(top + 1)]

    def variable(self, k: int, max_degree: int | None = None) -> list[np.ndarray]:
        """The coordinate function of variable k (q_k for k < n, p_(k-n) else) as a polynomial."""
        f = self.zeros(max_degree)
        unit = np.zeros(self.n_variables, dtype=np.int64)
        unit[k] = 1
        f[1][self.index(1, unit)] = 1.0
        return f

    def bracket(self, f: np.ndarray, a: int, g: np.ndarray, b: int) -> np.ndarray:
        """{f, g} for f homogeneous of degree a and g of degree b: the coefficients of degree a + b − 2."""
        c = a + b - 2
        out = self.zero(c) if c >= 0 else np.zeros(0, dtype=np.complex128)
        if a == 0 or b == 0 or c > self.max_degree:
            return out
        fi = np.flatnonzero(f)
        gi = np.flatnonzero(g)
        if len(fi) == 0 or len(gi) == 0:
            return out
        ef, eg = self.exponents[a][fi], self.exponents[b][gi]
        products = f[fi][:, None] * g[gi][None, :]
        base = self.keys[a][fi][:, None] + self.keys[b][gi][None, :]
        n = self.n_dof
        targets, values = [], []
        for k in range(n):
            weight = ef[:, k, None] * eg[None, :, n + k] - ef[:, n + k, None] * eg[None, :, k]
            mask = weight != 0
            if not mask.any():
                continue
            targets.append(base[mask] - (self.place[k] + self.place[n + k]))
            values.append(products[mask] * weight[mask])
        if targets:
            positions = self.position(c, np.concatenate(targets))
            values = np.concatenate(values)
            size = self.size(c)
            out += np.bincount(positions, weights=values.real, minlength=size)
            out += 1j * np.bincount(positions, weights=values.imag, minlength=size)
        return out

    def multiply(self, f: np.ndarray, a: int, g: np.ndarray, b: int) -> np.ndarray:
        """f g for f homogeneous of degree a and g of degree b (degree a + b ≤ max_degree)."""
        c = a + b
        out = self.zero(c)
        fi, gi = np.flatnonzero(f), np.flatnonzero(g)
        if len(fi) == 0 or len(gi) == 0:
            return out
        positions = self.position(c, (self.keys[a][fi][:, None] + self.keys[b][gi][None, :]).ravel())
        values = (f[fi][:, None] * g[gi][None, :]).ravel()
        out += np.bincount(positions, weights=values.real, minlength=len(out))
        out += 1j * np.bincount(positions, weights=values.imag, minlength=len(out))
        return out

    def substitute_linear(self, f: list[np.ndarray], matrix: np.ndarray, max_degree: int | None = None) -> list[np.ndarray]:
        """f(L y) as a polynomial in y, for the linear map x = L y given by ``matrix`` (2n × 2n).

        L = P L₁ U (scipy's LU) is applied as elementary substitutions, each cheap on dense arrays:
        the permutation, the unit lower factor as single shears x_i = y_i + c y_j column by column
        (L₁ = Π_j (I + l_j e_jᵀ), j increasing), the diagonal, the unit upper factor (j
        decreasing). A shear sends x_i^a to Σ_k C(a, k) c^k y_i^(a−k) y_j^k. Degrees are preserved.
        """
        top = (len(f) - 1) if max_degree is None else max_degree
        permutation, lower, upper = scipy.linalg.lu(np.asarray(matrix, dtype=np.complex128))
        diagonal = np.diag(upper).copy()
        unit_upper = upper / diagonal[:, None]
        m = self.n_variables
        out = []
        for degree in range(top + 1):
            if degree >= len(f):
                out.append(self.zero(degree))
                continue
            g = self._permute(np.asarray(f[degree], dtype=np.complex128), degree, permutation)
            for j in range(m):
                for i in range(j + 1, m):
                    if lower[i, j] != 0:
                        g = self._shear(g, degree, i, j, lower[i, j])
            g = g * np.prod(diagonal[None, :] ** self.exponents[degree], axis=1)
            for j in range(m - 1, -1, -1):
                for i in range(j):
                    if unit_upper[i, j] != 0:
                        g = self._shear(g, degree, i, j, unit_upper[i, j])
            out.append(g)
        return out

    def _permute(self, g: np.ndarray, degree: int, permutation: np.ndarray) -> np.ndarray:
        """g(P y) for a permutation matrix P (x_i = y_σ(i), P[i, σ(i)] = 1)."""
        sigma = np.argmax(permutation, axis=1)
        exponents = np.zeros_like(self.exponents[degree])
        exponents[:, sigma] = self.exponents[degree]
        out = self.zero(degree)
        out[self.index(degree, exponents)] = g
        return out

    def _shear(self, g: np.ndarray, degree: int, i: int, j: int, c: complex) -> np.ndarray:
        """g after x_i = y_i + c y_j (other variables unchanged)."""
        out = self.zero(degree)
        nonzero = np.flatnonzero(g)
        if len(nonzero) == 0:
            return out
        keys = self.keys[degree][nonzero]
        power = self.exponents[degree][nonzero, i]
        values = g[nonzero]
        for k in range(int(power.max()) + 1):
            mask = power >= k
            weight = np.array([math.comb(int(a), k) for a in power[mask]], dtype=np.float64) * c**k
            target = self.position(degree, keys[mask] + k * (self.place[j] - self.place[i]))
            contribution = values[mask] * weight
            out += np.bincount(target, weights=contribution.real, minlength=len(out))
            out += 1j * np.bincount(target, weights=contribution.imag, minlength=len(out))
        return out

    def evaluate(self, f: list[np.ndarray], points: np.ndarray, *, chunk: int = 512) -> np.ndarray:
        """f at ``points`` (shape ``(m, 2n)``, real or complex)."""
        return self.evaluate_all([f], points, chunk=chunk)[0]

    def evaluate_all(self, functions: list[list[np.ndarray]], points: np.ndarray, *, chunk: int = 256) -> np.ndarray:
        """Every polynomial of ``functions`` at ``points``, shape ``(len(functions), m)``.

        The monomials are built degree by degree, each from its parent (one product apiece), once
        per block of points, and shared by all the polynomials; real coefficients at real points
        stay real.
        """
        points = np.asarray(points)
        dtype = np.result_type(points, *[c for f in functions for c in f])
        top = max(len(f) for f in functions) - 1
        coefficients = [np.stack([f[d] if d < len(f) and len(f[d]) else np.zeros(self.size(d)) for f in functions])
                        for d in range(top + 1)]
        live = [bool(np.any(c)) for c in coefficients]
        total = np.zeros((len(functions), points.shape[0]), dtype=dtype)
        for start in range(0, points.shape[0], chunk):
            block = points[start:start + chunk].T
            monomials = np.ones((1, block.shape[1]), dtype=dtype)
            part = total[:, start:start + chunk]
            if live[0]:
                part += coefficients[0] @ monomials
            for degree in range(1, top + 1):
                monomials = monomials[self.parent[degree]] * block[self.factor[degree]]
                if live[degree]:
                    part += coefficients[degree] @ monomials
        return total
