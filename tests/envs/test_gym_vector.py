"""The vector environment: rows equal single environments, autoreset, threads, bad arguments."""

from __future__ import annotations

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

from gymnasium.vector import AutoresetMode  # noqa: E402

from aiauv_pin.envs import ENVIRONMENTS, SwimmingEnv, VehicleVectorEnv  # noqa: E402
from aiauv_pin.errors import ArgumentError  # noqa: E402


@pytest.mark.parametrize("env_id", sorted(ENVIRONMENTS))
def test_each_row_is_the_single_environment_with_next_step_autoreset(env_id):
    n, row, steps = 4, 2, 30
    vector = gymnasium.make_vec(env_id, num_envs=n, episode_steps=12)
    assert isinstance(vector, VehicleVectorEnv)
    assert vector.metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP
    rng = np.random.default_rng(1)
    actions = rng.uniform(-1.0, 1.0, (steps, *vector.action_space.shape))
    obs, _ = vector.reset(seed=10)
    assert obs.shape == (n, *vector.single_observation_space.shape)
    rows, rewards, ended = [obs[row]], [], []
    for action in actions:
        obs, reward, terminated, truncated, info = vector.step(action)
        rows.append(obs[row])
        rewards.append(reward[row])
        ended.append(terminated[row] or truncated[row])
        assert set(info) >= {"diverged", "_diverged"}
    assert sum(ended) >= 2  # the autoreset was exercised

    single = gymnasium.make(env_id, episode_steps=12)
    expected, expected_rewards = [single.reset(seed=10 + row)[0]], []
    done = False
    for action in actions:
        if done:  # NEXT_STEP: the step after the end resets, with reward 0
            expected.append(single.reset()[0])
            expected_rewards.append(0.0)
            done = False
            continue
        o, r, terminated, truncated, _ = single.step(action[row])
        expected.append(o)
        expected_rewards.append(r)
        done = terminated or truncated
    assert np.array_equal(np.array(rows), np.array(expected))
    assert np.array_equal(np.array(rewards), np.array(expected_rewards))
    vector.close()


def test_rows_do_not_depend_on_the_thread_count():
    runs = []
    for threads in (1, 3):
        vector = VehicleVectorEnv(SwimmingEnv, 7, threads=threads)
        obs, _ = vector.reset(seed=5)
        actions = np.random.default_rng(0).uniform(-1.0, 1.0, (10, 7, 8))
        log = [obs] + [vector.step(a)[0] for a in actions]
        runs.append(np.array(log))
        vector.close()
    assert np.array_equal(runs[0], runs[1])


def test_reset_mask_resets_only_those_rows():
    vector = VehicleVectorEnv(SwimmingEnv, 3)
    vector.reset(seed=0)
    for _ in range(5):
        obs, *_ = vector.step(np.ones((3, 8)) * 0.3)
    again, _ = vector.reset(seed=0, options={"reset_mask": np.array([True, False, False])})
    first, _ = VehicleVectorEnv(SwimmingEnv, 3).reset(seed=0)
    assert np.array_equal(again[0], first[0])
    assert np.array_equal(again[1:], obs[1:])


@pytest.mark.parametrize("num_envs", [0, -1, 2.0, True])
def test_bad_sizes_give_one_line(num_envs):
    with pytest.raises(ArgumentError) as error:
        VehicleVectorEnv(SwimmingEnv, num_envs)
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("actions", [np.zeros(8), np.zeros((3, 8)), np.full((2, 8), np.inf)])
def test_bad_actions_give_one_line(actions):
    vector = VehicleVectorEnv(SwimmingEnv, 2)
    vector.reset(seed=0)
    with pytest.raises(ArgumentError) as error:
        vector.step(actions)
    assert "\n" not in str(error.value)


def test_bad_seeds_and_masks_give_one_line():
    vector = VehicleVectorEnv(SwimmingEnv, 2)
    with pytest.raises(ArgumentError):
        vector.reset(seed=[1, 2, 3])
    with pytest.raises(ArgumentError):
        vector.reset(options={"reset_mask": np.array([1, 0])})
