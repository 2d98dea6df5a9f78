"""A real two-node Ray cluster (``ray.cluster_utils.Cluster``: a head and one more node, both on 127.0.0.1):
diagnose gives the report of the local pool (also with a user's plugin effect), a small study sweep gives the
serial numbers, and a task whose worker is killed mid-task is retried on the cluster."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import pytest

from ray_helpers import (OBJECT_STORE_BYTES, PLUGIN, ROOT, attempts, by_value, kill_when_started, ray_daemons,
                         ray_env, ray_session, recorded_square, report_without_timing)

ray = pytest.importorskip("ray")

from triplanar.executor import run_tasks
from triplanar.ray_executor import RayExecutor

# One Ray at a time under pytest-xdist. Long (`make test-slow`): a two-node cluster is separate Ray daemons started
# for the module, and diagnose runs three times in its own process (locally, on a Ray of its own, on the cluster);
# `make test` keeps the Ray backend on a local Ray (test_ray_executor.py).
pytestmark = [pytest.mark.slow, pytest.mark.long, pytest.mark.xdist_group("ray")]
DATA = ROOT / "data" / "lab_traces.csv"


@pytest.fixture(scope="module")
def cluster():
    from ray.cluster_utils import Cluster
    by_value("ray_helpers")
    node = {"num_cpus": 1, "object_store_memory": OBJECT_STORE_BYTES}
    two_nodes = Cluster(initialize_head=True, head_node_args={**node, "include_dashboard": False})
    try:
        two_nodes.add_node(**node)
        two_nodes.wait_for_nodes()
        ray.init(address=two_nodes.address, log_to_driver=False)
        yield two_nodes
    finally:
        ray.shutdown()
        two_nodes.shutdown()


def test_both_nodes_listen_on_the_loopback_address_only(cluster) -> None:
    nodes = [n for n in ray.nodes() if n["Alive"]]
    assert len(nodes) == 2 and {n["NodeManagerAddress"] for n in nodes} == {"127.0.0.1"}


def test_a_killed_worker_is_retried_on_the_cluster(cluster, tmp_path) -> None:
    jobs = [(x, str(tmp_path), 1) for x in range(4)]
    killer = kill_when_started(tmp_path, 1)
    assert run_tasks(recorded_square, jobs, RayExecutor()) == [0, 1, 4, 9]
    killer.join(1)
    assert len(attempts(tmp_path, 1)) == 2
    nodes = {p.read_text() for x in range(4) for p in attempts(tmp_path, x)}
    assert len(nodes) == 2  # the sweep ran on both nodes


def diagnose(out, *options: str) -> list[str]:
    return [sys.executable, "-m", "triplanar.cli", "diagnose", str(DATA), "--out", str(out), "--no-progress",
            "--folds", "2", "--no-plots", *options]


def test_diagnose_reports_are_the_same_locally_on_a_local_ray_and_on_the_cluster(cluster, tmp_path) -> None:
    """diagnose gives one report on the local pool, a local Ray and the cluster, with a user's plugin effect as a
    candidate (it must reach the workers)."""
    plugin = tmp_path / "my_tip.py"
    plugin.write_text(PLUGIN)
    options = ("--plugin", str(plugin), "--candidates", "plugin_tip,tip_offset")
    runs = {"local": ("--executor", "local"), "ray": ("--executor", "ray"),
            "cluster": ("--executor", "ray", "--ray-address", cluster.address)}
    env = ray_env()
    env.pop("RAY_ADDRESS", None)
    reports = {}
    daemons = ray_daemons()  # the cluster's
    for name, backend in runs.items():
        done = subprocess.run(diagnose(tmp_path / name, *options, *backend), cwd=ROOT, env=env,
                              capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr
        reports[name] = report_without_timing(tmp_path / name / "diagnose.json")
        if name == "ray":  # no address: a Ray of its own, started for the command and shut down after it
            assert "Started a local Ray instance" in done.stderr
            # its daemons exit a moment after the command (once in CI, with every core busy, more than 10 s later)
            deadline = time.time() + 60
            while ray_daemons() - daemons and time.time() < deadline:
                time.sleep(0.2)
            assert not ray_daemons() - daemons
    assert reports["local"]["missing_effect"] == "plugin_tip"  # end friction under the plugin's name
    assert reports["ray"] == reports["local"]
    assert reports["cluster"] == reports["local"]
    assert json.loads((tmp_path / "cluster" / "diagnose.json").read_text())["seconds"] > 0


def test_a_small_study_sweep_gives_the_serial_numbers_on_the_cluster(cluster) -> None:
    pytest.importorskip("stable_baselines3")
    from experiments.study import EvalTask, run_evaluation, scripted_controllers
    tasks = [EvalTask(c, (30.3, 45.0), 0, {}) for c in scripted_controllers()[:2]]
    here = [e for batch in run_tasks(run_evaluation, tasks, "serial") for e in batch]
    there = [e for batch in run_tasks(run_evaluation, tasks, RayExecutor()) for e in batch]
    assert len(here) == 4
    key = [(r.controller, r.load_N, r.mimicry_error_mm, r.reason, r.travel_m, r.steps) for r in here]
    assert [(r.controller, r.load_N, r.mimicry_error_mm, r.reason, r.travel_m, r.steps) for r in there] == key


def test_ray_address_from_the_environment_joins_the_cluster(cluster, tmp_path) -> None:
    env = dict(ray_env(), RAY_ADDRESS=cluster.address)
    session = ray_session(cluster.address)
    daemons = ray_daemons(session)
    assert len(daemons) == 3  # the head's gcs_server and raylet, the second node's raylet
    cmd = [sys.executable, "-m", "triplanar.cli", "lab-data", "--out", str(tmp_path / "d.csv"), "--loads", "30.3",
           "--repeats", "1", "--no-progress", "--executor", "ray"]
    done = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert f"Connecting to existing Ray cluster at address: {cluster.address}" in done.stderr
    # Joined, started no Ray of its own (Ray says so when it does; the diagnose test sees that line) and no node in the
    # cluster, and left the cluster running. The cluster's daemons only, by its session: other Rays' daemons come and
    # go on the machine meanwhile (an earlier test's local Ray still exiting broke a machine-wide count in CI).
    assert "Started a local Ray instance" not in done.stderr
    assert (tmp_path / "d.csv").exists() and ray_daemons(session) == daemons
    assert len([n for n in ray.nodes() if n["Alive"]]) == 2
