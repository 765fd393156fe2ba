"""Fixed-step integrators driven by coefficient tables; the loop over steps runs inside numba.

Two families serve every fixed-step method of the registry (spacephys.integrators):
  splitting_steps  drift/kick compositions (symplectic Euler, leapfrog, Yoshida 4/6/8);
  rk_steps         explicit Runge-Kutta tableaux (explicit Euler, classical RK4).
Positions and velocities are updated in place; gravity comes from gravity.accelerations,
thrust from kernels/control.py (exact within each drift of a splitting, sampled at the stages
and integrated exactly into the velocity of a Runge-Kutta step).
"""
import math

import numpy as np

from .._jit import kernel
from .arrays import capture, copy_into
from .control import add_thrust, begin_step, drift_thrust, finish_step, rk_thrust_fix
from .gravity import DIRECT, accelerations


@kernel
def _scratch(model, src):
    # exactly as wide as the source list so gravity's inner loop is unit-stride
    return np.empty((4, src.size if model == DIRECT else 1))


@kernel(inline=True)
def _step_start(pos, vel, mass, setup, ctrl, work, t0, dt, burn):
    """Keep the state at the step's start (for the collision pass) and set the actors'
    turns and burns over the step."""
    if setup.enabled or ctrl.enabled:
        copy_into(work.pos0, pos)
        copy_into(work.vel0, vel)
    if ctrl.enabled:
        begin_step(ctrl, setup, pos, vel, mass, t0, dt, burn)


@kernel(inline=True)
def _step_end(pos, vel, mass, setup, ctrl, work, burn, t0, dt, done, frame_at, frame, fpos,
              fvel, fmass):
    """Collisions, fuel, fuses and lifetimes after a step, then the recording's frame if one
    falls due: (whether bodies were removed, so the call must stop; the next frame)."""
    # (a call passing the Setup and Control tuples costs a reference count per array:
    # made only when there is something to do)
    stop = (setup.enabled or ctrl.enabled) and \
        finish_step(work.pos0, work.vel0, pos, vel, mass, setup, ctrl, burn, dt, t0, work)
    return stop, capture(frame_at, frame, done, fpos, fvel, fmass, pos, vel, mass)


@kernel(inline=True)
def _drag_kick(vel, acc, h, drag, still):
    """The kick with linear drag toward the wind, dv/dt = a - k (v - w) with a held: exact,
    v <- v_t + (v - v_t) exp(-k h), v_t = w + a / k the terminal velocity. drag : (4,)
    [k [1/time], w (3,) [length/time]]. Immovable bodies stay at rest."""
    k = drag[0]
    E = math.exp(-k * h)
    for i in range(vel.shape[0]):
        for c in range(3):
            vt = drag[1 + c] + acc[i, c] / k
            vel[i, c] = vt + (vel[i, c] - vt) * E
    for j in range(still.size):
        for c in range(3):
            vel[still[j], c] = 0.0


@kernel(parallel=True)
def splitting_steps(pos, vel, model, mass, src, passive, G, eps2, field, field_mass, still,
                    drift, kick, drag, dt, nsteps, setup, ctrl, work, frame_at, fpos, fvel,
                    fmass):
    """Advance nsteps steps of dt with the drift/kick sequence (drift[s], kick[s]).

    Stage s: pos += drift[s] dt vel, then vel += kick[s] dt a(pos) (skipped where kick[s] == 0).
    pos, vel : (n, 3) float64, updated in place; mass : (n,) float64; drift, kick : (S,) float64.
    drag : (4,) float64, [k, wind (3,)]: with k > 0 each kick also relaxes the velocities
    toward the wind at rate k, exactly (see _drag_kick), so the splitting keeps its order.
    model ... still : the gravity arguments of gravity.accelerations; setup : collide.Setup;
    ctrl : control.Control (ships, missiles, lifetimes); work : arrays.Work, n rows of
    scratch; frame_at : (F,) int64, the step counts after which a recording takes a frame,
    into fpos, fvel (F, n, 3) and fmass (F, n) (see arrays.capture; F = 0: none).
    Returns the steps taken: fewer than nsteps when a collision, a detonation or an expiry
    removed or merged bodies.
    """
    n = pos.shape[0]
    acc = work.acc
    burn = np.zeros((ctrl.actors.size, 8))
    scratch = _scratch(model, src)
    frame = 0
    for step in range(nsteps):
        t0 = setup.t0 + step * dt
        _step_start(pos, vel, mass, setup, ctrl, work, t0, dt, burn)
        tau = 0.0                                      # time into the step the drifts reached
        for s in range(drift.size):
            h = drift[s] * dt
            if h != 0.0:
                for i in range(n):
                    pos[i, 0] += h * vel[i, 0]
                    pos[i, 1] += h * vel[i, 1]
                    pos[i, 2] += h * vel[i, 2]
                if burn.shape[0]:
                    drift_thrust(ctrl.actors, burn, pos, vel, tau, tau + h)
                tau += h
            h = kick[s] * dt
            if h != 0.0:
                accelerations(pos, model, mass, src, passive, G, eps2, field, field_mass,
                              still, scratch, acc)
                if drag[0] > 0.0:
                    _drag_kick(vel, acc, h, drag, still)
                else:
                    for i in range(n):
                        vel[i, 0] += h * acc[i, 0]
                        vel[i, 1] += h * acc[i, 1]
                        vel[i, 2] += h * acc[i, 2]
        stop, frame = _step_end(pos, vel, mass, setup, ctrl, work, burn, t0, dt, step + 1,
                                frame_at, frame, fpos, fvel, fmass)
        if stop:
            return step + 1
    return nsteps


@kernel(parallel=True)
def rk_steps(pos, vel, model, mass, src, passive, G, eps2, field, field_mass, still,
             a, b, drag, dt, nsteps, setup, ctrl, work, frame_at, fpos, fvel, fmass):
    """Advance nsteps steps of dt with the explicit Runge-Kutta tableau (a, b).

    a : (S, S) float64, strictly lower triangular; b : (S,) float64 weights.
    Stage s evaluates x_s = x + dt sum_j a[s, j] v_j, v_s = v + dt sum_j a[s, j] a_j, a_s = a(x_s).
    drag : (4,) [k, wind (3,)]: the stages' accelerations include -k (v_s - wind).
    Collisions, actors, frames and the return value as in splitting_steps.
    """
    n = pos.shape[0]
    S = b.size
    kx = np.empty((S, n, 3))     # stage velocities (the derivative of position)
    kv = np.empty((S, n, 3))     # stage accelerations (the derivative of velocity)
    x = work.acc
    burn = np.zeros((ctrl.actors.size, 8))
    no_mask = np.zeros(0, np.bool_)
    scratch = _scratch(model, src)
    frame = 0
    for step in range(nsteps):
        t0 = setup.t0 + step * dt
        _step_start(pos, vel, mass, setup, ctrl, work, t0, dt, burn)
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
            accelerations(x, model, mass, src, passive, G, eps2, field, field_mass,
                          still, scratch, kv[s])
            if drag[0] > 0.0:
                for i in range(n):
                    for c in range(3):
                        kv[s, i, c] -= drag[0] * (kx[s, i, c] - drag[1 + c])
                for j in range(still.size):
                    for c in range(3):
                        kv[s, still[j], c] = 0.0
            c_s = 0.0
            for j in range(s):
                c_s += a[s, j]
            if burn.shape[0]:
                add_thrust(ctrl.actors, burn, kv[s], c_s * dt, no_mask, -1)
        for i in range(n):
            for c in range(3):
                dx = 0.0
                dv = 0.0
                for s in range(S):
                    dx += b[s] * kx[s, i, c]
                    dv += b[s] * kv[s, i, c]
                pos[i, c] += dt * dx
                vel[i, c] += dt * dv
        if burn.shape[0]:
            rk_thrust_fix(ctrl.actors, burn, vel, a, b, dt)
        stop, frame = _step_end(pos, vel, mass, setup, ctrl, work, burn, t0, dt, step + 1,
                                frame_at, frame, fpos, fvel, fmass)
        if stop:
            return step + 1
    return nsteps
