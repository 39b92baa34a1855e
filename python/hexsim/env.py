"""Gym-style environments for controller prototyping: the Gymnasium API without requiring it.

HoverEnv      hold a hover point; WaypointEnv: fly a list of waypoints.
reset(seed=None, options=None) -> (obs, info); step(action) -> (obs, reward, terminated, truncated, info).

Each episode starts in the air: the built-in cascade takes off and settles at the start point
(settle_s, not part of the episode), then the agent acts every control_period_s.

Observation (float64): from the true state, position error target − p (m, NED, 3), velocity (m/s,
NED, 3), attitude quaternion q_NB (w, x, y, z), body rates (rad/s, FRD, 3); and the raw compass 1
reading (µT, body, 3, with its noise), which carries the field the motor and battery currents make; WaypointEnv appends the waypoint
after the current one, relative to the current one (m, NED, 3; zeros for the last).
Action: act="motors": one normalised command per motor in [0, 1]; act="rates": [p, q, r] in
[-1, 1] × max_rate_radps and collective thrust in [0, 1] × the vehicle's largest thrust.
Reward per step: −(|position error|² + 0.1·|rates|²). Terminated: tilt above 60°, ground impact
(height above the start below ground_margin_m) or the simulation ending (diverged);
WaypointEnv also when the last waypoint is reached. Truncated: time_limit_s of agent time.
"""
import math

import numpy as np

import hexsim

try:  # Gymnasium's Box when it is installed, so that its wrappers and checkers accept the spaces.
    from gymnasium.spaces import Box
except ImportError:  # pragma: no cover - depends on the machine
    class Box:
        """The part of gymnasium.spaces.Box the environments use."""

        def __init__(self, low, high, shape=None, dtype=np.float64, seed=None):
            shape = shape if shape is not None else np.shape(low)
            self.low = np.broadcast_to(np.asarray(low, dtype=dtype), shape).copy()
            self.high = np.broadcast_to(np.asarray(high, dtype=dtype), shape).copy()
            self.shape, self.dtype = tuple(shape), np.dtype(dtype)
            self._rng = np.random.default_rng(seed)

        def sample(self):
            low = np.where(np.isfinite(self.low), self.low, -1.0)
            high = np.where(np.isfinite(self.high), self.high, 1.0)
            return self._rng.uniform(low, high).astype(self.dtype)

        def contains(self, x):
            x = np.asarray(x)
            return x.shape == self.shape and bool(np.all(x >= self.low) and np.all(x <= self.high))

        def seed(self, seed=None):
            self._rng = np.random.default_rng(seed)

        def __repr__(self):
            return f"Box({self.low.min()}, {self.high.max()}, {self.shape}, {self.dtype})"

MAX_TILT_DEG = 60.0
RATE_WEIGHT = 0.1


class HoverEnv:
    """Hold the hover point target_N_m (NED, m) from a start offset drawn in ±start_offset_m."""

    metadata = {"render_modes": []}
    render_mode = None

    def __init__(self, vehicle="default_hex", world="default", act="motors", target_N_m=(0.0, 0.0, -5.0),
                 time_limit_s=10.0, control_period_s=0.01, settle_s=6.0, start_offset_m=0.5,
                 max_rate_radps=math.pi, ground_margin_m=0.3, estimator="truth", set=None):
        if act not in ("motors", "rates"):
            raise hexsim.BadInputError(f"act: '{act}': expected motors or rates")
        if not control_period_s >= 0.001:
            raise hexsim.BadInputError(f"control_period_s: must be >= 0.001 (got {control_period_s})")
        self._config = dict(vehicle=vehicle, world=world, estimator=estimator, set=set)
        self.act = act
        self.target_N_m = np.asarray(target_N_m, dtype=float)
        self.time_limit_s = float(time_limit_s)
        self.steps_per_action = max(1, int(round(control_period_s / 0.001)))
        self.settle_s, self.start_offset_m = float(settle_s), float(start_offset_m)
        self.max_rate_radps, self.ground_margin_m = float(max_rate_radps), float(ground_margin_m)
        probe = hexsim.Simulation(vehicle=vehicle, world=world, estimator="truth", duration=0.001, set=set)
        self.rotors, self.max_thrust_N = probe.rotors, probe.max_thrust_N
        n_obs = 16 + self._extra_observations()
        self.observation_space = Box(-np.inf, np.inf, shape=(n_obs,), dtype=np.float64)
        if act == "motors":
            self.action_space = Box(0.0, 1.0, shape=(self.rotors,), dtype=np.float64)
        else:
            self.action_space = Box(np.array([-1.0, -1.0, -1.0, 0.0]), np.array([1.0, 1.0, 1.0, 1.0]),
                                    dtype=np.float64)
        self.sim = None
        self.np_random = np.random.default_rng()
        self._t0_s = 0.0
        self._ground_D_m = 0.0

    # --- Gymnasium API ---------------------------------------------------------------------------
    def reset(self, *, seed=None, options=None):
        if seed is not None:
            self.np_random = np.random.default_rng(seed)
            self.action_space.seed(seed)
        sim_seed = int(self.np_random.integers(1, 2**31))
        duration_s = self.settle_s + self.time_limit_s + 1.0
        self.sim = hexsim.Simulation(mission="square", seed=sim_seed, duration=duration_s, **self._config)
        self._ground_D_m = float(self.sim.state_vector()[3])
        self._begin_episode(options or {})
        start = self._start_point() + self.np_random.uniform(-1, 1, 3) * self.start_offset_m
        self.sim.act("position", [*start, 0.0])
        self.sim.step(int(round(self.settle_s * 1000)))
        self._t0_s = self.sim.time_s
        obs = self._observe()
        return obs, self._info(obs)

    def step(self, action):
        if self.sim is None:
            raise hexsim.BadInputError("step: call reset() first")
        a = np.clip(np.asarray(action, dtype=float), self.action_space.low, self.action_space.high)
        if self.act == "motors":
            self.sim.act("motors", a.tolist())
        else:
            self.sim.act("rates", [*(a[:3] * self.max_rate_radps), a[3] * self.max_thrust_N])
        alive = self.sim.step(self.steps_per_action)
        obs = self._observe()
        error, rates = obs[0:3], obs[10:13]
        reward = -(float(error @ error) + RATE_WEIGHT * float(rates @ rates))
        x = self.sim.state_vector()
        q = x[7:11]
        tilt_deg = math.degrees(math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (q[1] ** 2 + q[2] ** 2)))))
        height_m = self._ground_D_m - x[3]
        terminated = (not alive) or tilt_deg > MAX_TILT_DEG or height_m < self.ground_margin_m
        target = self._target()
        terminated = self._advance_target(error) or terminated
        if self._target() is not target:
            obs = self._observe()  # the next waypoint is the target from now on
        truncated = not terminated and self.sim.time_s - self._t0_s >= self.time_limit_s - 1e-9
        info = self._info(obs)
        info.update(tilt_deg=tilt_deg, height_m=height_m)
        return obs, reward, bool(terminated), bool(truncated), info

    def close(self):
        self.sim = None

    # --- What WaypointEnv changes ----------------------------------------------------------------
    def _extra_observations(self):
        return 0

    def _begin_episode(self, options):
        pass

    def _start_point(self):
        return self.target_N_m

    def _target(self):
        return self.target_N_m

    def _advance_target(self, error):
        return False

    def _extra(self):
        return []

    # --- Shared ----------------------------------------------------------------------------------
    def _observe(self):
        x = self.sim.state_vector()
        mag = self.sim.sensors()["mag_uT"]
        return np.concatenate([self._target() - x[1:4], x[4:7], x[7:11], x[11:14], mag, *self._extra()])

    def _info(self, obs):
        return {"t_s": self.sim.time_s - self._t0_s, "position_error_m": float(np.linalg.norm(obs[0:3])),
                "battery_A": self.sim.state()["battery_A"]}


class WaypointEnv(HoverEnv):
    """Fly waypoints (NED, m) in order; a waypoint counts as reached within acceptance_m."""

    def __init__(self, waypoints_N_m=((10.0, 0.0, -5.0), (10.0, 10.0, -5.0), (0.0, 10.0, -5.0), (0.0, 0.0, -5.0)),
                 acceptance_m=1.0, time_limit_s=40.0, **kwargs):
        self.waypoints_N_m = [np.asarray(w, dtype=float) for w in waypoints_N_m]
        if not self.waypoints_N_m:
            raise hexsim.BadInputError("waypoints_N_m: at least one waypoint")
        self.acceptance_m = float(acceptance_m)
        self.index = 0
        kwargs.setdefault("target_N_m", (0.0, 0.0, float(self.waypoints_N_m[0][2])))
        super().__init__(time_limit_s=time_limit_s, **kwargs)

    def _extra_observations(self):
        return 3

    def _begin_episode(self, options):
        self.index = 0

    def _start_point(self):
        return self.target_N_m  # the take-off point's hover, then the first waypoint

    def _target(self):
        return self.waypoints_N_m[self.index]

    def _advance_target(self, error):
        if np.linalg.norm(error) >= self.acceptance_m:
            return False
        if self.index + 1 == len(self.waypoints_N_m):
            return True
        self.index += 1
        return False

    def _extra(self):
        if self.index + 1 < len(self.waypoints_N_m):
            return [self.waypoints_N_m[self.index + 1] - self.waypoints_N_m[self.index]]
        return [np.zeros(3)]

    def _info(self, obs):
        info = super()._info(obs)
        info["waypoint_index"] = self.index
        return info
