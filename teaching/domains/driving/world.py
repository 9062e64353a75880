"""Constants of the driving world (units: feet, seconds, radians).

Everything a trajectory table depends on lives in :data:`WORLD`, whose
:func:`world_fingerprint` is stored with every table so that a table built
under other constants is refused on load.  See docs/calibration.md for why
each number is what it is.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass

import numpy as np


@dataclass(frozen=True)
class World:
    lane_width: float = 12.0
    lane_centres: tuple = (-12.0, 0.0, 12.0)  # left, centre, right; x grows to the right
    wheelbase: float = 9.0
    car_length: float = 15.0  # drawn body only
    car_width: float = 6.0
    horizon: int = 20  # T steps
    dt: float = 0.25  # seconds per step -> 5 s
    v_init: float = 50.0
    # Controls are piecewise constant over `n_knots` segments of T / n_knots steps.
    n_knots: int = 10
    steer_rate_max: float = 0.4  # rad/s: fastest lane change ~1.5 s at 50 ft/s
    accel_max: float = 10.0  # ft/s^2 both ways: 50 ft/s cannot brake below 0 in 5 s, so no clamp on v
    steer_max: float = 0.5  # rad, steering angle is clipped here
    sigma_long: float = 20.0  # closeness kernel, along the other car's heading
    sigma_lat: float = 3.0  # closeness kernel, across it: a quarter lane, so a car in the next lane costs ~e^-8
    road_half_width: float = 18.0  # three 12 ft lanes (drawing; the car's centre is limited by x_limit)
    # Where a car may drive (constraints of the world, not features; docs/calibration.md):
    x_limit: float = 12.0  # the car's centre stays between the outer lane centres
    lane_end_band: float = 2.0  # ft: at the end of the drive the centre is this close to a lane centre
    #                             (to the right lane's for "merge right": the goal is reached)
    heading_end_band: float = 0.05  # rad: ... and the car drives along its lane (no dive at the last moment)
    heading_penalty_scale: float = 100.0  # ft per rad: heading overshoot enters the penalty as feet
    constraint_penalty: float = 10.0  # W: ~W (ft outside)^2 in normalised reward units (kernels.overshoot_penalty)
    turn_smoothing: float = 1e-2  # rad: the turning feature is sum_t sqrt(dh^2 + eps^2) - eps (everywhere)
    # Euclidean learner: per-dimension scale of [x, y, heading, v, steer]
    state_scale: tuple = (12.0, 12.0, 0.1, 10.0, 0.05)

    @property
    def steps_per_knot(self) -> int:
        return self.horizon // self.n_knots

    @property
    def control_bounds(self) -> np.ndarray:
        """(2,) upper bounds on |steer rate|, |acceleration|."""
        return np.array([self.steer_rate_max, self.accel_max])

    @property
    def y_reachable_max(self) -> float:
        """Furthest y_T: full throttle straight ahead (explicit Euler)."""
        t = np.arange(self.horizon)
        return float(self.dt * np.sum(self.v_init + self.accel_max * self.dt * t))


WORLD = World()
THETA_STAR = np.array([-64.0, -0.1, -1.0, -0.1, -0.5])
FEATURE_NAMES = ("closeness", "acceleration", "speed_deviation", "turning", "goal_distance")

# Goals and lanes (indices used in the environment grid).
GOAL_MERGE, GOAL_FORWARD = 0, 1
GOAL_NAMES = ("merge right", "drive forward")


def world_fingerprint(world: World = WORLD) -> str:
    """Short stable hash of the world constants."""
    blob = json.dumps(asdict(world), sort_keys=True).encode()
    return hashlib.sha256(blob).hexdigest()[:16]
