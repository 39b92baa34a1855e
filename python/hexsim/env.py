"""Gymnasium environments for controller prototyping and training; the episode logic is hexsim's C++
(envs/), so that one environment and a vector of many step alike.

    HoverEnv            hold a hover point                      hexsim/Hover-v0
    WaypointEnv         fly a list of waypoints                 hexsim/Waypoint-v0
    CompassWaypointEnv  fly waypoint legs on what the autopilot
                        senses (IMU, GPS, baro, the disturbed
                        compass, or the estimator's state)      hexsim/CompassWaypoint-v0
    VectorEnv(n, task)  n of them stepped in one call on a thread pool (the GIL released)

With gymnasium installed the classes are gymnasium.Env / gymnasium.vector.VectorEnv with
gymnasium.spaces and are registered; without it they run on hexsim._compat's small base classes.
reset(seed=None, options=None) -> (obs, info); step(action) -> (obs, reward, terminated, truncated, info).
Seeding: an env reset with seed s flies the same episodes as env i of a VectorEnv reset with seed
s - i (a vector gives env i the seed s + i); reset() without a seed continues the env's episode stream.
Layouts, units, frames, rewards and termination: python/docs/ (one page per environment).
"""
import numpy as np

from . import _hexsim
from ._hexsim import ENV_INFO_NAMES, VectorCore, render_tracks

try:  # Gymnasium's classes when it is installed, so that its checker, wrappers and make() accept ours.
    import gymnasium as _gym
    from gymnasium.spaces import Box
    from gymnasium.vector.utils import batch_space as _batch_space
    _EnvBase, _VectorBase = _gym.Env, _gym.vector.VectorEnv
    HAVE_GYMNASIUM = True
except ImportError:  # pragma: no cover - depends on the machine
    from ._compat import Box, Env as _EnvBase, VectorEnv as _VectorBase, batch_box as _batch_space
    _gym = None
    HAVE_GYMNASIUM = False

_INT_INFO = {"waypoint_index": int, "is_success": bool}
_SEED_LIMIT = 2**63


def _core(n, threads, autoreset, vehicle, world, mission, estimator, set, calibration, calibration_seed, options):
    options = {k: v for k, v in options.items() if v is not None}
    return VectorCore(n, threads, autoreset, vehicle, world, mission, estimator or "", set, calibration,
                      int(calibration_seed), options)


def _check_reset_options(options):
    if options:  # no reset option exists yet: a misspelt one must not pass silently
        raise _hexsim.BadInputError(f"reset: options: {sorted(options)}: no reset options are defined")


class _Layout:
    """The vehicle as a motors-mode controller needs it (attributes and reset info)."""

    def _set_layout(self, layout):
        self.layout = dict(layout)
        self.rotors = int(layout["rotors"])
        self.rotor_p_B_m = layout["rotor_p_B_m"]    # (N, 3) m, body FRD
        self.spin = layout["spin"]                  # +1 counter-clockwise seen from above
        self.mixer = layout["mixer"]                # [thrust_N; τ_B (N·m)] = mixer @ rotor thrusts (N)
        self.hover_command = float(layout["hover_command"])  # equal motor command for m·g, full charge
        self.hover_thrust_N = float(layout["hover_thrust_N"])
        self.max_thrust_N = float(layout["max_thrust_N"])
        self.mass_kg = float(layout["mass_kg"])
        self.inertia_kgm2 = layout["inertia_kgm2"]  # 3×3, body FRD


class HoverEnv(_EnvBase, _Layout):
    """Hold the hover point target_N_m (NED, m) from a start offset drawn in ±start_offset_m."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 100}
    task = "hover"
    defaults = dict(act="motors", observe="truth", estimator="truth")

    def __init__(self, render_mode=None, *, vehicle="default_hex", world="default", mission="square",
                 estimator=None, set=None, calibration="none", calibration_seed=1, **options):
        if render_mode not in (None, "rgb_array"):
            raise _hexsim.BadInputError(f"render_mode: '{render_mode}': expected None or 'rgb_array'")
        self.render_mode = render_mode
        options = {**{k: v for k, v in self.defaults.items() if k != "estimator"}, **options}
        self.options = options
        self._core = _core(1, 1, False, vehicle, world, mission, estimator or self.defaults["estimator"], set,
                           calibration, calibration_seed, dict(options, task=self.task))
        self._set_layout(self._core.layout)
        self.observation_space = Box(-np.inf, np.inf, shape=(self._core.observation_size,), dtype=np.float64)
        self.action_space = Box(self._core.action_low, self._core.action_high, dtype=np.float64)
        self.metadata = dict(self.metadata, render_fps=round(1.0 / self._core.agent_dt_s))
        self._seeded = False
        self._track = []
        self._planned = np.atleast_2d(np.asarray(options.get("target_N_m", (0.0, 0.0, -5.0)), dtype=float))

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        _check_reset_options(options)
        if seed is None and not self._seeded:  # a fresh env without a seed: one from the OS's entropy
            seed = int(self.np_random.integers(0, _SEED_LIMIT))
        if seed is not None:
            self.action_space.seed(int(seed) % 2**32)
            self._seeded = True
        obs, info = self._core.reset(None if seed is None else [int(seed)])
        info = self._info(info[0])
        info.update(self.layout, episode_sim_seed=self._core.episode_sim_seeds[0])
        self._track = [self._position(info)]
        return obs[0], info

    def step(self, action):
        obs, reward, terminated, truncated, info = self._core.step(np.asarray(action, dtype=np.float64))
        info = self._info(info[0])
        if self.render_mode is not None:
            self._track.append(self._position(info))
        return obs[0], float(reward[0]), bool(terminated[0]), bool(truncated[0]), info

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        return render_tracks(self._planned, np.asarray(self._track))

    def close(self):
        self._track = []

    @staticmethod
    def _info(row):
        info = {name: _INT_INFO.get(name, float)(value) for name, value in zip(ENV_INFO_NAMES, row)}
        return info

    @staticmethod
    def _position(info):
        return (info["true_p_N_m"], info["true_p_E_m"], info["true_p_D_m"])


class WaypointEnv(HoverEnv):
    """Fly waypoints (NED, m) in order from a take-off hover at target_N_m; reached within acceptance_m."""

    task = "waypoint"
    SQUARE_N_m = ((10.0, 0.0, -5.0), (10.0, 10.0, -5.0), (0.0, 10.0, -5.0), (0.0, 0.0, -5.0))

    def __init__(self, render_mode=None, *, waypoints_N_m=SQUARE_N_m, time_limit_s=40.0, **kwargs):
        waypoints = np.asarray(waypoints_N_m, dtype=float).reshape(-1, 3)
        if waypoints.size:
            kwargs.setdefault("target_N_m", (0.0, 0.0, float(waypoints[0][2])))
        super().__init__(render_mode, waypoints_N_m=waypoints, time_limit_s=time_limit_s, **kwargs)
        self.waypoints_N_m = waypoints
        self._planned = np.vstack([np.atleast_2d(self.options["target_N_m"]), waypoints])


class CompassWaypointEnv(WaypointEnv):
    """Waypoint legs flown on the autopilot's own senses: the compass's current-driven disturbance
    turns into heading error, and heading error into cross-track error. Truth only in info."""

    task = "compass_waypoint"
    defaults = dict(act="attitude", observe="sensors", estimator="eskf")
    LEGS_N_m = ((20.0, 0.0, -5.0), (20.0, 20.0, -5.0))

    def __init__(self, render_mode=None, *, waypoints_N_m=LEGS_N_m, time_limit_s=60.0, calibration="none",
                 **kwargs):
        super().__init__(render_mode, waypoints_N_m=waypoints_N_m, time_limit_s=time_limit_s,
                         calibration=calibration, **kwargs)


_TASKS = {"hover": HoverEnv, "waypoint": WaypointEnv, "compass_waypoint": CompassWaypointEnv}


class VectorEnv(_VectorBase, _Layout):
    """n environments of one task stepped in one call: actions (n, action) in; observations (n, obs),
    rewards, terminations, truncations (n) and info arrays out. Auto-reset in Gymnasium's next-step
    mode: the step after an episode ends starts the env's next episode (action ignored, reward 0)."""

    def __init__(self, num_envs, task="hover", *, threads=None, render_mode=None, vehicle="default_hex",
                 world="default", mission="square", estimator=None, set=None, calibration="none",
                 calibration_seed=1, **options):
        if task not in _TASKS:
            raise _hexsim.BadInputError(f"task: '{task}': expected one of {', '.join(_TASKS)}")
        if render_mode is not None:
            raise _hexsim.BadInputError("render_mode: a VectorEnv does not render (use one env's rgb_array)")
        single = _TASKS[task]
        if task != "hover":
            options.setdefault("waypoints_N_m", single.SQUARE_N_m if task == "waypoint" else single.LEGS_N_m)
            options.setdefault("time_limit_s", 40.0 if task == "waypoint" else 60.0)
            options.setdefault("target_N_m", (0.0, 0.0, float(np.asarray(options["waypoints_N_m"])[0][2])))
        options = {**{k: v for k, v in single.defaults.items() if k != "estimator"}, **options}
        threads = threads if threads is not None else min(num_envs, _cpu_count())
        self.task, self.options, self.num_envs = task, options, int(num_envs)
        self._core = _core(self.num_envs, int(threads), True, vehicle, world, mission,
                           estimator or single.defaults["estimator"], set, calibration, calibration_seed,
                           dict(options, task=task))
        self._set_layout(self._core.layout)
        self.single_observation_space = Box(-np.inf, np.inf, shape=(self._core.observation_size,), dtype=np.float64)
        self.single_action_space = Box(self._core.action_low, self._core.action_high, dtype=np.float64)
        self.observation_space = _batch_space(self.single_observation_space, self.num_envs)
        self.action_space = _batch_space(self.single_action_space, self.num_envs)
        autoreset = _gym.vector.AutoresetMode.NEXT_STEP if HAVE_GYMNASIUM else "NextStep"
        self.metadata = {"autoreset_mode": autoreset, "render_modes": []}
        self.render_mode = None
        self._seeded = False
        self._mask = np.ones(self.num_envs, dtype=bool)

    @property
    def threads(self):
        return self._core.threads

    def reset(self, *, seed=None, options=None):
        super().reset(seed=None if isinstance(seed, (list, tuple, np.ndarray)) else seed)
        _check_reset_options(options)
        if seed is None and not self._seeded:
            seed = int(np.random.default_rng().integers(0, _SEED_LIMIT - self.num_envs))
        if seed is None:
            seeds = None
        elif isinstance(seed, (list, tuple, np.ndarray)):
            seeds = [int(s) for s in seed]
        else:
            seeds = [int(seed) + i for i in range(self.num_envs)]
        if seeds is not None:
            self.action_space.seed(seeds[0] % 2**32)
            self._seeded = True
        obs, info = self._core.reset(seeds)
        infos = self._infos(info)
        infos.update(self.layout)
        return obs, infos

    def step(self, actions):
        obs, rewards, terminated, truncated, info = self._core.step(np.asarray(actions, dtype=np.float64))
        return obs, rewards, terminated, truncated, self._infos(info)

    def _infos(self, info):
        infos = {}
        for k, name in enumerate(ENV_INFO_NAMES):
            column = info[:, k]
            infos[name] = column.astype(_INT_INFO[name]) if name in _INT_INFO else column
            infos["_" + name] = self._mask
        return infos

    def bench_physics(self, agent_steps):
        """Benchmark reference: the same simulations stepped in a plain C++ loop (one thread)."""
        self._core.bench_physics(int(agent_steps))


def _cpu_count():
    import os
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def _vector_entry(task):
    def make(num_envs=1, **kwargs):
        return VectorEnv(num_envs, task, **kwargs)
    return make


ENV_IDS = {"hexsim/Hover-v0": ("HoverEnv", "hover"), "hexsim/Waypoint-v0": ("WaypointEnv", "waypoint"),
           "hexsim/CompassWaypoint-v0": ("CompassWaypointEnv", "compass_waypoint")}

if HAVE_GYMNASIUM:
    for _id, (_cls, _task) in ENV_IDS.items():
        if _id not in _gym.registry:
            _gym.register(id=_id, entry_point=f"hexsim.env:{_cls}", vector_entry_point=_vector_entry(_task))
