#!/usr/bin/env python3
"""Coefficients of host/lookup/fast_trig.h: Chebyshev fits (mpmath.chebyfit,
50 digits) of the polynomial parts of atan, sin and cos in z = r^2, printed
as the header spells them, with each fit's maximum error.

    python3 host/lookup/fast_trig_fit.py
"""
import mpmath as mp

mp.mp.dps = 50


def fit(name, f, zmax, n, scale):
    c, err = mp.chebyfit(f, [0, zmax], n, error=True)
    print(f"{name}: {n} coefficients (z^0 first), fit error <= {mp.nstr(err * scale, 3)}")
    print("  " + ", ".join(repr(float(x)) for x in c[::-1]))


def limit(g, at0):
    return lambda z: mp.mpf(at0) if z == 0 else g(z)


tan_pi8 = mp.tan(mp.pi / 8)
# atan(t) = t + t z h(z), |t| <= tan(pi/8): error in atan = t z err(h).
fit("atan h", limit(lambda z: (mp.atan(mp.sqrt(z)) / mp.sqrt(z) - 1) / z, -mp.mpf(1) / 3),
    tan_pi8**2, 9, tan_pi8**3)
q = (mp.pi / 4) ** 2
# sin(r) = r + r^3 S(z), cos(r) = 1 - z/2 + z^2 C(z), |r| <= pi/4.
fit("sin S", limit(lambda z: (mp.sin(mp.sqrt(z)) - mp.sqrt(z)) / (z * mp.sqrt(z)), -mp.mpf(1) / 6),
    q, 6, q * mp.pi / 4)
fit("cos C", limit(lambda z: (mp.cos(mp.sqrt(z)) - 1 + z / 2) / (z * z), mp.mpf(1) / 24), q, 6, q * q)
for name, v in [("pi", mp.pi), ("pi/2", mp.pi / 2), ("pi/4", mp.pi / 4), ("3 pi/4", 3 * mp.pi / 4)]:
    print(f"{name} = {float(v)!r} + {float(v - mp.mpf(float(v)))!r}")
e = mp.floor(mp.log(mp.pi / 2, 2)) - 32
hi = mp.floor(mp.pi / 2 / mp.mpf(2) ** e) * mp.mpf(2) ** e  # 33 significant bits
print(f"pi/2 = {float(hi)!r} (33 bits) + {float(mp.pi / 2 - hi)!r}")
print(f"2/pi = {float(2 / mp.pi)!r}, tan(pi/8) = {float(tan_pi8)!r}")
