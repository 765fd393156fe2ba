"""spacephys.draw (issue 43, item 8): a World drawn with pygame-ce off screen (SDL's dummy
video driver), each element found at the pixel the camera puts it."""
import math
import os

import numpy as np
import pytest

os.environ["SDL_VIDEODRIVER"] = "dummy"
os.environ["PYGAME_HIDE_SUPPORT_PROMPT"] = "1"
import pygame                                                             # noqa: E402

import spacephys as sp                                                    # noqa: E402
from spacephys.draw import KIND_COLOURS, PATH, TETHER, WALL, Camera, Painter  # noqa: E402

SIZE = (400, 300)


@pytest.fixture
def surface():
    pygame.display.init()
    yield pygame.Surface(SIZE)
    pygame.display.quit()


def _pixel(surface, camera, pos):
    x, y = camera(np.asarray(pos, float)).astype(int)
    return tuple(surface.get_at((int(x), int(y))))[:3]


def test_bodies_walls_and_paths_are_drawn_where_the_camera_puts_them(surface):
    w = sp.World(2, gravity="none", dt=0.1)
    planet = w.add_body(1.0, (0.0, 0.0), radius=20.0, kind="planet")
    rock = w.add_body(1.0, (60.0, 30.0), radius=6.0, kind="asteroid")
    w.add_segment((-80.0, -60.0), (80.0, -60.0))
    path = np.stack([np.linspace(-90, 90, 50), np.full(50, 50.0)], axis=1)
    painter = Painter(surface, stars=0)
    camera = painter.draw(w, 1.0, Camera(half=100.0), path=path)
    assert camera.scale == SIZE[1] / 200.0
    assert _pixel(surface, camera, (0.0, 0.0)) == KIND_COLOURS["planet"]
    assert _pixel(surface, camera, (62.0, 30.0)) == KIND_COLOURS["asteroid"]
    assert _pixel(surface, camera, (0.0, -60.0)) == WALL
    assert _pixel(surface, camera, (10.0, 50.0)) == PATH
    assert _pixel(surface, camera, (-50.0, 20.0)) == (0, 0, 10)          # empty space
    # a spinning body shows its x axis: a dark line from its centre along the heading
    w.set_heading(rock, math.pi / 2)
    painter.draw(w, 1.0, camera)
    assert _pixel(surface, camera, (60.0, 34.0)) != KIND_COLOURS["asteroid"]
    assert _pixel(surface, camera, (64.0, 30.0)) == KIND_COLOURS["asteroid"]
    assert planet in w


def test_a_ship_points_along_its_heading_and_its_team_colour_and_flame_show(surface):
    w = sp.World(2, gravity="none", dt=0.1)
    ship = w.add_ship(sp.ShipSpec(dry_mass=1, fuel_mass=1, max_thrust=1, exhaust_speed=10,
                                  turn_rate=1, radius=5.0), (0.0, 0.0), heading=math.pi / 2)
    painter = Painter(surface, stars=0)
    camera = painter.draw(w, 1.0, Camera(half=20.0), colours={ship: (1, 2, 250)},
                          flames=[ship])
    assert _pixel(surface, camera, (0.0, 4.0)) == (1, 2, 250)           # the nose, up
    assert _pixel(surface, camera, (4.0, 0.0)) == (0, 0, 10)            # not to the right
    assert _pixel(surface, camera, (0.0, -5.5)) == (255, 140, 40)       # the flame, behind


def test_the_camera_follows_a_body_and_sees_across_a_wrapping_seam(surface):
    w = sp.World(2, gravity="none", dt=0.1)
    w.set_boundary("periodic", lo=(-100.0, -100.0), hi=(100.0, 100.0))
    chased = w.add_body(1.0, (95.0, 0.0), (60.0, 0.0), radius=2.0, kind="planet")
    across = w.add_body(1.0, (-97.0, 0.0), radius=2.0, kind="moon")   # 8 to its right
    camera = Camera(half=20.0, follow=chased)
    painter = Painter(surface, stars=0)
    painter.draw(w, 1.0, camera)
    np.testing.assert_array_equal(camera.centre, [95.0, 0.0])
    assert _pixel(surface, camera, (103.0, 0.0)) == KIND_COLOURS["moon"]  # its near image
    x, _ = camera(np.array([-97.0, 0.0]))
    assert SIZE[0] / 2 < x < SIZE[0]
    w.step(1)                                              # the chased body crosses the seam
    painter.draw(w, 0.5, camera)
    assert camera.centre[0] == w.pos[0, 0] < -98.0         # drawn where it is, not mid-box
    assert across in w


def test_trails_keep_the_last_positions_and_zoom_scales(surface):
    w = sp.World(2, gravity="none", dt=1.0)
    body = w.add_body(1.0, (-50.0, 0.0), (10.0, 0.0), radius=1.0, kind="planet")
    painter = Painter(surface, trails=4, stars=0)
    camera = Camera(half=100.0, zoom=2.0)
    for _ in range(6):
        painter.draw(w, 1.0, camera)
        w.step(1)
    painter.draw(w, 1.0, camera)
    assert camera.scale == 2.0 * SIZE[1] / 200.0
    dim = tuple(int(0.5 * c) for c in KIND_COLOURS["planet"])
    assert _pixel(surface, camera, (5.0, 0.0)) == dim                  # within the last 4
    assert _pixel(surface, camera, (-25.0, 0.0)) == (0, 0, 10)         # older: forgotten
    assert body in w


def test_a_tether_is_a_line_between_its_ends(surface):
    w = sp.World(2, gravity="none", dt=0.1)
    a = w.add_body(1.0, (-50.0, 0.0), radius=2.0, kind="planet")
    b = w.add_body(1.0, (50.0, 0.0), radius=2.0, kind="planet")
    painter = Painter(surface, stars=0)
    camera = painter.draw(w, 1.0, Camera(half=100.0))
    assert _pixel(surface, camera, (0.0, 0.0)) == (0, 0, 10)
    w.tether(a, b, rigid=True)
    painter.draw(w, 1.0, camera)
    assert _pixel(surface, camera, (0.0, 0.0)) == TETHER
    assert _pixel(surface, camera, (20.0, 0.0)) == TETHER


def test_hud_text_sits_on_a_panel(surface):
    painter = Painter(surface, stars=0)
    surface.fill((200, 200, 200))
    painter.text(["score 3"], 10, 10)
    assert surface.get_at((8, 9))[0] < 100                 # darkened behind the text
    assert surface.get_at((300, 200))[0] == 200


@pytest.mark.parametrize("kwargs, message", [({"zoom": 0.0}, "zoom"),
                                             ({"half": -1.0}, "half"),
                                             ({"zoom": float("nan")}, "zoom")])
def test_bad_cameras_are_named(kwargs, message):
    with pytest.raises(ValueError, match=message):
        Camera(**kwargs)


def test_the_guides_example_runs_as_written(tmp_path):
    """docs/guide/drawing.md's code block, in a process of its own, off screen."""
    import pathlib
    import subprocess
    import sys
    text = (pathlib.Path(__file__).parents[1] / "docs/guide/drawing.md").read_text()
    code = text.split("```python\n")[1].split("```")[0]
    code += "pygame.image.save(screen, 'shot.png')\nprint(round(w.t, 6))\n"
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600,
                          env={**os.environ, "SDL_VIDEODRIVER": "dummy"})
    assert done.returncode == 0, done.stderr
    assert float(done.stdout.split()[-1]) == pytest.approx(4.0)
    pygame.display.init()
    shot = pygame.surfarray.array3d(pygame.image.load(str(tmp_path / "shot.png")))
    pygame.display.quit()
    assert (shot == PATH).all(axis=2).sum() > 50                   # the predicted path
    assert (shot == KIND_COLOURS["planet"]).all(axis=2).sum() > 100


def test_a_compound_body_is_drawn_circle_by_circle_turning_with_its_heading(surface):
    w = sp.World(2, gravity="none", dt=1.0)
    bell = w.add_body(1.0, (0.0, 0.0), shape=sp.Circles([[3.0, 0.0], [-3.0, 0.0]], [1.0, 1.0]),
                      kind="asteroid")
    rock = KIND_COLOURS["asteroid"]
    painter = Painter(surface, stars=0)
    camera = painter.draw(w, 1.0, Camera(half=10.0))
    assert _pixel(surface, camera, (3.0, 0.0)) == rock
    assert _pixel(surface, camera, (-3.0, 0.0)) == rock
    assert _pixel(surface, camera, (0.0, 0.0)) == (0, 0, 10)           # the gap between
    assert _pixel(surface, camera, (0.0, 3.0)) == (0, 0, 10)
    w.set_heading(bell, math.pi / 2)                                     # turned a quarter
    painter.draw(w, 1.0, camera)
    assert _pixel(surface, camera, (0.0, 3.0)) == rock
    assert _pixel(surface, camera, (0.0, -3.0)) == rock
    assert _pixel(surface, camera, (3.0, 0.0)) == (0, 0, 10)
    assert _pixel(surface, camera, (-3.0, 0.0)) == (0, 0, 10)
    # between two steps: the circles go with the body's interpolated position
    w.set_body(bell, vel=(4.0, 0.0))
    w.step(1)
    painter.draw(w, 0.5, camera)
    assert _pixel(surface, camera, (2.0, 3.0)) == rock
    assert _pixel(surface, camera, (2.0, -3.0)) == rock
    assert _pixel(surface, camera, (4.0, 3.0)) == (0, 0, 10)           # not where it is now


def test_a_compound_ship_shows_its_circles_and_its_flame(surface):
    hull = sp.Circles([[2.0, 0.0], [0.0, 0.0], [-2.0, 0.0]], [1.0, 1.0, 1.0])
    w = sp.World(2, gravity="none", dt=0.1)
    ship = w.add_ship(sp.ShipSpec(dry_mass=1, fuel_mass=1, max_thrust=1, exhaust_speed=10,
                                  turn_rate=1, shape=hull), (0.0, 0.0), heading=math.pi / 2)
    painter = Painter(surface, stars=0)
    camera = painter.draw(w, 1.0, Camera(half=10.0), flames=[ship])
    for y in (2.0, 0.0, -2.0):
        assert _pixel(surface, camera, (0.0, y)) == KIND_COLOURS["ship"]
    assert _pixel(surface, camera, (0.9, 2.0)) == KIND_COLOURS["ship"]  # round, not a
    assert _pixel(surface, camera, (-1.5, -2.0)) == (0, 0, 10)          # triangle's corners
    assert _pixel(surface, camera, (2.0, 0.0)) == (0, 0, 10)            # along y, not x
    assert _pixel(surface, camera, (0.0, -3.6)) == (255, 140, 40)       # the flame, behind


def test_a_3d_compound_body_is_seen_from_above(surface):
    w = sp.World(3, gravity="none", dt=0.1)
    bell = w.add_body(1.0, (0.0, 0.0, 0.0), kind="planet",
                      shape=sp.Circles([[3.0, 0.0, 0.0], [-3.0, 0.0, 0.0]], [1.0, 1.0]))
    w.set_heading(bell, (0.0, 1.0, 0.0))
    painter = Painter(surface, stars=0)
    camera = painter.draw(w, 1.0, Camera(half=10.0))
    assert _pixel(surface, camera, (0.0, 3.0)) == KIND_COLOURS["planet"]
    assert _pixel(surface, camera, (0.0, -3.0)) == KIND_COLOURS["planet"]
    assert _pixel(surface, camera, (3.0, 0.0)) == (0, 0, 10)
    assert _pixel(surface, camera, (0.0, 0.0)) == (0, 0, 10)
