"""Drawing a World with pygame-ce in a few lines, as pymunk.pygame_util does for pymunk: the
bodies where w.interpolate(alpha) puts them, coloured by kind, ships and missiles along their
headings, spinning bodies with a mark, compound bodies (sp.Circles) circle by circle, fading
debris, trails, walls, tethers, predicted paths and labels, through a Camera that can follow a
body, zoom and look across a wrapping box's seams.

    import pygame, spacephys as sp
    screen = pygame.display.set_mode((960, 720))
    painter = sp.draw.Painter(screen, trails=60)
    camera = sp.draw.Camera(follow=ship, half=300)
    ...
    alpha = w.advance(frame_time)
    painter.draw(w, alpha, camera, path=prediction, labels={ship: "you"})
    painter.text(["score 3"])
    pygame.display.flip()

2D Worlds are drawn as they are; 3D Worlds from above (x right, y up). Needs pygame-ce (the
`game` extra)."""
import math
from collections import deque

import numpy as np

from .extras import require

BACKGROUND = (0, 0, 10)
KIND_COLOURS = {"star": (255, 220, 110), "planet": (70, 120, 220), "moon": (170, 170, 170),
                "station": (150, 255, 150), "asteroid": (150, 130, 110),
                "ship": (90, 200, 255), "missile": (240, 240, 200),
                "debris": (255, 170, 80), "body": (200, 200, 200)}
TEXT = (220, 220, 220)
FLAME = (255, 140, 40)
WALL = (120, 120, 140)
PATH = (80, 140, 255)
TETHER = (200, 200, 120)


def _pygame():
    require("spacephys.draw", "pygame")
    import pygame
    if not pygame.font.get_init():
        pygame.font.init()
    return pygame


def drawn_positions(world, alpha):
    """(n, 2) where to draw each body: between its last two states (w.interpolate), except a
    body that crossed a wrapping box's seam in the last step (drawn where it is now: the
    interpolation would sweep it across the whole box)."""
    drawn = world.interpolate(alpha)[:, :2]
    mode, lo, hi, _ = world.boundary
    if mode == "periodic" and world.n:
        now = world.pos[:, :2]
        jumped = np.abs(drawn - now) > (hi - lo)[:2] / 4
        drawn = np.where(jumped, now, drawn)
    return drawn


def framing(world, drawn, centre=(0.0, 0.0)):
    """(centre (2,), half height) of a view holding a World: a wrapping World's whole box,
    else every body but debris about `centre`, with a fifth to spare. drawn (n, 2)."""
    mode, lo, hi, _ = world.boundary
    if mode == "periodic":
        return (lo + hi)[:2] / 2, float(hi[1] - lo[1]) / 2
    heavy = drawn[world.kind != world.kind_code("debris")] \
        if "debris" in world.kinds and world.n else drawn
    reach = float(np.abs(heavy - centre).max()) if heavy.size else 1.0
    return np.asarray(centre, float), 1.2 * max(reach, 1e-9)


class Camera:
    """What the view shows: `centre` (2,) [length] at the middle of the surface, `half`
    [length] from the middle to the top edge, divided by `zoom`. follow : a body id to keep
    in the middle (its drawn position; the camera stays where it was once the body is
    gone). half None: framed on the first draw to hold every body but debris (and the whole
    box of a wrapping World). In a wrapping World every body is drawn at its image nearest
    the centre, so a camera following a ship sees across the seams."""

    def __init__(self, centre=(0.0, 0.0), half=None, follow=None, zoom=1.0):
        self.centre = np.array(centre, float).reshape(2)
        self.half = None if half is None else float(half)
        self.follow = follow
        self.zoom = float(zoom)
        if not (self.zoom > 0.0 and math.isfinite(self.zoom)):
            raise ValueError(f"zoom = {zoom!r}: must be a positive number")
        if self.half is not None and not (self.half > 0.0 and math.isfinite(self.half)):
            raise ValueError(f"half = {half!r}: must be a positive length")
        self.size = (1, 1)
        self.scale = 1.0
        self.period = None

    def aim(self, world, drawn, size):
        """Set the centre (following), the scale and the wrap for this frame: drawn (n, 2)
        positions, size (w, h) of the surface in pixels."""
        mode, lo, hi, _ = world.boundary
        self.period = (hi - lo)[:2] if mode == "periodic" else None
        if self.half is None:
            self.centre, self.half = framing(world, drawn, self.centre)
        if self.follow is not None and self.follow in world:
            self.centre = drawn[world.index_of(self.follow)].copy()
        self.size = size
        self.scale = size[1] / (2.0 * self.half / self.zoom)

    def nearest(self, pos):
        """Positions (..., 2) moved to their image nearest the centre (a wrapping World)."""
        pos = np.asarray(pos, float)[..., :2]
        if self.period is None:
            return pos
        return self.centre + (pos - self.centre + self.period / 2) % self.period - \
            self.period / 2

    def __call__(self, pos, wrap=True):
        """World positions (..., 2 or 3) to pixels (..., 2): y up in the world, down on
        screen; each at its image nearest the centre (wrap False: where it is)."""
        pos = self.nearest(pos) if wrap else np.asarray(pos, float)[..., :2]
        x = self.size[0] / 2 + (pos[..., 0] - self.centre[0]) * self.scale
        y = self.size[1] / 2 - (pos[..., 1] - self.centre[1]) * self.scale
        return np.stack([x, y], axis=-1)

    def to_world(self, pixel):
        """A pixel (x, y) back to world (2,) (a mouse click)."""
        x, y = pixel
        return self.centre + np.array([x - self.size[0] / 2, self.size[1] / 2 - y]) / self.scale


class Painter:
    """Draws Worlds onto a pygame Surface. colours : {kind name: (r, g, b)} over
    KIND_COLOURS; trails : how many past positions each body's trail keeps (0: none;
    debris never have one); stars : background stars (the same sky every run)."""

    def __init__(self, surface, colours=None, trails=0, stars=200, font_size=20):
        pygame = _pygame()
        self.surface = surface
        self.colours = {**KIND_COLOURS, **(colours or {})}
        self.trails = int(trails)
        self._trail = {}                         # id -> deque of world (2,) positions
        self._last_t = None
        self.font = pygame.font.Font(None, font_size)
        size = surface.get_size()
        self.sky = np.random.default_rng(7).integers(0, size, (stars, 2))

    def colour(self, world, kind):
        return self.colours.get(world.kinds[kind], self.colours["body"])

    def draw(self, world, alpha=1.0, camera=None, *, path=None, labels=None, colours=None,
             flames=(), background=BACKGROUND):
        """Draw one frame of `world` at `alpha` (World.advance's) through `camera` (default:
        a Camera framed on the bodies, kept from frame to frame). path : a Prediction, a
        (P, dim) array of positions, or a list of (positions, colour); labels : {id: text};
        colours : {id: (r, g, b)} for single bodies (a team's ships); flames : ids of ships
        whose engine is lit. Returns the camera."""
        pygame = _pygame()
        surf = self.surface
        camera = camera if camera is not None else self.__dict__.setdefault("camera", Camera())
        drawn = drawn_positions(world, alpha)
        camera.aim(world, drawn, surf.get_size())
        if background is not None:
            surf.fill(background)
            if len(self.sky):
                pixels = pygame.surfarray.pixels3d(surf)
                pixels[self.sky[:, 0], self.sky[:, 1]] = (70, 70, 90)
                del pixels                                  # (unlocks the surface)
        self._walls(world, camera)
        px = camera(drawn)
        self._tethers(world, px)
        names = np.array(world.kinds)[world.kind] if world.n else np.zeros(0, str)
        debris = names == "debris"
        self._remember(world, drawn, debris)
        self._trails(world, camera)
        if debris.any():                                    # thousands: points, no calls
            self._points(px[debris], world.intensity[debris], self.colours["debris"])
        self._paths(path, camera)
        ids, radius = world.ids, world.radius
        headings = world.headings if world.dim == 2 else self._flat(world.headings)
        colours = colours or {}
        flames = set(flames)
        compound = self._compound(world, camera.scale)
        for r in np.flatnonzero(~debris):
            name, body = names[r], int(ids[r])
            x, y = float(px[r, 0]), float(px[r, 1])
            colour = colours.get(body) or self.colour(world, world.kind[r])
            size = radius[r] * camera.scale
            h = headings[r]
            if r in compound and size >= 4.0:            # circle by circle (big enough)
                if name == "ship" and body in flames and not np.isnan(h):
                    self._flame(x, y, size, h)
                for (dx, dy), rc in zip(*compound[r]):
                    pygame.draw.circle(surf, colour, (x + dx, y + dy), max(1.0, rc))
            elif name == "ship" and not np.isnan(h):
                self._ship(x, y, max(10.0, size), h, colour, body in flames)
            elif name == "missile" and not np.isnan(h):
                c, s = math.cos(h), -math.sin(h)
                pygame.draw.line(surf, colour, (x - 3 * c, y - 3 * s), (x + 3 * c, y + 3 * s), 2)
            elif name == "station":
                s = max(4.0, size)
                pygame.draw.rect(surf, colour, (x - s, y - s, 2 * s, 2 * s), 1)
            else:
                pygame.draw.circle(surf, colour, (x, y), max(2.0, size))
                if not np.isnan(h) and size >= 4.0:          # a spinning body: its x axis
                    end = (x + size * math.cos(h), y - size * math.sin(h))
                    pygame.draw.line(surf, background or (0, 0, 0), (x, y), end, 1)
        for body, label in (labels or {}).items():
            if body in world:
                x, y = px[world.index_of(body)]
                self._label(label, x + 8, y - 8, TEXT)
        return camera

    def text(self, lines, x=6, y=6, colour=TEXT, panel=True):
        """Lines of text from (x, y) down, on a dark translucent panel (so that what moves
        under a HUD does not hide it)."""
        pygame = _pygame()
        lines = [line for line in lines if line is not None]
        rendered = [self.font.render(line, True, colour) if line else None for line in lines]
        step = self.font.get_linesize()
        if panel and any(rendered):
            width = max(r.get_width() for r in rendered if r) + 8
            back = pygame.Surface((width, step * len(rendered) + 4), pygame.SRCALPHA)
            back.fill((0, 0, 0, 170))
            self.surface.blit(back, (x - 4, y - 2))
        for r in rendered:
            if r is not None:
                self.surface.blit(r, (x, y))
            y += step

    # ------------------------------------------------------------------ pieces
    @staticmethod
    def _flat(h3):
        """3D heading vectors seen from above: their angle in the x-y plane."""
        return np.arctan2(h3[:, 1], h3[:, 0]) if len(h3) else np.zeros(0)

    def _ship(self, x, y, size, h, colour, flame):
        pygame = _pygame()
        c, s = math.cos(h), -math.sin(h)                     # screen y points down
        nose = (x + size * c, y + size * s)
        left = (x + size * (-0.7 * c + 0.6 * s), y + size * (-0.7 * s - 0.6 * c))
        right = (x + size * (-0.7 * c - 0.6 * s), y + size * (-0.7 * s + 0.6 * c))
        if flame:
            self._flame(x, y, size, h)
        pygame.draw.polygon(self.surface, colour, [nose, left, right])

    def _flame(self, x, y, size, h):
        """A lit engine's flame behind (x, y) [pixels], against heading h, for a ship of size
        [pixels]."""
        pygame = _pygame()
        c, s = math.cos(h), -math.sin(h)
        left = (x + size * (-0.7 * c + 0.6 * s), y + size * (-0.7 * s - 0.6 * c))
        right = (x + size * (-0.7 * c - 0.6 * s), y + size * (-0.7 * s + 0.6 * c))
        tail = (x - 1.3 * size * c, y - 1.3 * size * s)
        pygame.draw.polygon(self.surface, FLAME, [left, tail, right])

    @staticmethod
    def _compound(world, scale):
        """{row: (offsets (k, 2), radii (k,)) in pixels} of the compound bodies' circles:
        each circle's offset from its body's centre turned by the body's orientation now (the
        headings drawn are now's too; 3D: seen from above), added to where the body is drawn,
        so the circles move with its interpolated position (and its nearest image)."""
        ids, _, centres, radii = world.circles()
        if not len(ids):
            return {}
        rows = world.index_of(ids)
        off = (centres[:, :2] - world.pos[rows, :2]) * scale
        off[:, 1] *= -1.0                                  # screen y points down
        out = {}
        for r in np.unique(rows):
            mine = rows == r
            out[int(r)] = (off[mine], radii[mine] * scale)
        return out

    def _tethers(self, world, px):
        """Each tether as a line between its ends (where the camera puts each end)."""
        pygame = _pygame()
        tethers = world.tethers
        if not len(tethers):
            return
        rows = world.index_of(np.concatenate([tethers["a"], tethers["b"]])).reshape(2, -1)
        for i, j in rows.T:
            pygame.draw.line(self.surface, TETHER, px[i].tolist(), px[j].tolist(), 1)

    def _points(self, px, intensity, colour):
        pygame = _pygame()
        w, h = self.surface.get_size()
        xy = px.astype(np.int64)
        inside = (xy[:, 0] >= 0) & (xy[:, 0] < w) & (xy[:, 1] >= 0) & (xy[:, 1] < h)
        fade = intensity[inside, None]
        pixels = pygame.surfarray.pixels3d(self.surface)
        pixels[xy[inside, 0], xy[inside, 1]] = (np.asarray(colour, float) * fade).astype(np.uint8)
        del pixels

    def _remember(self, world, drawn, debris):
        """Add this frame's positions to the trails (once per World time)."""
        if not self.trails or world.t == self._last_t:
            return
        self._last_t = world.t
        keep = {}
        for r in np.flatnonzero(~debris):
            body = int(world.ids[r])
            trail = self._trail.get(body) or deque(maxlen=self.trails)
            trail.append(drawn[r].copy())
            keep[body] = trail
        self._trail = keep                               # the gone bodies' trails go too

    def _trails(self, world, camera):
        pygame = _pygame()
        for body, trail in self._trail.items():
            if len(trail) < 2 or body not in world:
                continue
            pts = np.array(trail)
            colour = self.colour(world, world.kind[world.index_of(body)])
            dim = tuple(int(0.5 * c) for c in colour)
            # a wrapping World: break the line where it jumps across a seam
            jumps = np.zeros(len(pts) - 1, bool) if camera.period is None else \
                (np.abs(np.diff(pts, axis=0)) > camera.period / 2).any(axis=1)
            pix = camera(pts)
            for piece in np.split(np.arange(len(pts)), np.flatnonzero(jumps) + 1):
                if piece.size > 1:
                    pygame.draw.lines(self.surface, dim, False, pix[piece].tolist(), 1)

    def _paths(self, path, camera):
        pygame = _pygame()
        if path is None:
            return
        if hasattr(path, "pos"):                         # a Prediction: every body's path
            path = [(p, PATH) for p in path.pos]
        elif isinstance(path, np.ndarray):
            path = [(path, PATH)]
        for positions, colour in path:
            positions = np.asarray(positions, float)
            positions = positions[np.isfinite(positions).all(axis=1)]
            if len(positions) > 1:
                pygame.draw.lines(self.surface, colour, False,
                                  camera(positions).tolist(), 1)

    def _walls(self, world, camera):
        """Segments as they are; planes (lines in 2D) as their line across the whole view.
        Walls are drawn where they are, not at nearest images."""
        pygame = _pygame()
        reach = max(camera.size) / camera.scale              # past every edge of the view
        for row in world.walls:
            a = row[1:3]
            if row[0] == 0:
                along = np.array([-row[5], row[4]])          # the unit normal turned a quarter
                foot = a + np.dot(camera.centre - a, along) * along
                ends = foot + np.outer([-reach, reach], along)
            else:
                ends = np.array([a, row[4:6]])
            pix = camera(ends, wrap=False)
            pygame.draw.line(self.surface, WALL, pix[0].tolist(), pix[1].tolist(), 2)

    def _label(self, text, x, y, colour):
        self.surface.blit(self.font.render(text, True, colour), (x, y))
