"""spacephys play: Spacewar! (duel), a ship in a planetary system steered by its predicted
path (orbit) and a battle of AI ships (arena), drawn with pygame-ce (the `game` extra).

Written on the public API only (World, queries, guidance, predict, plans, recommend, run
logs), as a game developer would: the modes in duel.py, orbit.py and arena.py, the
computer's pilot in pilot.py, the frame loop (fixed steps, interpolated drawing, recording
and replay) in loop.py, the drawing in view.py. pygame is imported by loop.py and view.py
only, so the modes and the pilot run without it.
"""
from .modes import MODES, make_mode
from .pilot import Pilot

__all__ = ["MODES", "make_mode", "Pilot"]
