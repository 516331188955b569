"""The physics floor both benchmarks divide by: bare PyBullet stepping cost per body.

N boxes on the daemon's spawn grid (5 m apart, so they never touch), each getting the two
external-force calls a quadrotor needs per 4 ms step, in one DIRECT world; CPU seconds per
simulated second per body. ``reads=True`` adds the two calls that read a body's state back after
each step (pose, velocity), as vehicles/physics.py makes them: every PyBullet call a vehicle
costs.
"""

from __future__ import annotations

import time

import pybullet

from gateway.sim.simulation import PHYSICS_DT_S
from vehicles.types import grid_spawn_ned_m


def bare_pybullet_cpu_per_body_sim_s(n: int, sim_s: float, reads: bool = False) -> float:
    """CPU seconds per simulated second per body, ``n`` bodies stepped for ``sim_s``."""
    cid = pybullet.connect(pybullet.DIRECT)
    try:
        pybullet.setGravity(0, 0, -9.81, physicsClientId=cid)
        pybullet.setTimeStep(PHYSICS_DT_S, physicsClientId=cid)
        plane = pybullet.createCollisionShape(pybullet.GEOM_PLANE, physicsClientId=cid)
        pybullet.createMultiBody(0, plane, physicsClientId=cid)
        box = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=[0.2, 0.2, 0.05],
                                            physicsClientId=cid)
        bodies = []
        for i in range(n):
            north, east = grid_spawn_ned_m(i)
            bodies.append(pybullet.createMultiBody(2.0, box, basePosition=[east, north, 1.0],
                                                   physicsClientId=cid))
        steps = int(sim_s / PHYSICS_DT_S)
        t0 = time.process_time()
        for _ in range(steps):
            for body in bodies:
                pybullet.applyExternalForce(body, -1, (0, 0, 19.62), (0, 0, 1.0),
                                            pybullet.WORLD_FRAME, physicsClientId=cid)
                pybullet.applyExternalTorque(body, -1, (0, 0, 0), pybullet.WORLD_FRAME,
                                             physicsClientId=cid)
            pybullet.stepSimulation(physicsClientId=cid)
            if reads:
                for body in bodies:
                    pybullet.getBasePositionAndOrientation(body, physicsClientId=cid)
                    pybullet.getBaseVelocity(body, physicsClientId=cid)
        return (time.process_time() - t0) / (steps * PHYSICS_DT_S) / n
    finally:
        pybullet.disconnect(cid)
