"""A recorded match replayed as its mode draws it (issue 43, item 12): the same HUD, team
colours, flames and overlay as the match itself, pixel for pixel; a recording of the arena is
small; --frames stops a replay."""
import os

import numpy as np
import pytest

os.environ["SDL_VIDEODRIVER"] = "dummy"
os.environ["PYGAME_HIDE_SUPPORT_PROMPT"] = "1"
import pygame                                                             # noqa: E402

import spacephys as sp                                                    # noqa: E402
from spacephys.game import make_mode                                      # noqa: E402
from spacephys.game.loop import play, replay                              # noqa: E402


def _pixels(path):
    pygame.display.init()
    try:
        return pygame.surfarray.array3d(pygame.image.load(str(path)))
    finally:
        pygame.display.quit()


@pytest.mark.parametrize("name, players, frames, seed", [("arena", 0, 600, 2),
                                                         ("duel", 1, 240, 2),
                                                         ("duel", 0, 900, 3)])
def test_a_replay_draws_the_last_frame_as_the_match_did(tmp_path, name, players, frames, seed):
    """Arena: ten ships respawning into slots over 10 s (the replay must give each respawned
    ship its side's colour); duel with a player: flames read from the World; duel of the
    computers, seed 3: both ships lost and back by frame 900 (adopted in the replay)."""
    path = tmp_path / "match.h5"
    m = make_mode(name, players=players, seed=seed)
    script = {0: {"w", "a"}, 100: {"w", "space"}, 180: set()}
    done = play(m, frames=frames, headless=True, record=path, script=script,
                screenshot=tmp_path / "played.png")
    result, drawn = replay(path, headless=True, screenshot=tmp_path / "replayed.png")
    assert result.ok, result.message
    assert drawn == done.frames == frames
    played, replayed = _pixels(tmp_path / "played.png"), _pixels(tmp_path / "replayed.png")
    assert len(np.unique(played.reshape(-1, 3), axis=0)) > 10           # not blank
    assert np.array_equal(played, replayed)
    if seed == 3:
        assert sorted(m.score) == [1, 1] and min(m.ships) > 2**32        # both came back
    if name == "arena":
        # frames once a game second (the replay checks them), tables compressed: the 18 MB
        # of a frame of every body every 0.1 s uncompressed is 1.9 MB
        assert os.path.getsize(path) < 3e6
        assert len(sp.open_run(path)) == 11


def test_the_orbit_replay_predicts_the_path_ahead_and_measures_no_warps(tmp_path):
    path = tmp_path / "orbit.h5"
    m = make_mode("orbit", players=1)
    play(m, frames=200, headless=True, record=path, script={0: {"a", "w"}, 100: set()})
    m.close()
    import spacephys.game.loop as loop
    made = []
    real = loop.make_mode
    loop.make_mode = lambda *a, **k: made.append(real(*a, **k)) or made[-1]
    try:
        result, drawn = replay(path, headless=True)
    finally:
        loop.make_mode = real
    assert result.ok and drawn == 200
    watched = made[0]
    watched.finish_prediction()
    assert watched.ship == m.ship and watched._chooser is None
    assert watched.prediction is not None and watched.prediction.ids[0] == m.ship


def test_replay_stops_after_the_frames_asked_for(tmp_path):
    path = tmp_path / "match.h5"
    play(make_mode("duel", players=0), frames=90, headless=True, record=path)
    assert replay(path, headless=True, frames=30) == (None, 30)


def test_a_world_recorded_outside_the_game_is_drawn_as_it_is(tmp_path):
    path = tmp_path / "run.h5"
    w = sp.World(2, dt=0.01)
    w.add_body(1.0, (0.0, 0.0), radius=0.1, kind="star")
    w.add_body(1e-3, (1.0, 0.0), (0.0, 1.0), radius=0.05, kind="planet")
    with w.record(path):
        for _ in range(20):
            w.advance(1 / 60)
    result, drawn = replay(path, headless=True, screenshot=tmp_path / "shot.png")
    assert result.ok and drawn == 20
    assert len(np.unique(_pixels(tmp_path / "shot.png").reshape(-1, 3), axis=0)) > 5
