"""Physical constants and the shearing sheet's fixed numbers, declared once."""

import math

#: Newton's constant G [m^3 kg^-1 s^-2], CODATA 2018.
G_SI = 6.67430e-11
#: Shear parameter of a Keplerian disk: the shear flow is vy = -SHEAR * Omega * x.
SHEAR = 1.5
#: One orbit in radians.
TWO_PI = 2.0 * math.pi
#: Speed of light in vacuum c [m/s], exact by the SI's definition of the metre (2019).
SPEED_OF_LIGHT = 299_792_458.0
