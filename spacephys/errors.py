"""The errors spacephys raises besides ValueError (bad input): a breakdown of the integration."""


class InstabilityError(FloatingPointError):
    """The integration broke down: a body's state became NaN or infinite, or the energy
    error passed the limit set with World.watch_energy. ids: the bodies concerned, worst
    first; t: the World's time when it was found."""

    def __init__(self, message, ids, t):
        super().__init__(message)
        self.ids = ids
        self.t = t
