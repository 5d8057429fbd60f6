"""``AimedSwing``, the scripted HUMAN-LIKE player that hits with the commanded racket velocity:
its swing model against the simulator, its reading of the arm, its aim and its tolerance."""

from __future__ import annotations

import numpy as np
import pytest

from rallysim.core.humanlike import HumanLikeBodies
from rallysim.envs.humanlike_return_v0 import HumanLikeReturnVectorEnv
from rallysim.policies.aimed_swing import (
    FORWARD_SWING,
    RAISE_TARGET,
    AimedSwing,
    ArmSwing,
    arm_state,
)


def play_return(policy, n=64, seed=3):
    """Hit, angle error (deg) and signed speed error of each of ``n`` seeded serves."""
    env = HumanLikeReturnVectorEnv(n, seed=seed)
    obs, _ = env.reset(seed=seed)
    done = np.zeros(n, bool)
    hit = np.zeros(n, bool)
    angle, speed = np.full(n, np.nan), np.full(n, np.nan)
    for _ in range(60):
        obs, _, term, trunc, info = env.step(policy(obs))
        new = info["hit"] & ~done
        hit |= new
        angle[new], speed[new] = info["angle_error"][new], info["speed_error"][new]
        done |= term | trunc
        if done.all():
            break
    return hit, angle, speed


def test_arm_swing_model_replays_the_simulator():
    """Accelerating then coasting, the simulated raise follows ``ArmSwing.angles`` to rounding:
    the servo saturates at exactly the strength and the arm turns as one body."""
    arm = ArmSwing()
    bodies = HumanLikeBodies(3)
    held = np.array([-0.4, -0.2, 0.0])
    accelerate, coast = np.array([14.0, 19.0, 24.0]), np.array([8.7, 9.3, 9.5])
    pose = np.zeros((3, 1, 8))
    pose[:, 0, 2], pose[:, 0, 3] = held, FORWARD_SWING
    bodies.reset(np.arange(3), np.full((3, 1), -3.0), pose=pose)
    actions = np.ones((3, 1, 15))
    actions[..., 2:10] = 2.0 * (pose - bodies.lo) / (bodies.hi - bodies.lo) - 1.0
    actions[..., RAISE_TARGET] = 1.0  # the top of the range: the servo pushes with its limit
    got = [bodies.qpos[:, 0, 2].copy()]
    for i in range(10):
        actions[:, 0, 12] = 2.0 * (accelerate if i < 5 else coast) / 60.0 - 1.0
        bodies.set_actions(actions)
        bodies.physics_step()
        got.append(bodies.qpos[:, 0, 2].copy())
    want = arm.angles(held, np.zeros(3), accelerate, coast, 10)
    np.testing.assert_allclose(np.array(got).T, want, atol=1e-9)
    assert np.all(np.diff(want[:, 6:], axis=1) > 0.02)  # it did swing (> 1 rad/s)
    # the other joints held still: spine, chest, forward swing, twist, elbow, wrist
    np.testing.assert_allclose(bodies.qpos[:, 0, [0, 1, 4, 5, 6, 7]], 0.0, atol=1e-9)


def test_arm_state_reads_the_raise_from_observations():
    env = HumanLikeReturnVectorEnv(16, seed=1)
    obs, _ = env.reset(seed=1)
    swing, bodies = AimedSwing(), env.task.game.bodies
    moving = 0
    for _ in range(20):
        obs, *_ = env.step(swing(obs))
        theta, rate = arm_state(obs)
        np.testing.assert_allclose(theta, bodies.qpos[:, 0, 2], atol=1e-6)
        np.testing.assert_allclose(rate, bodies.qvel[:, 0, 2], atol=1e-5)
        moving += int((np.abs(rate) > 1.0).sum())
    assert moving >= 16  # swings were read, not only poses at rest


def test_aimed_swing_meets_the_velocity_targets():
    hit, angle, speed = play_return(AimedSwing())
    assert hit.mean() >= 0.98  # issue 5's targets: >= 90 %, <= 5 deg, <= 10 %
    assert np.nanmean(angle) < 0.5
    assert np.nanmean(np.abs(speed)) < 0.01


def test_aimed_swing_follows_a_commanded_target():
    """Reset options set the target; the racket at the hit matches it."""
    env = HumanLikeReturnVectorEnv(8, seed=5)
    target = np.array([2.0, -1.0, 2.5])
    obs, _ = env.reset(seed=5, options={"target_velocity": target})
    swing = AimedSwing()
    got = np.full((8, 3), np.nan)
    for _ in range(40):
        obs, _, _, _, info = env.step(swing(obs))
        got[info["hit"]] = info["racket_velocity"][info["hit"]]
    assert np.allclose(got, target, atol=0.02)


@pytest.mark.slow
def test_a_meeting_a_step_off_still_hits_near_the_target():
    """Holding the arm 3 deg higher or lower moves the meeting into the coasting decision's
    step before or after the planned one; the coasting arm still hits at nearly the target
    velocity (measured 2.0 deg, 1.2 % over 64 serves; a wrist flick met a step off was 50 %
    too fast or too slow)."""
    swing = AimedSwing()
    for offset in np.radians([-3.0, 3.0]) / (np.pi / 2):  # in action units
        def shifted(obs, offset=offset):
            actions = swing(obs)
            plan = swing.last_plan
            holding = plan["found"] & (plan["decisions"] >= 2)
            actions[holding, RAISE_TARGET] += offset
            return actions

        hit, angle, speed = play_return(shifted)
        assert hit.mean() >= 0.98
        assert 1.0 < np.nanmean(angle) < 3.0  # moved off the plan, yet near the target
        assert np.nanmean(np.abs(speed)) < 0.03


def test_noisy_actions_keep_the_aim_near_the_target():
    """Gaussian noise (sigma 0.01, correlated over decisions like a clone's errors) on every
    action: the swing's strength is steered from the arm's observed state (measured 1.6 deg)."""
    swing = AimedSwing()
    rng = np.random.default_rng(2)
    state = np.zeros((64, 15))

    def noisy(obs):
        state[:] = 0.8 * state + 0.6 * rng.normal(0.0, 0.01, state.shape)
        return np.clip(swing(obs) + state, -1.0, 1.0)

    hit, angle, speed = play_return(noisy)
    assert hit.mean() >= 0.98
    assert np.nanmean(angle) < 3.0
    assert np.nanmean(np.abs(speed)) < 0.03
