"""Drawing a mode's World with pygame-ce: the bodies where w.interpolate(alpha) puts them
(ships as triangles along their heading, debris as fading points), the mode's overlay
(predicted paths, markers) and its HUD."""
import math

import numpy as np
import pygame

BACKGROUND = (0, 0, 10)
KIND_COLOURS = {"star": (255, 220, 110), "planet": (70, 120, 220), "moon": (170, 170, 170),
                "station": (150, 255, 150), "asteroid": (150, 130, 110),
                "body": (200, 200, 200)}
DEBRIS = np.array([255.0, 170.0, 80.0])
TEXT = (220, 220, 220)


def positions(world, alpha):
    """(n, 2) where to draw each body: between its last two states, except across a
    periodic seam (the interpolation would cross the whole box)."""
    drawn = world.interpolate(alpha)[:, :2]
    mode, lo, hi, _ = world.boundary
    if mode == "periodic" and world.n:
        now = world.pos[:, :2]
        jumped = np.abs(drawn - now) > (hi - lo)[:2] / 4
        drawn = np.where(jumped, now, drawn)
    return drawn


class Projection:
    """World coordinates to pixels: `centre` (2,) at the middle of a surface `size` (w, h)
    pixels, `half` [length] from the middle to the top; y up in the world, down on screen."""

    def __init__(self, size, centre, half):
        self.size = size
        self.centre = np.asarray(centre, float)
        self.scale = size[1] / (2.0 * half)

    def __call__(self, pos):
        pos = np.asarray(pos, float)
        x = self.size[0] / 2 + (pos[..., 0] - self.centre[0]) * self.scale
        y = self.size[1] / 2 - (pos[..., 1] - self.centre[1]) * self.scale
        return np.stack([x, y], axis=-1)


class View:
    """Draws onto `surface` (the window, or an off-screen Surface)."""

    def __init__(self, surface):
        self.surface = surface
        self.size = surface.get_size()
        self.font = pygame.font.Font(None, 20)
        rng = np.random.default_rng(7)                      # the same sky every run
        self.sky = rng.integers(0, self.size, (200, 2))
        self.projection = None

    def draw(self, mode, alpha):
        """One frame of `mode` at `alpha` (World.advance's)."""
        w, surf = mode.world, self.surface
        surf.fill(BACKGROUND)
        pixels = pygame.surfarray.pixels3d(surf)
        pixels[self.sky[:, 0], self.sky[:, 1]] = (70, 70, 90)
        drawn = positions(w, alpha)
        project = self.projection = Projection(self.size, *mode.camera(drawn))
        px = project(drawn)
        kinds = w.kinds
        names = np.array(kinds)[w.kind] if w.n else np.zeros(0, str)
        debris = names == "debris"
        if debris.any():                                    # thousands: points, no calls
            xy = px[debris].astype(np.int64)
            inside = (xy[:, 0] >= 0) & (xy[:, 0] < self.size[0]) & (xy[:, 1] >= 0) & \
                (xy[:, 1] < self.size[1])
            fade = w.intensity[debris][inside, None]
            pixels[xy[inside, 0], xy[inside, 1]] = (DEBRIS * fade).astype(np.uint8)
        del pixels                                          # (unlocks the surface)
        ids, radius = w.ids, w.radius
        for r in np.flatnonzero(~debris):
            name, body = names[r], int(ids[r])
            x, y = px[r]
            if name == "ship":
                self._ship(w, mode, body, x, y, max(10.0, radius[r] * project.scale))
            elif name == "missile":
                pygame.draw.circle(surf, mode.colour(body), (x, y), 2)
            elif name == "station":
                s = max(4.0, radius[r] * project.scale)
                pygame.draw.rect(surf, KIND_COLOURS[name], (x - s, y - s, 2 * s, 2 * s), 1)
            else:
                pygame.draw.circle(surf, KIND_COLOURS.get(name, KIND_COLOURS["body"]), (x, y),
                                   max(2.0, radius[r] * project.scale))
        self._overlay(mode.overlay(), project)
        self._text(mode.hud(), 6, 6)
        keys = "   ".join(f"{k}: {what}" for k, what in mode.keys)
        self._text([keys], 6, self.size[1] - 22)

    def _ship(self, w, mode, body, x, y, size):
        h = w.heading(body)
        c, s = math.cos(h), -math.sin(h)                     # screen y points down
        nose = (x + size * c, y + size * s)
        left = (x + size * (-0.7 * c + 0.6 * s), y + size * (-0.7 * s - 0.6 * c))
        right = (x + size * (-0.7 * c - 0.6 * s), y + size * (-0.7 * s + 0.6 * c))
        if mode.thrusting(body):
            tail = (x - 1.3 * size * c, y - 1.3 * size * s)
            pygame.draw.polygon(self.surface, (255, 140, 40), [left, tail, right])
        pygame.draw.polygon(self.surface, mode.colour(body), [nose, left, right])

    def _overlay(self, overlay, project):
        for path, colour in overlay.get("paths", []):
            path = np.asarray(path)
            path = path[np.isfinite(path).all(axis=1)]
            if len(path) > 1:
                pygame.draw.lines(self.surface, colour, False, project(path).tolist(), 1)
        for pos, colour, label in overlay.get("markers", []):
            x, y = project(pos)
            pygame.draw.circle(self.surface, colour, (x, y), 4, 1)
            if label:
                self.surface.blit(self.font.render(label, True, colour), (x + 6, y - 6))

    def _text(self, lines, x, y):
        for line in lines:
            if line:
                self.surface.blit(self.font.render(line, True, TEXT), (x, y))
            y += 18
