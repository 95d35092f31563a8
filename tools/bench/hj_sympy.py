#!/usr/bin/env python3
"""The exact phase of pgi written in sympy, as the baselines of tools/bench/bench_exact.py:
- RingImpl: sympy's sparse polynomial rings (sympy.polys.rings.ring over QQ), the graded algorithm
  (truncated Cauchy products, composition by cached powers) recomposing every lower order at each term,
  as pgi did before its composition order by order;
- RingByOrderImpl: the same rings and pgi's present algorithm (series/composition.hpp): each composition
  completed one order at a time, each product coefficient formed once, and the even Hamilton-Jacobi terms of
  the symmetric realisations known to vanish (docs/math.md 5), not composed;
- ExprImpl: plain sympy expressions (expand / subs / diff / coeff), grading by an auxiliary symbol.
Both compute the Lie-Poisson closed form or the radial realisation (docs/math.md 3-4) and the
Hamilton-Jacobi terms (docs/math.md 5). `--check-log-canonical` prints the independent derivation used in
tests/poisson_hamilton_jacobi.cpp (exponential realisation expanded by sympy itself)."""
import sys

import sympy as sp
from sympy import QQ
from sympy.polys.rings import ring


def bernoulli(m):
    """B_m of z/(e^z - 1); sympy >= 1.12 returns B_1 = +1/2, the other convention."""
    return sp.Rational(-1, 2) if m == 1 else sp.bernoulli(m)


class RingImpl:
    def __init__(self, coords, brackets):
        self.n = n = len(coords)
        self.R, *gens = ring(",".join(coords + ["p_" + c for c in coords]), QQ)
        self.X, self.P = gens[:n], gens[n:]
        self.symbols = {c: sp.Symbol(c) for c in coords}
        self.pi = [[self.R.zero] * n for _ in range(n)]
        for (i, j), s in brackets.items():
            self.pi[i][j] = self.parse(s)
            self.pi[j][i] = -self.pi[i][j]

    def parse(self, text):
        return self.R(sp.sympify(text, locals=self.symbols))

    def mul_trunc(self, a, b):
        N = len(a)
        r = [self.R.zero] * N
        for i in range(N):
            if a[i]:
                for j in range(N - i):
                    if b[j]:
                        r[i + j] += a[i] * b[j]
        return r

    def compose(self, f, images, N):
        """f with variable v -> series images[v] (dict), O(e^N)."""
        powers = {}
        out = [self.R.zero] * N
        for monom, c in f.items():
            mono = self.R({tuple(e if v not in images else 0 for v, e in enumerate(monom)): c})
            term = [mono] + [self.R.zero] * (N - 1)
            for v, e in enumerate(monom):
                if v in images and e:
                    pw = powers.setdefault(v, [[self.R.one] + [self.R.zero] * (N - 1)])
                    while len(pw) <= e:
                        pw.append(self.mul_trunc(pw[-1], images[v]))
                    term = self.mul_trunc(term, pw[e])
            out = [a + b for a, b in zip(out, term)]
        return out

    def can(self, F, G):
        return sum((F.diff(self.X[i]) * G.diff(self.P[i]) - F.diff(self.P[i]) * G.diff(self.X[i])
                    for i in range(self.n)), self.R.zero)

    def lie_poisson(self, D):
        n = self.n
        alpha = [[self.X[i]] + [self.R.zero] * D for i in range(n)]
        v = list(self.X)
        for m in range(1, D + 1):
            v = [sum((self.pi[i][j].diff(self.X[k]) * v[k] * self.P[j] for j in range(n) for k in range(n)), self.R.zero)
                 for i in range(n)]
            c = QQ(bernoulli(m).p, bernoulli(m).q) / QQ(int(sp.factorial(m)))
            for i in range(n):
                alpha[i][m] = v[i] * c
        return alpha

    def log_canonical(self, D):
        """alpha_j = exp((1/2) sum_i a_ij x_i p_i) x_j with pi_ij = a_ij x_i x_j."""
        n = self.n
        alpha = []
        for j in range(n):
            u = sum((self.pi[i][j] * self.P[i] * QQ(1, 2) for i in range(n) if self.pi[i][j]), self.R.zero)
            # pi_ij / x_j = a_ij x_i, so u_j = (1/2) sum_i a_ij x_i p_i = (1/2) sum_i pi_ij p_i / x_j
            u = sum((self.R({tuple(e - (1 if v == j else 0) for v, e in enumerate(mon)): c}) for mon, c in u.items()), self.R.zero)
            comps, term = [self.X[j]], self.X[j]
            for m in range(1, D + 1):
                term = term * u * QQ(1, m)
                comps.append(term)
            alpha.append(comps)
        return alpha

    def radial(self, D):
        n = self.n
        alpha = [[self.X[i]] + [self.R.zero] * D for i in range(n)]
        for m in range(D):
            images = {l: alpha[l][: m + 1] for l in range(n)}
            for j in range(n):
                nxt = self.R.zero
                for i in range(n):
                    R = self.compose(self.pi[i][j], images, m + 1)[m] if self.pi[i][j] else self.R.zero
                    for a in range(1, m + 1):
                        R -= self.can(alpha[i][a], alpha[j][m + 1 - a])
                    nxt += self.P[i] * R
                alpha[j][m + 1] = nxt * QQ(1, m + 2)
        return alpha

    def hamilton_jacobi(self, alpha, H, k):
        H = self.parse(H)
        S = [H]
        for i in range(1, k):
            N = i + 1
            images = {self.n + l: [self.R.zero] + [S[j - 1].diff(self.X[l]) for j in range(1, N)] for l in range(self.n)}
            a = {l: self.compose(sum(alpha[l][: N], self.R.zero), images, N) for l in range(self.n)}
            S.append(self.compose(H, a, N)[i] * QQ(1, i + 1))
        return [str(s.as_expr()).replace("**", "^") for s in S]


    # --- modified Hamiltonians (docs/math.md 7), the same algorithm as magnus/ ---
    def compose_series(self, fs, images, N):
        """sum_m t^m f_m(images), each f a list of t-coefficients."""
        out = []
        for f in fs:
            r = [self.R.zero] * N
            for m, c in enumerate(f[:N]):
                if c:
                    comp = self.compose(c, images, N)
                    for d in range(N - m):
                        r[m + d] += comp[d]
            out.append(r)
        return out

    def inverse_near_identity(self, u, N):
        n = self.n
        v = [[self.R.zero] * N for _ in range(n)]
        for _ in range(1, N):
            images = {i: [self.X[i] + v[i][0]] + v[i][1:] for i in range(n)}
            v = [[-c for c in s] for s in self.compose_series(u, images, N)]
        return v

    def pbracket(self, f, g):
        n = self.n
        return sum((self.pi[i][j] * f.diff(self.X[i]) * g.diff(self.X[j]) for i in range(n) for j in range(n) if self.pi[i][j]),
                   self.R.zero)

    def series_bracket(self, A, B):
        N = min(len(A), len(B))
        r = [self.R.zero] * N
        for a in range(N):
            if A[a]:
                for b in range(N - a):
                    if B[b]:
                        r[a + b] += self.pbracket(A[a], B[b])
        return r

    def magnus(self, h, m):
        M = [self.R.zero] * (m + 1)
        for j in range(1, m + 1):
            hj = (h + [self.R.zero] * j)[:j]
            Mj = M[:j]
            term, rhs = hj, list(hj)
            for i in range(1, j):
                term = self.series_bracket(Mj, term)
                c = QQ(bernoulli(i).p, bernoulli(i).q) / QQ(int(sp.factorial(i)))
                if c:
                    rhs = [a + c * b for a, b in zip(rhs, term)]
            M[j] = rhs[j - 1] * QQ(1, j)
        return M

    def modified(self, alpha, H, k, m):
        """H_0..H_m of the order-k scheme on the realisation alpha (beta = alpha(x, -p))."""
        n, N = self.n, m + 1
        S = [self.parse(s) for s in self.hamilton_jacobi(alpha, H, k)]
        images = {n + l: [self.R.zero] + [S[j - 1].diff(self.X[l]) if j <= k else self.R.zero for j in range(1, N)]
                  for l in range(n)}
        beta_minus_x = [sum((alpha[i][d] * (-1) ** d for d in range(1, min(N, len(alpha[i])))), self.R.zero) for i in range(n)]
        u = [self.compose(b, images, N) for b in beta_minus_x]
        v = self.inverse_near_identity(u, N)
        dS = [S[j - 1] * (j) if j <= k else self.R.zero for j in range(1, N + 1)]
        h = self.compose_series([dS], {i: [self.X[i] + v[i][0]] + v[i][1:] for i in range(n)}, N)[0]
        M = self.magnus(h, m + 1)
        return [str(M[j + 1].as_expr()) for j in range(m + 1)]


class ByOrder:
    """f_i(images) one order at a time, as pgi's ComposeByOrder: products of the images memoised by exponent
    and formed one coefficient at a time; the caller completes the images (lists it keeps) as orders are read."""

    def __init__(self, R, fs, images):
        self.R, self.images = R, images
        self.groups = []
        for f in fs:
            self.append(f)
        self.products = {(): [R.one]}

    def append(self, f):
        """f as the next polynomial (ComposeByOrder::append), sharing the products formed so far."""
        g = {}
        for monom, c in f.items():
            key = tuple((v, e) for v, e in enumerate(monom) if e and v in self.images)
            kept = tuple(0 if v in self.images else e for v, e in enumerate(monom))
            g[key] = g.get(key, self.R.zero) + self.R({kept: c})
        self.groups.append(list(g.items()))

    def product(self, key, d):
        c = self.products.setdefault(key, [])
        if not key:
            c.extend([self.R.zero] * (d + 1 - len(c)))
            return c
        if len(c) > d:
            return c
        v, e = key[0]
        low = self.product((((v, e - 1),) if e > 1 else ()) + key[1:], d)
        image = self.images[v]
        for k in range(len(c), d + 1):
            c.append(sum((low[i] * image[k - i] for i in range(k + 1) if low[i] and image[k - i]), self.R.zero))
        return c

    def coefficient(self, i, m):
        return sum((kept * p for key, kept in self.groups[i] for p in [self.product(key, m)[m]] if p), self.R.zero)


class RingByOrderImpl(RingImpl):
    def radial(self, D):
        n = self.n
        alpha = [[self.X[i]] + [self.R.zero] * D for i in range(n)]
        entries = [(i, j) for i in range(n) for j in range(i + 1, n)]  # R is skew like pi
        pi_of_alpha = ByOrder(self.R, [self.pi[i][j] for i, j in entries], {l: alpha[l] for l in range(n)})
        for m in range(D):
            nxt = [self.R.zero] * n
            for entry, (i, j) in enumerate(entries):
                R = pi_of_alpha.coefficient(entry, m)
                for a in range(1, m + 1):
                    R -= self.can(alpha[i][a], alpha[j][m + 1 - a])
                nxt[j] += self.P[i] * R
                nxt[i] -= self.P[j] * R
            for j in range(n):
                alpha[j][m + 1] = nxt[j] * QQ(1, m + 2)
        return alpha

    def hamilton_jacobi(self, alpha, H, k):
        # pgi's algorithm (docs/math.md 5): G = H o alpha graded by p-degree, G_i appended when S_(i+1) first
        # reads it, and G along p = grad S_t completed one order per term. The realisations here are symmetric
        # (beta = alpha(x, -p)), so, as pgi does (EvenTerms::from_symmetry), S_2j = 0 is not composed and S_(i+1)
        # reads only the G_d with d = i mod 2
        n, zero = self.n, self.R.zero
        H = self.parse(H)
        alpha_images = {l: [alpha[l][d] if d < len(alpha[l]) else zero for d in range(k)] for l in range(n)}
        p_images = {n + l: [zero] * k for l in range(n)}
        H_along_alpha, G_along_gradient = ByOrder(self.R, [H], alpha_images), ByOrder(self.R, [], p_images)
        G_along_gradient.append(H_along_alpha.coefficient(0, 0))
        S = [H]
        for i in range(1, k):
            vanishes = i % 2 == 1
            G_along_gradient.append(zero if vanishes else H_along_alpha.coefficient(0, i))
            for l in range(n):
                p_images[n + l][i] = S[i - 1].diff(self.X[l])
            if vanishes:
                S.append(zero)
                continue
            S.append(sum((G_along_gradient.coefficient(d, i) for d in range(0, i + 1, 2)), zero) * QQ(1, i + 1))
        return [str(s.as_expr()).replace("**", "^") for s in S]

class ExprImpl:
    def __init__(self, coords, brackets):
        self.n = n = len(coords)
        self.X = sp.symbols(coords)
        self.P = sp.symbols(["p_" + c for c in coords])
        self.t, self.e = sp.symbols("t_ e_")
        self.pi = [[sp.Integer(0)] * n for _ in range(n)]
        for (i, j), s in brackets.items():
            self.pi[i][j] = sp.sympify(s, locals=dict(zip(coords, self.X)))
            self.pi[j][i] = -self.pi[i][j]

    def can(self, F, G):
        return sp.expand(sum(sp.diff(F, self.X[i]) * sp.diff(G, self.P[i]) - sp.diff(F, self.P[i]) * sp.diff(G, self.X[i])
                             for i in range(self.n)))

    def lie_poisson(self, D):
        n = self.n
        alpha = [[self.X[i]] + [sp.Integer(0)] * D for i in range(n)]
        v = list(self.X)
        for m in range(1, D + 1):
            v = [sp.expand(sum(sp.diff(self.pi[i][j], self.X[k]) * v[k] * self.P[j] for j in range(n) for k in range(n)))
                 for i in range(n)]
            for i in range(n):
                alpha[i][m] = sp.expand(bernoulli(m) / sp.factorial(m) * v[i])
        return alpha

    def radial(self, D):
        n, e = self.n, self.e
        alpha = [[self.X[i]] + [sp.Integer(0)] * D for i in range(n)]
        for m in range(D):
            sub = {self.X[l]: sum(e ** a * alpha[l][a] for a in range(m + 1)) for l in range(n)}
            for j in range(n):
                nxt = 0
                for i in range(n):
                    R = sp.expand(self.pi[i][j].subs(sub, simultaneous=True)).coeff(e, m)
                    R -= sum(self.can(alpha[i][a], alpha[j][m + 1 - a]) for a in range(1, m + 1))
                    nxt += self.P[i] * R
                alpha[j][m + 1] = sp.expand(nxt / (m + 2))
        return alpha

    def hamilton_jacobi(self, alpha, H, k):
        t, n = self.t, self.n
        H = sp.sympify(H, locals={str(x): x for x in self.X})
        S = [H]
        for i in range(1, k):
            St = sum(t ** j * S[j - 1] for j in range(1, i + 1))
            psub = {self.P[l]: sp.diff(St, self.X[l]) for l in range(n)}
            a = [sp.expand(sum(alpha[l][: i + 1]).subs(psub, simultaneous=True)) for l in range(n)]
            a = [sum(x.coeff(t, j) * t ** j for j in range(i + 1)) for x in a]
            comp = sp.expand(H.subs(dict(zip(self.X, a)), simultaneous=True))
            S.append(sp.expand(comp.coeff(t, i) / (i + 1)))
        return [str(s) for s in S]


def check_log_canonical():
    x, y, t, px, py = sp.symbols("x y t p_x p_y")
    a = [[0, 2], [-2, 0]]
    X, P = [x, y], [px, py]
    alpha = [sp.exp(sp.Rational(1, 2) * sum(a[i][j] * X[i] * P[i] for i in range(2))) * X[j] for j in range(2)]
    H = lambda u: u[0] * u[1] + u[0]
    S = [H(X)]
    for i in range(1, 3):
        St = sum(t ** (j + 1) * S[j] for j in range(i))
        comp = H([al.subs({P[l]: sp.diff(St, X[l]) for l in range(2)}) for al in alpha])
        S.append(sp.expand(sp.series(comp, t, 0, i + 1).removeO().coeff(t, i) / (i + 1)))
    for j, s in enumerate(S):
        print(f"S_{j + 1} = {s}")


if __name__ == "__main__" and "--check-log-canonical" in sys.argv:
    check_log_canonical()
