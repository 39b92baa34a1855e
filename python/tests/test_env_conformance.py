"""The Gymnasium contract, checked by us with or without gymnasium installed: spaces and dtypes,
seeding reproducibility, the 5-tuple, reset options, observations inside their spaces."""
import numpy as np
import pytest

import hexsim
from hexsim.env import CompassWaypointEnv, HoverEnv, WaypointEnv

FAST = dict(settle_s=3.0, time_limit_s=0.2)
COMPASS = dict(FAST, settle_s=5.0)  # 1 s of static alignment on the ground first
ENVS = [
    (HoverEnv, dict(FAST, target_N_m=(0.0, 0.0, -2.0)), 16),
    (WaypointEnv, dict(FAST, waypoints_N_m=[(1.0, 0.0, -2.0), (1.0, 1.0, -2.0)]), 19),
    (CompassWaypointEnv, dict(COMPASS, waypoints_N_m=[(3.0, 0.0, -2.0)]), 20),
    (CompassWaypointEnv, dict(COMPASS, waypoints_N_m=[(3.0, 0.0, -2.0)], observe="estimator"), 19),
]
IDS = ["hover", "waypoint", "compass_sensors", "compass_estimator"]


@pytest.mark.parametrize("cls,kwargs,n_obs", ENVS, ids=IDS)
def test_given_each_env_then_the_gymnasium_contract_holds(cls, kwargs, n_obs):
    env = cls(**kwargs)
    assert env.observation_space.shape == (n_obs,) and env.observation_space.dtype == np.float64
    assert env.action_space.dtype == np.float64 and env.render_mode is None
    assert "rgb_array" in env.metadata["render_modes"] and env.metadata["render_fps"] == 100
    obs, info = env.reset(seed=21, options={})
    assert isinstance(info, dict) and obs.dtype == np.float64 and env.observation_space.contains(obs)
    steps = 0
    while True:
        out = env.step(env.action_space.sample())
        steps += 1
        assert len(out) == 5
        obs, reward, terminated, truncated, info = out
        assert env.observation_space.contains(obs) and type(reward) is float
        assert type(terminated) is bool and type(truncated) is bool and type(info["is_success"]) is bool
        if terminated or truncated:
            break
    assert steps <= 20  # time_limit_s / control_period_s


@pytest.mark.parametrize("cls,kwargs,n_obs", ENVS[:3], ids=IDS[:3])
def test_given_one_seed_then_the_same_episode_and_another_seed_a_different_one(cls, kwargs, n_obs):
    def episode(env, seed):
        obs, _ = env.reset(seed=seed)
        trace = [obs]
        action = np.clip(np.full(env.action_space.shape, 0.3), env.action_space.low, env.action_space.high)
        for _ in range(5):
            obs, reward, terminated, truncated, _ = env.step(action)
            trace += [obs, [reward]]
            if terminated or truncated:
                break
        return np.concatenate(trace)
    a, b = cls(**kwargs), cls(**kwargs)
    assert np.array_equal(episode(a, 5), episode(b, 5))
    assert not np.array_equal(episode(a, 5), episode(a, 6))
    # reset() without a seed continues the stream: the second episode is new, and repeatable.
    a.reset(seed=5)
    b.reset(seed=5)
    assert np.array_equal(a.reset()[0], b.reset()[0]) and not np.array_equal(a.reset()[0], episode(a, 5)[:n_obs])


def test_given_reset_options_then_none_and_empty_pass_and_an_unknown_one_is_bad_input():
    env = HoverEnv(**ENVS[0][1])
    env.reset(seed=1, options=None)
    with pytest.raises(hexsim.BadInputError, match="options"):
        env.reset(seed=1, options={"start": 3})


def test_given_compass_waypoint_then_the_true_attitude_is_only_in_info():
    env = CompassWaypointEnv(**ENVS[2][1])
    obs, info = env.reset(seed=2)
    # Sensors: GPS-relative target, GPS velocity, gyro, accel, compass, baro error, current, leg.
    assert 20.0 < np.linalg.norm(obs[12:15]) < 120.0  # the compensated compass, µT
    assert np.linalg.norm(obs[9:12]) == pytest.approx(9.8, abs=1.0)  # specific force at hover
    assert np.allclose(obs[17:20], [1.0, 0.0, 0.0])   # the leg points north
    for key in ("yaw_true_deg", "yaw_est_deg", "yaw_error_deg", "cross_track_m", "true_p_N_m"):
        assert key in info
    with pytest.raises(hexsim.BadInputError, match="observe"):
        CompassWaypointEnv(observe="truth", **FAST)


def test_given_rgb_array_then_render_returns_an_image_and_none_renders_nothing():
    env = HoverEnv(render_mode="rgb_array", **ENVS[0][1])
    env.reset(seed=1)
    env.step(env.action_space.sample())
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3 and frame.std() > 0
    assert HoverEnv(**ENVS[0][1]).render() is None
    with pytest.raises(hexsim.BadInputError):
        HoverEnv(render_mode="human")
