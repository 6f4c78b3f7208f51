"""Training smoke tests, no ML framework: a scripted policy beats a random one, and a random
search over a travelling wave's parameters on the vector environment improves the return.

The wave, ``a_i(t) = A sin(2 pi f t + i lag)`` on joint ``i``, is a policy written for these tests
only (the gaits of issue 35 are controllers of their own); a few thousand steps in all.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("gymnasium")

from aiauv_pin.envs import PathFollowingEnv, SwimmingEnv, VehicleVectorEnv


def _wave(t: float, amplitude: float, frequency: float, lag: float, n: int = 8) -> np.ndarray:
    return amplitude * np.sin(2.0 * np.pi * frequency * t + lag * np.arange(n))


def _episode_return(env, policy, steps: int, seed: int) -> float:
    obs, _ = env.reset(seed=seed)
    total = 0.0
    for k in range(steps):
        obs, reward, terminated, truncated, _ = env.step(policy(k * env.step_duration, obs))
        total += reward
        if terminated or truncated:
            break
    return total


def test_a_travelling_wave_swims_faster_than_random_actions():
    env = SwimmingEnv(episode_steps=250)
    rng = np.random.default_rng(0)
    random = _episode_return(env, lambda t, o: rng.uniform(-1.0, 1.0, 8), 250, seed=0)
    wave = _episode_return(env, lambda t, o: _wave(t, 0.6, 1.0, np.pi / 4), 250, seed=0)
    assert wave > random + 50.0  # 10 s: over 0.2 m/s faster on average


def test_surging_straight_follows_the_path_better_than_random_actions():
    env = PathFollowingEnv(episode_steps=250)
    rng = np.random.default_rng(0)
    straight = np.zeros(9)
    straight[8] = 0.5  # half the surge thrust, joints straight
    random = _episode_return(env, lambda t, o: rng.uniform(-1.0, 1.0, 9), 250, seed=0)
    scripted = _episode_return(env, lambda t, o: straight, 250, seed=0)
    assert scripted > random


def test_random_search_on_the_vector_environment_improves_the_return():
    """(1+8) random search over (amplitude, frequency, lag), 8 candidates evaluated in one vector
    environment per generation: 4 generations of 8 x 75 steps (2400 steps in all)."""
    n, steps = 8, 75
    vector = VehicleVectorEnv(SwimmingEnv, n, episode_steps=steps)
    rng = np.random.default_rng(3)

    def returns(parameters: np.ndarray) -> np.ndarray:
        vector.reset(seed=0)
        total, alive = np.zeros(n), np.ones(n, dtype=bool)
        for k in range(steps):
            t = k * vector.task.step_duration
            actions = np.array([_wave(t, *p) for p in parameters])
            _, reward, terminated, truncated, _ = vector.step(np.clip(actions, -1.0, 1.0))
            total += np.where(alive, reward, 0.0)  # an episode's return, not its successor's
            alive &= ~(terminated | truncated)
        return total

    best = np.array([0.3, 0.5, 0.0])  # a standing wave: it does not swim
    best_return = returns(np.tile(best, (n, 1)))[0]
    start = best_return
    for _ in range(3):
        candidates = best + rng.normal(0.0, [0.2, 0.3, 0.6], (n, 3))
        candidates[:, 0] = np.clip(candidates[:, 0], 0.05, 1.0)
        candidates[:, 1] = np.clip(candidates[:, 1], 0.1, 2.0)
        scores = returns(candidates)
        if scores.max() > best_return:
            best, best_return = candidates[scores.argmax()], scores.max()
    vector.close()
    assert best_return > start + 1.0


def test_steering_the_base_angles_towards_the_path_beats_surging_straight():
    """A proportional law on the base angle about z (``steering="base_angles"``): against the
    cross-track error ``e_y`` and the end-effector's heading ``x_e . y``, half the surge thrust."""
    env = PathFollowingEnv(steering="base_angles", episode_steps=500)
    assert env.action_space.shape == (3,)

    def steer(t, o):
        return np.array([0.0, np.clip(-(0.5 * o[0] + 2.0 * o[3]), -1.0, 1.0), 0.5])

    straight = _episode_return(env, lambda t, o: np.array([0.0, 0.0, 0.5]), 500, seed=0)
    steered = _episode_return(env, steer, 500, seed=0)
    assert steered > straight + 100.0
    assert np.linalg.norm(env.cross_track()[0]) < 1.0  # [m], after 20 s
