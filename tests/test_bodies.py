"""SIMPLE player bodies: servo, limits, base, kinematics (docs/reference.md §5)."""

import mujoco
import numpy as np
import pytest

from rallysim.core.bodies import SimpleBodies, player_geometry
from rallysim.core.game import Game


def drive(b: SimpleBodies, action, steps: int):
    """Physics steps of ``b`` (in a game: the compiled steps move the bodies) under
    ``action``; each step's arm angles and rates."""
    game = b.__dict__.setdefault("_game", Game(b.n_envs, b.n_players, bodies=b))
    a = np.broadcast_to(np.asarray(action, float), (b.n_envs, b.n_players, 3))
    b.set_actions(a)
    thetas, omegas = [], []
    for _ in range(steps):
        game._physics_step()
        thetas.append(b.theta.copy())
        omegas.append(b.omega.copy())
    return np.array(thetas), np.array(omegas)


def test_arm_geometry_from_mjcf():
    g = player_geometry()
    assert g["pivot_z"] == pytest.approx(0.65)
    assert g["face_offset"] == pytest.approx(1.06)
    assert g["inertia"] == pytest.approx(0.022, abs=0.001)
    assert np.degrees(g["limit"]) == pytest.approx(85.0)


def test_full_force_swing_is_rate_limited_and_reaches_target():
    b = SimpleBodies(1, 1)
    b.reset(np.array([0]), np.array([[-3.0]]), theta=-np.radians(85))
    th, om = drive(b, [1.0, 1.0, 0.0], 40)
    assert np.abs(om).max() <= 7.0 + 1e-9
    assert np.abs(om).max() == pytest.approx(7.0)
    # 170 degrees at 7 rad/s takes 0.424 s: 22 physics steps, then it holds the target
    assert th[-1, 0, 0] == pytest.approx(np.radians(85), abs=1e-9)
    assert th[19, 0, 0] < np.radians(85) - 0.1
    assert np.abs(th).max() <= np.radians(85) + 1e-12


def test_weak_drive_overshoot_stops_at_the_joint_limit():
    b = SimpleBodies(1, 1)
    b.reset(np.array([0]), np.array([[-3.0]]), theta=0.0)
    drive(b, [1.0, 1.0, 0.0], 3)  # swing at full speed toward +85 ...
    b.theta[:] = np.radians(75)
    th, _ = drive(b, [1.0, -0.95, 0.0], 30)  # ... then too weak to brake in time
    assert np.abs(th).max() == pytest.approx(np.radians(85))
    assert np.abs(th).max() <= np.radians(85) + 1e-12


def test_zero_force_gives_no_torque():
    b = SimpleBodies(1, 1)
    b.reset(np.array([0]), np.array([[-3.0]]), theta=0.3)
    th, om = drive(b, [-1.0, -1.0, 0.0], 20)
    assert np.all(b.torque == 0.0)
    # only round-off of the gravity compensation remains
    assert np.abs(th - 0.3).max() < 1e-12 and np.abs(om).max() < 1e-12


def test_torque_limit_bounds_acceleration():
    b = SimpleBodies(1, 1)
    b.reset(np.array([0]), np.array([[-3.0]]), theta=-1.0)
    _, om = drive(b, [1.0, 0.0, 0.0], 1)  # 7.5 N m
    assert om[0, 0, 0] == pytest.approx(7.5 * 0.02 / b.inertia, rel=1e-9)


def test_base_speed_and_range():
    b = SimpleBodies(1, 2)
    b.reset(np.array([0]), np.array([[-3.0, -3.0]]))
    drive(b, [0.0, 0.0, 1.0], 5)
    assert b.base_x[0] == pytest.approx([-2.5, -2.5])  # 5 m/s for 0.1 s, own frame
    drive(b, [0.0, 0.0, 1.0], 50)
    assert b.base_x[0] == pytest.approx([-1.0, -1.0])
    drive(b, [0.0, 0.0, -1.0], 200)
    assert b.base_x[0] == pytest.approx([-6.5, -6.5])
    # player 1 stands mirrored on the far side
    assert b.mocap[0, 0, 0] == pytest.approx(-6.5) and b.mocap[0, 1, 0] == pytest.approx(6.5)


def test_face_kinematics_match_mujoco_for_both_players():
    b = SimpleBodies(2, 2)
    b.reset(np.array([0, 1]), np.array([[-2.0, -4.0], [-1.5, -6.0]]),
            theta=np.array([[0.3, -0.7], [1.2, -1.4]]))
    mujoco.mj_kinematics(b.model, b.data)
    site = b.data.site_xpos.reshape(2, 2, 3)
    own = b.face_centre()
    world = own * np.array([1.0, 1.0, 1.0])
    world[..., 0] *= b.forward
    world[..., 1] *= b.forward
    assert np.abs(site - world).max() < 1e-12
