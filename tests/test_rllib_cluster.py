"""A real Ray cluster: a head and a second node started with ``ray start`` on loopback, the
low-level stage trained across both through ``rallysim train --backend rllib --address``.

About a minute on two cores. Each node offers one CPU and each env runner takes one, so Ray
must place one env runner on each node. The nodes run in a process group of their own that
the test ends by its id (no machine-wide ``ray stop``, which would end other users' Ray too).
The training runs through the ``rallysim`` command in a process of its own, like a user's.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("ray")
pytest.importorskip("torch")

pytestmark = [pytest.mark.cluster, pytest.mark.slow]
RAY = str(Path(sys.executable).with_name("ray"))
# Budget and settings measured to rise reliably: the last iterations' mean episode reward is
# 0.5-0.75 against 0.02-0.05 at the start (a random policy rarely hits the serve).
DECISIONS = 100_000
SETTINGS = ["ppo.n_envs=32", "ppo.n_steps=64", "ppo.batch_size=512", "ppo.anneal_lr=false",
            "eval.episodes=200", "checkpoint_every=1000000"]


def free_ports(n: int) -> list[int]:
    socks = [socket.socket() for _ in range(n)]
    for s in socks:
        s.bind(("127.0.0.1", 0))
    ports = [s.getsockname()[1] for s in socks]
    for s in socks:
        s.close()
    return ports


def start_node(args: list[str], log: Path, env: dict[str, str]) -> subprocess.Popen:
    """``ray start ... --block`` in a new session: its id is the group of all its processes."""
    with log.open("w") as out:
        return subprocess.Popen([RAY, "start", "--block", "--disable-usage-stats",
                                 "--node-ip-address=127.0.0.1", *args],
                                stdout=out, stderr=subprocess.STDOUT, env=env,
                                start_new_session=True)


def wait_for_nodes(address: str, n: int, env: dict[str, str], timeout: float = 90.0
                   ) -> list[str]:
    """The ids of the cluster's nodes once ``n`` are alive, asked by a driver of its own."""
    code = ("import sys, time, ray\n"
            "ray.init(address=sys.argv[1], logging_level='ERROR', log_to_driver=False)\n"
            "deadline = time.monotonic() + float(sys.argv[3])\n"
            "while time.monotonic() < deadline:\n"
            "    alive = [n['NodeID'] for n in ray.nodes() if n['Alive']]\n"
            "    if len(alive) >= int(sys.argv[2]):\n"
            "        print(' '.join(alive)); break\n"
            "    time.sleep(0.5)\n")
    out = subprocess.run([sys.executable, "-c", code, address, str(n), str(timeout)],
                         capture_output=True, text=True, env=env, timeout=timeout + 60)
    ids = out.stdout.split()
    assert len(ids) >= n, f"the cluster at {address} did not reach {n} nodes: {out.stderr}"
    return ids


def stop_group(proc: subprocess.Popen) -> None:
    for sig, wait in ((signal.SIGTERM, 15), (signal.SIGKILL, 5)):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            return
        try:
            proc.wait(wait)
        except subprocess.TimeoutExpired:
            continue
        # the group may outlive its leader for a moment
        time.sleep(1.0)


@pytest.fixture
def two_node_cluster(monkeypatch):
    # A loopback test cluster needs no shared token: turn Ray's token auth off for the nodes
    # and this driver alike.
    monkeypatch.setenv("RAY_AUTH_MODE", "disabled")
    monkeypatch.setenv("RAY_USAGE_STATS_ENABLED", "0")
    env = dict(os.environ)
    temp = Path(tempfile.mkdtemp(prefix="rsray", dir="/tmp"))  # short: Ray's socket paths
    gcs, client, *agent = free_ports(6)
    address = f"127.0.0.1:{gcs}"
    nodes: list[subprocess.Popen] = []
    try:
        nodes.append(start_node(
            ["--head", f"--port={gcs}", "--num-cpus=1", f"--temp-dir={temp}",
             "--include-dashboard=false",
             f"--ray-client-server-port={client}", f"--dashboard-agent-listen-port={agent[0]}",
             f"--metrics-export-port={agent[1]}"], temp / "head.log", env))
        time.sleep(3.0)
        nodes.append(start_node(
            [f"--address={address}", "--num-cpus=1",
             f"--dashboard-agent-listen-port={agent[2]}", f"--metrics-export-port={agent[3]}"],
            temp / "worker.log", env))
        node_ids = wait_for_nodes(address, 2, env)
        yield address, node_ids, env
    finally:
        for proc in reversed(nodes):
            stop_group(proc)
        shutil.rmtree(temp, ignore_errors=True)


def test_low_level_trains_across_two_nodes(two_node_cluster, tmp_path):
    address, node_ids, env = two_node_cluster
    out = tmp_path / "low"
    # The CLI in a process of its own, as a user runs it: a Ray driver connects once per
    # process (this one may already have run a local Ray for other tests).
    run = subprocess.run(
        [str(Path(sys.executable).with_name("rallysim")), "train", "low", "--backend", "rllib",
         "--address", address, "--env-runners", "2", "--budget", str(DECISIONS),
         "--seed", "0", "--out", str(out), "--quiet", "--set", *SETTINGS],
        capture_output=True, text=True, env=env, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    curve = json.loads((out / "curve.json").read_text())

    # (a) one env runner on each node of the cluster
    assert sorted(curve["cluster_nodes"]) == sorted(node_ids)
    assert sorted(curve["env_runner_nodes"]) == sorted(node_ids)

    # (b) the low-level reward rises over the budget
    rewards = [row["ep_rew_mean"] for row in curve["iterations"]]
    first, last = float(np.mean(rewards[:3])), float(np.mean(rewards[-3:]))
    print(f"episode reward, first 3 iterations {first:.3f} -> last 3 {last:.3f}; "
          f"final evaluation {curve['final']['mean_reward']:.3f}, hit rate "
          f"{curve['final']['hit_rate']:.3f}; {curve['steps_per_s']:.0f} decisions/s")
    assert curve["steps"] >= DECISIONS
    assert last > first + 0.25
    assert curve["final"]["hit_rate"] > 0.5  # deterministic policy: most serves are hit
