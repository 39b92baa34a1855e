"""With gymnasium installed (not in Debian 12: python/docs/README.md), its own checker and wrappers
accept the environments. Skipped where gymnasium does not import."""
import numpy as np
import pytest

import hexsim  # noqa: F401  (registers the ids)

try:
    import gymnasium as gym
    from gymnasium.utils.env_checker import check_env
except ImportError:  # collected and reported as skipped (pytest exits 0), not "no tests" (exit 5)
    gym = None
pytestmark = pytest.mark.skipif(gym is None, reason="gymnasium does not import")

FAST = dict(settle_s=3.0, time_limit_s=0.2, target_N_m=(0.0, 0.0, -2.0))


@pytest.mark.parametrize("env_id", ["hexsim/Hover-v0", "hexsim/Waypoint-v0", "hexsim/CompassWaypoint-v0"])
def test_given_gymnasium_then_check_env_passes(env_id):
    kwargs = dict(FAST, settle_s=5.0, waypoints_N_m=[(2.0, 0.0, -2.0)]) if "Hover" not in env_id else FAST
    env = gym.make(env_id, **kwargs)
    assert isinstance(env.unwrapped, gym.Env)
    check_env(env.unwrapped)


def test_given_gymnasium_then_the_wrappers_and_vector_envs_run():
    env = gym.wrappers.NormalizeObservation(gym.wrappers.TimeLimit(gym.make("hexsim/Hover-v0", **FAST), 5))
    env.reset(seed=1)
    for _ in range(5):
        *_, truncated, _ = env.step(env.action_space.sample())
    assert truncated
    sync = gym.vector.SyncVectorEnv([lambda: gym.make("hexsim/Hover-v0", **FAST)] * 2)
    assert sync.reset(seed=1)[0].shape == (2, 16)
    vec = gym.make_vec("hexsim/Hover-v0", num_envs=3, vectorization_mode="vector_entry_point", **FAST)
    assert isinstance(vec, gym.vector.VectorEnv) and vec.reset(seed=1)[0].shape == (3, 16)
    stats = gym.wrappers.vector.RecordEpisodeStatistics(vec)
    stats.reset(seed=1)
    for _ in range(21):
        *_, info = stats.step(stats.action_space.sample())
        if "episode" in info:
            break
    assert "episode" in info and np.all(info["episode"]["l"][info["_episode"]] == 20)
