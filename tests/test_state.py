"""Body storage under random adds and removes, against a plain dict model (hypothesis)."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import spacephys as sp

ops = st.lists(st.one_of(
    st.tuples(st.just("add"), st.integers(1, 40)),
    st.tuples(st.just("remove"), st.lists(st.integers(0, 10_000), min_size=1, max_size=8)),
    st.tuples(st.just("remove_stale"), st.integers(0, 10_000)),
), max_size=40)


@settings(deadline=None, max_examples=150)
@given(ops)
def test_random_adds_and_removes_match_a_dict(sequence):
    w = sp.World(dim=3, capacity=2)
    model = {}            # id -> mass, in insertion order (dicts keep it)
    dead = []
    counter = 0.0
    for op, arg in sequence:
        if op == "add":
            masses = counter + np.arange(arg, dtype=float)
            counter += arg
            ids = w.add_bodies(masses, np.zeros((arg, 3)) + masses[:, None])
            assert len(set(ids.tolist()) & (set(model) | set(dead))) == 0   # never reused
            model.update(zip(ids.tolist(), masses))
        elif op == "remove" and model:
            live = list(model)
            chosen = sorted({live[k % len(live)] for k in arg})
            w.remove(chosen)
            for i in chosen:
                del model[i]
                dead.append(i)
        elif op == "remove_stale" and dead:
            stale = dead[arg % len(dead)]
            with pytest.raises(ValueError, match=f"id = {stale} names no live body"):
                w.remove(stale)
        # the views are the model; rows move on removal, the serials keep the order of
        # addition
        assert dict(zip(w.ids.tolist(), w.mass.tolist())) == model
        serial = w.state()["bodies"]["columns"]["serial"]
        assert w.ids[np.argsort(serial)].tolist() == list(model)
        assert np.array_equal(w.pos[:, 0], w.mass)        # rows moved together
        for i in model:
            assert w.ids[w.index_of(i)] == i
        for i in dead:
            assert i not in w
