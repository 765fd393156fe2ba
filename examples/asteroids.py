"""Asteroids in orbit: a ship with a laser and torpedoes among asteroids circling a planet,
an enemy that fires guided missiles at it, asteroids that break into debris, a score counted
from events, and a HUD with the coasting orbit's periapsis — drawn with spacephys.draw.

    python examples/asteroids.py                # W A D thrust and turn, space laser, T torpedo
    python examples/asteroids.py --headless --frames 1200    # the computer flies, no window

Each piece is one call: the laser is a ray cast that leaves the ship out (ignore=); the
player's torpedoes and the enemy's missiles share their launcher's group, so they never hit
it (group=); an asteroid's explosion= breaks it up when anything destroys it; its tag= is
its points, read back from the destroy event that removed it (tag_a); predict(coast=True)
is the path with the engine off."""
import argparse
import dataclasses
import math
import os

import numpy as np

import spacephys as sp

parser = argparse.ArgumentParser()
parser.add_argument("--headless", action="store_true", help="no window; the computer flies")
parser.add_argument("--frames", type=int, default=None, help="stop after this many frames")
args = parser.parse_args()
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
if args.headless:
    os.environ["SDL_VIDEODRIVER"] = "dummy"
import pygame                                                  # noqa: E402 (after the driver)

MU, PLANET_R = 4e5, 40.0                                       # G = 1
w = sp.World(dim=2, dt=1 / 120, seed=1)
planet = w.add_body(MU, (0, 0), radius=PLANET_R, kind="planet", fixed=True)
rng = np.random.default_rng(1)
for _ in range(14):                                            # rocks on circular orbits
    r, a, size = rng.uniform(150, 380), rng.uniform(-math.pi, math.pi), rng.choice([5, 8, 12])
    v = math.sqrt(MU / r)
    w.add_body(1.0, (r * math.cos(a), r * math.sin(a)), (-v * math.sin(a), v * math.cos(a)),
               radius=size, kind="asteroid", tag=60 // size,   # small rocks score most
               explosion=sp.ExplosionSpec(count=12, speed=25, lifetime=2.0))


def orbiting(spec, r, angle):
    """A ship on a circular orbit of radius r, `angle` along it, nose forward."""
    v = math.sqrt(MU / r)
    return w.add_ship(spec, (r * math.cos(angle), r * math.sin(angle)),
                      (-v * math.sin(angle), v * math.cos(angle)), heading=angle + math.pi / 2)


hull = sp.ShipSpec(dry_mass=1, fuel_mass=1, max_thrust=30, exhaust_speed=400, turn_rate=3,
                   radius=5, group=1, explosion=sp.ExplosionSpec(count=30, speed=30, lifetime=2))
player = orbiting(hull, 260.0, 0.0)
enemy = orbiting(dataclasses.replace(hull, group=2), 420.0, math.pi)
PLAYERS = 1                                                    # the tag of the player's shots
torpedo = sp.MissileSpec(mass=0.01, launch_speed=120, lifetime=3.0, radius=2, group=1)
seeker = sp.MissileSpec(mass=0.1, fuel_mass=0.1, thrust=8, exhaust_speed=300, guidance="pn",
                        turn_rate=3, launch_speed=20, lifetime=6, radius=2, group=2)
for a, b in (("missile", "asteroid"), ("missile", "ship"), ("ship", "asteroid")):
    w.set_collision(a, b, "destroy_both")
w.set_collision("*", "planet", "destroy_a")
ROCK = w.kind_code("asteroid")

pygame.display.init()
screen = pygame.display.set_mode((960, 720))
painter = sp.draw.Painter(screen, trails=40)
camera = sp.draw.Camera(half=450)
clock = pygame.time.Clock()
score, frame, path, beam, next_torpedo = 0, 0, None, None, 0.0
fired = lasered = torpedoed = most_debris = 0                  # for the summary at the end
while args.frames is None or frame < args.frames:
    keys = {pygame.key.name(e.key) for e in pygame.event.get() if e.type == pygame.KEYDOWN}
    if pygame.event.peek(pygame.QUIT) or "escape" in keys:
        break
    beam = None
    if player in w:
        here, h = w.pos[w.index_of(player)], w.heading(player)
        if args.headless:                      # the computer: turn to the nearest rock, shoot
            rock, gap = w.nearest(here, kinds=["asteroid"])        # the laser near, else a
            fire = shoot = False                                   # torpedo
            if rock[0, 0] >= 0:
                d = w.pos[w.index_of(int(rock[0, 0]))] - here
                off = math.remainder(math.atan2(d[1], d[0]) - h, 2 * math.pi)
                w.control(player, turn=max(-1.0, min(1.0, 4 * off)), throttle=0.0)
                fire = abs(off) < 0.03 and gap[0, 0] < 100.0
                shoot = abs(off) < 0.03 and w.t >= next_torpedo and not fire
        else:
            held = pygame.key.get_pressed()
            w.control(player, throttle=float(held[pygame.K_w]),
                      turn=float(held[pygame.K_a]) - float(held[pygame.K_d]))
            fire, shoot = "space" in keys, "t" in keys
        if fire:                               # the laser: hitscan, the ship itself left out
            ray = w.raycast(here, (math.cos(h), math.sin(h)), 300.0, ignore=player)
            end = ray.distance[0] if ray.hit[0] else 300.0
            beam = np.array([here, here + end * np.array([math.cos(h), math.sin(h)])])
            if ray.hit[0] and ray.body[0] >= 0 and w.kind[w.index_of(int(ray.body[0]))] == ROCK:
                score += int(w.tags[w.index_of(int(ray.body[0]))])
                w.explode(int(ray.body[0]))    # its own explosion=
                lasered += 1
        if shoot:
            w.set_body(w.launch(player, torpedo), tag=PLAYERS)
            next_torpedo = w.t + 1.0
    if enemy in w and player in w and frame % 240 == 120:
        w.launch(enemy, seeker, target=player, heading=w.heading(enemy) + math.pi / 2)
    w.advance(1 / 60)
    for e in w.events:                   # a rock (a) destroyed by the player's torpedo (b)
        if e["kind"] == sp.events.DESTROY and e["kind_a"] == ROCK and e["tag_b"] == PLAYERS:
            score += int(e["tag_a"])
            torpedoed += 1
        fired += e["kind"] == sp.events.LAUNCH and e["b"] == enemy
    if frame % 15 == 0 and player in w:
        path = w.predict(player, 4.0, points=120, coast=True)
    elements = w.elements(player, about=planet) if player in w else None
    painter.draw(w, 1.0, camera, path=path if player in w else None,
                 colours={player: (90, 200, 255), enemy: (255, 120, 90)},
                 labels={enemy: "enemy"})
    if beam is not None:
        pygame.draw.line(screen, (255, 60, 60), *camera(beam).tolist(), 2)
    rocks = int((w.kind == ROCK).sum())
    most_debris = max(most_debris, int((w.kind == w.kind_code("debris")).sum()))
    painter.text([f"score {score}   rocks {rocks}   t = {w.t:.1f}",
                  f"periapsis altitude {elements.pericentre - PLANET_R:.0f}" if elements
                  else "ship destroyed"])
    pygame.display.flip()
    frame += 1
    if not args.headless:
        clock.tick(60)

fate = {True: "alive", False: "destroyed"}
print(f"frames {frame}  score {score}  rocks left {int((w.kind == ROCK).sum())}  lasered "
      f"{lasered}  torpedoed {torpedoed}  debris at most {most_debris}  player {fate[player in w]}  "
      f"enemy {fate[enemy in w]} after firing {fired} missiles")
