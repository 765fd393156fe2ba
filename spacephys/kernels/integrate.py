"""Fixed-step integrators driven by coefficient tables: the families the step kernel
(kernels/step.run) runs for every fixed-step method of the registry (spacephys.integrators):
  Splitting    drift/kick compositions (symplectic Euler, leapfrog, Yoshida 4/6/8);
  RungeKutta   explicit Runge-Kutta tableaux (explicit Euler, classical RK4).
Forces come from forces.accelerations, thrust from kernels/control.py (exact within each drift
of a splitting, sampled at the stages and integrated exactly into the velocity of a
Runge-Kutta step).
"""
from collections import namedtuple

import numpy as np

from .arrays import zeroed
from .control import add_thrust, drift_thrust, rk_thrust_fix
from .forces import accelerations, kick
from . import step

# drift, kick (S,) each: stage s drifts pos += drift[s] dt vel, then kicks vel += kick[s] dt
# a(pos) (skipped where kick[s] == 0)
Splitting = namedtuple("Splitting", ("drift", "kick"))
# a (S, S) strictly lower triangular, b (S,) weights
RungeKutta = namedtuple("RungeKutta", ("a", "b"))


def _no_scratch(method, state, fx, actors):
    return None


def _split(method, carry, sa, burns, fx, t, dt, k, kicked, played):
    """One step of the drift/kick sequence. With drag each kick also relaxes the velocities
    toward the wind, exactly (forces.kick), so the splitting keeps its order. A step played
    from a prediction's tape (played) drifts only the rows it kicks: the tape puts the
    pulling ones where they end."""
    drift, kicks = method
    pos, vel, acc = sa.pos, sa.vel, sa.acc
    n = pos.shape[0]
    tau = 0.0                                      # time into the step the drifts reached
    for s in range(drift.size):
        h = drift[s] * dt
        if h != 0.0:
            if played:
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
            if burns is not None:
                drift_thrust(burns[0], burns[1], pos, vel, tau, tau + h)
            tau += h
        h = kicks[s] * dt
        if h != 0.0:
            accelerations(fx, t + tau, pos, vel, acc, kicked, False)
            kick(fx.drag, fx.still, vel, acc, h, kicked)
    return True


step.register(Splitting, start_=_no_scratch, advance_=_split, parallel=True, lean=True,
              forceinline=True)


def _stages(method, state, fx, actors):
    """(kx, kv) (S, n, 3): the stage velocities (the derivative of position) and
    accelerations; zeros, not empty: a step played from a prediction's tape leaves the
    pulling rows unset, and they must not carry NaN into pos before the tape restores them."""
    S = method.b.size
    n = state.pos.shape[0]
    return np.empty((S, n, 3)), zeroed(np.empty((S, n, 3)))


def _rk(method, carry, sa, burns, fx, t, dt, k, kicked, played):
    """One step of the tableau: stage s evaluates x_s = x + dt sum_j a[s, j] v_j,
    v_s = v + dt sum_j a[s, j] a_j, a_s = a(x_s, v_s), drag included."""
    a, b = method
    kx, kv = carry
    pos, vel, x = sa.pos, sa.vel, sa.acc
    n = pos.shape[0]
    S = b.size
    no_mask = sa.alive[:0]
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
        if burns is not None:
            add_thrust(burns[0], burns[1], kv[s], c_s * dt, no_mask, -1)
    for i in range(n):
        for c in range(3):
            dx = 0.0
            dv = 0.0
            for s in range(S):
                dx += b[s] * kx[s, i, c]
                dv += b[s] * kv[s, i, c]
            pos[i, c] += dt * dx
            vel[i, c] += dt * dv
    if burns is not None:
        rk_thrust_fix(burns[0], burns[1], vel, a, b, dt)
    return True


step.register(RungeKutta, start_=_stages, advance_=_rk, parallel=True, lean=True,
              forceinline=True)
