"""hexsim.VectorEnv: n environments in one call equal n single ones, whatever n and the threads."""
import numpy as np
import pytest

import hexsim

FAST = dict(settle_s=2.0, target_N_m=(0.0, 0.0, -1.0), time_limit_s=0.05)  # 5-step episodes
STEPS = 12  # two auto-resets


def actions_for(k, n, rotors, hover):
    rng = np.random.default_rng(k)
    return np.clip(hover + 0.05 * rng.standard_normal((n, rotors)), 0.0, 1.0)


def vector_trace(n, threads, seed):
    vec = hexsim.VectorEnv(n, threads=threads, **FAST)
    assert vec.threads == threads
    obs, _ = vec.reset(seed=seed)
    trace = [obs]
    for k in range(STEPS):
        obs, rewards, terminated, truncated, info = vec.step(actions_for(k, n, vec.rotors, vec.hover_command))
        assert obs.shape == (n, 16) and rewards.shape == terminated.shape == info["is_success"].shape == (n,)
        trace += [obs, rewards[:, None], terminated[:, None], truncated[:, None]]
    return np.hstack(trace)


def single_trace(n, seed):
    rows = []
    for i in range(n):
        env = hexsim.HoverEnv(**FAST)
        obs, _ = env.reset(seed=seed + i)
        row, over = [obs], False
        for k in range(STEPS):
            action = actions_for(k, n, env.rotors, env.hover_command)[i]
            if over:  # the vector's next-step auto-reset: the next episode, reward 0
                obs, reward, terminated, truncated, over = env.reset()[0], 0.0, False, False, False
            else:
                obs, reward, terminated, truncated, _ = env.step(action)
                over = terminated or truncated
            row += [obs, [reward], [terminated], [truncated]]
        rows.append(np.concatenate(row))
    return np.vstack(rows)


@pytest.mark.parametrize("n", [1, 7, 64])
def test_given_n_envs_on_one_or_two_threads_then_they_equal_n_hover_envs_with_the_same_seeds(n):
    want = single_trace(n, seed=40)
    for threads in (1, 2):
        assert np.array_equal(vector_trace(n, threads, seed=40), want), f"threads={threads}"


def test_given_a_vector_then_spaces_are_batched_and_infos_carry_masks():
    vec = hexsim.VectorEnv(3, "compass_waypoint", threads=2, waypoints_N_m=[(3.0, 0.0, -2.0)],
                           settle_s=3.0, time_limit_s=0.1)
    assert vec.single_observation_space.shape == (20,) and vec.observation_space.shape == (3, 20)
    assert vec.action_space.shape == (3, 4) and str(vec.metadata["autoreset_mode"]).endswith("NEXT_STEP") or \
        vec.metadata["autoreset_mode"] == "NextStep"
    obs, info = vec.reset(seed=[7, 7, 8])
    assert np.array_equal(obs[0], obs[1]) and not np.array_equal(obs[0], obs[2])
    obs, rewards, terminated, truncated, info = vec.step(vec.action_space.sample())
    assert info["_cross_track_m"].all() and info["cross_track_m"].shape == (3,)
    with pytest.raises(hexsim.BadInputError, match="actions"):
        vec.step(np.zeros((2, 4)))
    bad = np.zeros((3, 4))
    bad[2, 1] = np.nan
    with pytest.raises(hexsim.BadInputError, match="env 2, value 1: not a finite number"):
        vec.step(bad)
    with pytest.raises(hexsim.BadInputError, match="task"):
        hexsim.VectorEnv(2, "hover_upside_down")
