"""Fixed-step integrators driven by coefficient tables; the loop over steps runs inside numba.

Two families serve every fixed-step method of the registry (spacephys.integrators):
  splitting_steps  drift/kick compositions (symplectic Euler, leapfrog, Yoshida 4/6/8);
  rk_steps         explicit Runge-Kutta tableaux (explicit Euler, classical RK4).
Both take the same arguments as every step kernel: (state, forces, rules, actors, frames,
method, dt, nsteps, t0), see kernels/step.py; they return (steps taken, status bits).
Forces come from forces.accelerations, thrust from kernels/control.py (exact within each drift
of a splitting, sampled at the stages and integrated exactly into the velocity of a
Runge-Kutta step).
"""
import numpy as np

from .._jit import kernel
from .arrays import zeroed
from .control import add_thrust, drift_thrust, rk_thrust_fix
from . import tape
from .forces import accelerations, hoist, kick
from .step import begin, capture, end, hoist as hoist_step, status


@kernel(parallel=True)
def splitting_steps(state, forces, rules, actors, frames, method, dt, nsteps, t0):
    """Advance nsteps steps of dt with the drift/kick sequence method = (drift, kick), (S,)
    each: stage s drifts pos += drift[s] dt vel, then kicks vel += kick[s] dt a(pos) (skipped
    where kick[s] == 0). With drag each kick also relaxes the velocities toward the wind,
    exactly (forces.kick), so the splitting keeps its order. Returns (steps taken,
    status): fewer than nsteps when a collision, a detonation or an expiry removed or merged
    bodies.
    """
    drift, kicks = method
    pos, vel = state.pos, state.vel
    n = pos.shape[0]
    acc = state.acc
    # the force table read once: a read of an array field, or an array handed to a helper,
    # costs its reference counts on every call
    fx = hoist(forces)
    everyone, passive, src = fx.everyone, fx.passive, fx.src
    frame = 0
    mass = state.mass
    if actors is not None:
        movers, burn = actors.actors, actors.burn
    ht = hoist_step(state, rules, actors)
    # a variable, not the expression in the call: with `rules is not None` written into the
    # tape.collided call, the compiled kernel entered the force loop's parallel region (no
    # work) on every call of a 3-body scene (seen in gdb; tests/test_jit.py guards it)
    collisions = rules is not None
    kicked, was = everyone, False
    for step in range(nsteps):
        t = t0 + step * dt
        begin(state, rules, actors, ht, t, dt, False, step == nsteps - 1)
        played = tape.playing(fx.tape)                 # a prediction's tape (kernels/tape.py)
        if played != was:           # rebound only when it changes: a rebinding costs refcounts
            kicked, was = (passive if played else everyone), played
        tau = 0.0                                      # time into the step the drifts reached
        for s in range(drift.size):
            h = drift[s] * dt
            if h != 0.0:
                if played:          # the pulling rows: the tape puts them where they end
                    for a in range(kicked.size):
                        i = kicked[a]
                        pos[i, 0] += h * vel[i, 0]
                        pos[i, 1] += h * vel[i, 1]
                        pos[i, 2] += h * vel[i, 2]
                else:
                    for i in range(n):
                        pos[i, 0] += h * vel[i, 0]
                        pos[i, 1] += h * vel[i, 1]
                        pos[i, 2] += h * vel[i, 2]
                if actors is not None:
                    drift_thrust(movers, burn, pos, vel, tau, tau + h)
                tau += h
            h = kicks[s] * dt
            if h != 0.0:
                accelerations(fx, t + tau, pos, vel, acc, kicked, False)
                kick(fx.drag, fx.still, vel, acc, h, kicked)
        tape.integrated(fx.tape, src, pos, vel, mass, played)
        stop = end(state, rules, actors, ht, t, dt)
        tape.collided(fx.tape, src, pos, vel, mass, played, collisions)
        frame = capture(frames, frame, step + 1, ht)
        if stop:
            return step + 1, status(state, True)
    return nsteps, status(state, False)


@kernel(parallel=True)
def rk_steps(state, forces, rules, actors, frames, method, dt, nsteps, t0):
    """Advance nsteps steps of dt with the explicit Runge-Kutta tableau method = (a, b):
    a (S, S) strictly lower triangular, b (S,) weights. Stage s evaluates
    x_s = x + dt sum_j a[s, j] v_j, v_s = v + dt sum_j a[s, j] a_j, a_s = a(x_s, v_s), drag
    included. Returns as splitting_steps.
    """
    a, b = method
    pos, vel = state.pos, state.vel
    n = pos.shape[0]
    S = b.size
    kx = np.empty((S, n, 3))     # stage velocities (the derivative of position)
    # stage accelerations (the derivative of velocity); zeros, not empty: a step played from a
    # prediction's tape leaves the pulling rows unset, and they must not carry NaN into pos
    # before the tape restores them
    kv = zeroed(np.empty((S, n, 3)))
    x = state.acc
    mass = state.mass
    fx = hoist(forces)                      # as in splitting_steps
    everyone, passive, src = fx.everyone, fx.passive, fx.src
    no_mask = np.empty(0, np.bool_)
    frame = 0
    ht = hoist_step(state, rules, actors)
    collisions = rules is not None          # a variable: see splitting_steps
    kicked, was = everyone, False
    for step in range(nsteps):
        t = t0 + step * dt
        begin(state, rules, actors, ht, t, dt, False, step == nsteps - 1)
        played = tape.playing(fx.tape)      # a prediction's tape: the pulling rows' stages
        if played != was:                   # go unused, the tape restores them
            kicked, was = (passive if played else everyone), played
        for s in range(S):
            for i in range(n):
                for c in range(3):
                    xs = pos[i, c]
                    vs = vel[i, c]
                    for j in range(s):
                        if a[s, j] != 0.0:
                            xs += dt * a[s, j] * kx[j, i, c]
                            vs += dt * a[s, j] * kv[j, i, c]
                    x[i, c] = xs
                    kx[s, i, c] = vs
            c_s = 0.0
            for j in range(s):
                c_s += a[s, j]
            accelerations(fx, t + c_s * dt, x, kx[s], kv[s], kicked, True)
            if actors is not None:
                add_thrust(actors.actors, actors.burn, kv[s], c_s * dt, no_mask, -1)
        for i in range(n):
            for c in range(3):
                dx = 0.0
                dv = 0.0
                for s in range(S):
                    dx += b[s] * kx[s, i, c]
                    dv += b[s] * kv[s, i, c]
                pos[i, c] += dt * dx
                vel[i, c] += dt * dv
        if actors is not None:
            rk_thrust_fix(actors.actors, actors.burn, vel, a, b, dt)
        tape.integrated(fx.tape, src, pos, vel, mass, played)
        stop = end(state, rules, actors, ht, t, dt)
        tape.collided(fx.tape, src, pos, vel, mass, played, collisions)
        frame = capture(frames, frame, step + 1, ht)
        if stop:
            return step + 1, status(state, True)
    return nsteps, status(state, False)
