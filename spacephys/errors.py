"""The errors spacephys raises besides ValueError (bad input): a breakdown of the integration;
and where a warning points (caller_level)."""
import inspect
import os


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


def caller_level():
    """warnings.warn's stacklevel for the first frame outside spacephys (the user's call)."""
    frame, level = inspect.currentframe().f_back, 1
    while frame is not None and frame.f_code.co_filename.startswith(_PACKAGE):
        frame, level = frame.f_back, level + 1
    return level


_PACKAGE = os.path.dirname(os.path.abspath(__file__))
