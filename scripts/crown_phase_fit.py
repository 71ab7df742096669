#!/usr/bin/python3
"""The polynomial in scene/street.cpp's crown_phase (the Lambert sphere's phase law for tree crowns).

Φ(α) = (2/(3π))·(sin α + (π − α)·cos α). With c = cos α, a = |c| and s = √(1 − a):
  sin α = s·√(1 + a);  for c ≥ 0, (π − α)·c = a·(π − arccos a);  for c < 0, (π − α)·c = −a·arccos a,
so Φ = (2/(3π))·(s·Q(a) + [c ≥ 0]·π·a) with Q(a) = √(1 + a) − a·arccos(a)/√(1 − a), which is smooth
on [0, 1] (arccos(a)/√(1 − a) → √2 at a = 1). Q is fitted here by a degree-5 Chebyshev least-squares
polynomial on a 200,001-point grid and printed in powers of a, with its largest error on the grid.
Run: /usr/bin/python3 scripts/crown_phase_fit.py
"""
import numpy as np

a = np.linspace(0.0, 1.0, 200001)
r = np.empty_like(a)
r[:-1] = np.arccos(a[:-1]) / np.sqrt(1.0 - a[:-1])
r[-1] = np.sqrt(2.0)
Q = np.sqrt(1.0 + a) - a * r
cheb = np.polynomial.chebyshev.chebfit(2.0 * a - 1.0, Q, 5)
P = np.polynomial.Polynomial(np.polynomial.chebyshev.cheb2poly(cheb))(np.polynomial.Polynomial([-1.0, 2.0]))
Pf = P.coef.astype(np.float32).astype(np.float64)  # as the code stores them
err = np.abs(np.polynomial.Polynomial(Pf)(a) - Q).max()
print("Q(a) coefficients, a^0 .. a^5 (float32):", ", ".join(f"{c:.9g}f" for c in P.coef.astype(np.float32)))
print(f"largest |P(a) - Q(a)| on the grid, float32 coefficients: {err:.3g}")
print(f"so |ΔΦ| <= (2/(3π))·s·{err:.3g} <= {2 / (3 * np.pi) * err:.3g}")
