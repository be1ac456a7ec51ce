"""Exact unit conversion factors (SI inside, English units at the edges).

All factors are exact by definition of the international foot and pound
(1959) and of standard gravity (CGPM 1901), except where stated.
"""

FT = 0.3048  #: metre per foot (exact)
IN = 0.0254  #: metre per inch (exact)
LBM = 0.45359237  #: kilogram per pound-mass (exact)
G0 = 9.80665  #: standard gravity, m/s^2 (exact)
LBF = LBM * G0  #: newton per pound-force (exact, 4.4482216152605)
SLUG = LBF / FT  #: kilogram per slug (exact, 14.593902937206364...)
SLUG_FT2 = SLUG * FT * FT  #: kg m^2 per slug ft^2
FT2 = FT * FT  #: m^2 per ft^2
SLUG_FT3 = SLUG / FT**3  #: kg/m^3 per slug/ft^3
HP = 550.0 * LBF * FT  #: watt per (mechanical, shaft) horsepower, 550 ft lbf/s (exact, 745.69987...)
KT = 1852.0 / 3600.0  #: m/s per knot (exact)
DEG = 3.141592653589793 / 180.0  #: rad per degree
