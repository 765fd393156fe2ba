"""Unit systems: the value of G that makes F = G m1 m2 / D^2 hold in each."""
from dataclasses import dataclass


@dataclass(frozen=True)
class UnitSystem:
    """name; G [length^3 / (mass time^2)]; the length, mass and time units in words."""
    name: str
    G: float
    length: str
    mass: str
    time: str


# Gaussian gravitational constant k [AU^(3/2) Msun^(-1/2) day^-1] (IAU), Julian year of 365.25 d:
# G = (k * 365.25)^2 = 39.4769... AU^3 / (Msun yr^2), a little under 4 pi^2 = 39.478...
_K_GAUSS = 0.01720209895

UNITS = {
    "game": UnitSystem("game", 1.0, "length unit", "mass unit", "time unit"),
    "si": UnitSystem("si", 6.67430e-11, "m", "kg", "s"),                 # CODATA 2018
    "au-msun-yr": UnitSystem("au-msun-yr", (_K_GAUSS * 365.25) ** 2, "AU", "solar mass",
                             "Julian year"),
}


def get_units(name):
    """The UnitSystem registered under name; ValueError listing the valid names otherwise."""
    try:
        return UNITS[name]
    except (KeyError, TypeError):
        raise ValueError(f"units={name!r} is not known; valid: {', '.join(UNITS)}") from None
