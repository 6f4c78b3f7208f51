"""The Gymnasium environments: Gymnasium's checker, seeding, spaces and bad arguments."""

from __future__ import annotations

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

import aiauv_pin  # noqa: E402
from aiauv_pin.envs import ENVIRONMENTS, PathFollowingEnv, StationKeepingEnv, SwimmingEnv  # noqa: E402
from aiauv_pin.errors import ArgumentError  # noqa: E402

IDS = sorted(ENVIRONMENTS)


def _trajectory(env, seed: int, steps: int = 40):
    """Observations and rewards of ``steps`` steps from ``reset(seed)`` with seeded actions."""
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    observations, rewards = [obs], []
    for _ in range(steps):
        obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        observations.append(obs)
        rewards.append(reward)
        if terminated or truncated:
            observations.append(env.reset()[0])
    return np.array(observations), np.array(rewards)


@pytest.mark.parametrize("env_id", IDS)
def test_gymnasium_checker_passes(env_id):
    from gymnasium.utils.env_checker import check_env

    env = gymnasium.make(env_id, episode_steps=50)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


@pytest.mark.parametrize("env_id", IDS)
def test_the_same_seed_gives_the_same_trajectory(env_id):
    env = gymnasium.make(env_id, episode_steps=25)
    first = _trajectory(env, 7)
    again = _trajectory(env, 7)
    other = _trajectory(env, 8)
    assert np.array_equal(first[0], again[0]) and np.array_equal(first[1], again[1])
    assert not np.array_equal(first[0][0], other[0][0])
    fresh = gymnasium.make(env_id, episode_steps=25)  # another instance, same numbers
    assert np.array_equal(_trajectory(fresh, 7)[0], first[0])


@pytest.mark.parametrize(
    ("cls", "observation", "action"),
    [(PathFollowingEnv, 37, 9), (StationKeepingEnv, 41, 15), (SwimmingEnv, 26, 8)],
)
def test_documented_sizes_on_the_paper_vehicle(cls, observation, action):
    env = cls()
    assert env.observation_space.shape == (observation,)
    assert env.action_space.shape == (action,)
    assert env.step_duration == pytest.approx(0.04)
    obs, info = env.reset(seed=0)
    assert obs.shape == (observation,) and info == {}
    env.close()


def test_truncation_after_episode_steps():
    env = SwimmingEnv(episode_steps=3)
    env.reset(seed=0)
    flags = [env.step(np.zeros(8))[3] for _ in range(3)]
    assert flags == [False, False, True]


def test_a_joint_past_its_limit_terminates():
    env = SwimmingEnv(control="torques", max_joint_torque=200.0)
    env.reset(seed=0)
    for _ in range(100):
        _, _, terminated, _, info = env.step(np.ones(8))
        if terminated:
            break
    assert terminated and info["beyond_joint_limit"] and not info["diverged"]


def test_station_keeping_rewards_the_target():
    env = StationKeepingEnv(target_offset=0.0, max_current=0.0)
    obs, _ = env.reset(seed=0)
    assert np.allclose(obs[:6], 0.0)  # no position or attitude error at the start
    _, reward, *_ = env.step(np.zeros(15))
    assert reward == pytest.approx(0.0, abs=1e-6)  # still water, at the target, no effort


def test_path_following_observes_the_cross_track_error():
    env = PathFollowingEnv(initial_heading=0.0)
    obs, _ = env.reset(seed=3)
    assert obs[0] == pytest.approx(env.sim.q[0, 1])  # straight vehicle: e_y is the base's y
    assert np.allclose(obs[2:5], [1.0, 0.0, 0.0])  # the end-effector points along the path


@pytest.mark.parametrize(
    "arguments",
    [
        {"control": "velocity"},
        {"episode_steps": 0},
        {"episode_steps": 2.5},
        {"dt": 0.0},
        {"substeps": 0},
        {"method": "leapfrog"},
        {"max_joint_torque": -1.0},
        {"servo_gains": (1.0,)},
        {"max_error": 0.0},
    ],
)
def test_bad_arguments_give_one_line(arguments):
    with pytest.raises(ArgumentError) as error:
        PathFollowingEnv(**arguments)
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("action", [np.zeros(3), np.full(9, np.nan), "surge", np.zeros((1, 9))])
def test_bad_actions_give_one_line(action):
    env = PathFollowingEnv()
    env.reset(seed=0)
    with pytest.raises(ArgumentError) as error:
        env.step(action)
    assert "\n" not in str(error.value)


def test_the_pinocchio_backend_is_refused():
    with pytest.raises(ArgumentError, match="compiled backend"):
        SwimmingEnv(aiauv_pin.load_vehicle(backend="pinocchio"))


def test_base_angles_spread_over_the_joints_by_the_papers_pattern():
    from aiauv_control.joint_references import joint_references

    env = PathFollowingEnv(steering="base_angles")
    env.reset(seed=0)
    env.set_controls(np.array([[0.4, -0.7, 0.0]]))
    m, nj = env.n_thrusters, env.n_joints
    expected = joint_references([0.4 * env.q_max, -0.7 * env.q_max], ["z", "y"] * 4, 0.7, env.q_max)
    assert np.allclose(env.sim.controls[0, m + nj :], expected, rtol=0, atol=1e-15)


def test_base_angles_need_references():
    with pytest.raises(ArgumentError, match="references"):
        PathFollowingEnv(steering="base_angles", control="torques")
    with pytest.raises(ArgumentError, match="steering"):
        PathFollowingEnv(steering="heading")
