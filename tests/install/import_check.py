"""Run by consumer.cmake with PYTHONPATH set to the installed package's directory only: pgi imports from
there and steps the harmonic oscillator (one midpoint step of dt = 0.1 from (1, 0), to round-off)."""
import sys

import pgi

prefix = sys.argv[1]
assert pgi.__file__.startswith(prefix), (pgi.__file__, prefix)
s = pgi.Scheme(coordinates=["q", "p"], brackets={"q,p": "1"}, hamiltonian="(q^2 + p^2)/2", order=2)
x = s.step([1.0, 0.0], 0.1)
# k = 2 on the oscillator is the midpoint rule: q = (1 - h^2/4)/(1 + h^2/4), p = -h/(1 + h^2/4), h = 0.1
assert abs(x[0] - 0.9975 / 1.0025) < 1e-15 and abs(x[1] + 0.1 / 1.0025) < 1e-15, x
print("python: pgi", pgi.__version__, "from", pgi.__file__, "step", x)
