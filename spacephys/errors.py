"""The errors spacephys raises besides ValueError (bad input): a breakdown of the integration."""


class InstabilityError(FloatingPointError):
    """The integration broke down: a body's state became NaN or infinite, or the energy
    error passed the limit set with World.watch_energy. ids: the bodies concerned, worst
    first; t: the World's time when it was found."""

    def __init__(self, message, ids, t):
        super().__init__(message)
        self.ids = ids
        self.t = t


class PrecisionWarning(UserWarning):
    """The bodies lie so far from the origin, for the size of the scene, that positions keep
    too few significant digits within it (errors grow with that); move the origin to the
    scene (World.shift_origin). Given once per World."""
