"""Drawing a mode's World: spacephys.draw's Painter with the mode's camera, team colours,
engine flames and overlay (predicted paths, markers), then its HUD and help line on panels."""
import numpy as np
import pygame

from ..draw import Camera, Painter

TEXT = (220, 220, 220)


class View:
    """Draws onto `surface` (the window, or an off-screen Surface)."""

    def __init__(self, surface):
        self.surface = surface
        self.size = surface.get_size()
        self.painter = Painter(surface)
        self.font = self.painter.font
        self.projection = None

    def draw(self, mode, alpha):
        """One frame of `mode` at `alpha` (World.advance's)."""
        w = mode.world
        from ..draw import drawn_positions
        centre, half = mode.camera(drawn_positions(w, alpha))
        camera = self.projection = Camera(centre, half)
        overlay = mode.overlay()
        ships = [int(i) for i in w.actor_ids]
        self.painter.draw(w, alpha, camera, path=overlay.get("paths", []),
                          colours={body: mode.colour(body) for body in ships},
                          flames=[int(i) for i in mode.flames()])
        for pos, colour, label in overlay.get("markers", []):
            x, y = camera(np.asarray(pos))
            pygame.draw.circle(self.surface, colour, (x, y), 4, 1)
            if label:
                self.surface.blit(self.font.render(label, True, colour), (x + 6, y - 6))
        self.painter.text(mode.hud(), 6, 6)
        keys = "   ".join(f"{k}: {what}" for k, what in mode.keys)
        self.painter.text([keys], 6, self.size[1] - 22)
