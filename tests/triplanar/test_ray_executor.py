"""The Ray backend on a local Ray (``ray.init(num_cpus=2)``, loopback only): order, retries after a killed worker,
resume from the per-task checkpoint, plugins on the workers, the CLI flags."""

from __future__ import annotations

from pathlib import Path

import pytest

from ray_helpers import OBJECT_STORE_BYTES, PLUGIN, attempts, by_value, kill_when_started, recorded_square

ray = pytest.importorskip("ray")

from triplanar.executor import TaskCheckpoint, run_tasks
from triplanar.ray_executor import RayExecutor

# A Ray takes seconds to start, and most tests run commands on it; one Ray at a time under pytest-xdist.
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("ray")]


@pytest.fixture(scope="module")
def local_ray():
    by_value("ray_helpers")
    by_value(__name__)
    # "local": a new Ray even when a file of another (or of a dead one: /tmp/ray/ray_current_cluster) is on this
    # machine; plain init() would try to join it (seen 2026-11-28: a leftover file made every test here an error)
    ray.init(address="local", num_cpus=2, object_store_memory=OBJECT_STORE_BYTES, include_dashboard=False,
             _node_ip_address="127.0.0.1", log_to_driver=False)
    try:
        yield RayExecutor()  # uses the Ray above, leaves it running
    finally:
        ray.shutdown()


def flaky_square(job: tuple[int, str]) -> int:
    """x * x, logging each call; task 3 fails until ``allow`` exists, after the other four tasks' checkpoints are
    written (it waits for them rather than for a fixed time, which a loaded machine overran: up to 120 s)."""
    import time
    x, folder = job
    with open(Path(folder) / "calls.txt", "a") as f:
        f.write(f"{x}\n")
    if x == 3 and not (Path(folder) / "allow").exists():
        deadline = time.monotonic() + 120.0
        while len(list((Path(folder) / "partial").glob("*.npz"))) < 4 and time.monotonic() < deadline:
            time.sleep(0.05)
        raise RuntimeError("interrupted")
    return x * x


def effect_seen_by_worker(effect) -> tuple[str, bool]:
    from triplanar.effects import REGISTRY
    return type(effect).__module__, effect.name in REGISTRY


def test_results_come_back_in_task_order_and_a_killed_worker_is_retried(local_ray, tmp_path) -> None:
    jobs = [(x, str(tmp_path), 2) for x in range(6)]
    killer = kill_when_started(tmp_path, 2)
    assert run_tasks(recorded_square, jobs, local_ray) == [x * x for x in range(6)]
    killer.join(1)
    runs = attempts(tmp_path, 2)
    assert len(runs) == 2 and runs[0].name != runs[1].name  # killed once, run again by another worker process
    assert all(len(attempts(tmp_path, x)) == 1 for x in (0, 1, 3, 4, 5))


def test_an_interrupted_sweep_resumes_without_redoing_finished_tasks(local_ray, tmp_path) -> None:
    checkpoint = TaskCheckpoint(tmp_path / "partial")
    jobs = [(x, str(tmp_path)) for x in range(5)]
    with pytest.raises(RuntimeError, match="interrupted"):
        run_tasks(flaky_square, jobs, local_ray, checkpoint=checkpoint)
    assert len(list((tmp_path / "partial").glob("*.npz"))) == 4
    (tmp_path / "allow").touch()
    assert run_tasks(flaky_square, jobs, local_ray, checkpoint=checkpoint) == [0, 1, 4, 9, 16]
    calls = [int(x) for x in (tmp_path / "calls.txt").read_text().split()]
    assert sorted(calls) == [0, 1, 2, 3, 3, 4]  # only the unfinished task ran again


def test_plugin_effects_reach_the_workers(local_ray, tmp_path) -> None:
    import sys

    from triplanar.effects import REGISTRY, make_effect
    from triplanar.plugins import import_plugins
    plugin = tmp_path / "my_tip.py"
    plugin.write_text(PLUGIN)
    import_plugins([str(plugin)])
    try:
        effect = make_effect("plugin_tip:phi_deg=8")
        with pytest.raises(ModuleNotFoundError, match="triplanar_plugin_my_tip"):  # a worker without the plugin
            run_tasks(effect_seen_by_worker, [effect], RayExecutor())
        shipped = RayExecutor(plugins=[str(plugin)])
        assert run_tasks(effect_seen_by_worker, [effect, effect], shipped) == [("triplanar_plugin_my_tip", True)] * 2
    finally:  # the registry is global: later tests must not see the plugin's effect
        REGISTRY.pop("plugin_tip", None)
        sys.modules.pop("triplanar_plugin_my_tip", None)


def test_lab_data_is_the_same_file_serial_and_on_ray(local_ray, tmp_path) -> None:
    from triplanar.cli import main
    outputs = {}
    for executor in ("serial", "ray"):
        out = tmp_path / f"{executor}.csv"
        assert main(["lab-data", "--out", str(out), "--loads", "30.3,45", "--repeats", "2", "--no-progress",
                     "--executor", executor]) == 0
        outputs[executor] = (out.read_bytes(), Path(f"{out}.truth.json").read_text().replace(out.name, "X"))
    assert outputs["serial"] == outputs["ray"]


def test_paper_simulations_are_the_same_on_ray(local_ray) -> None:
    from triplanar.paper import cases
    sim = cases.Simulator(*__import__("triplanar.specimen", fromlist=["reference"]).reference())
    runs = cases.reference_runs([30.3, 45.0])[:4]
    here = [sim.simulate_run(r) for r in runs]
    there = run_tasks(sim.simulate_run, runs, local_ray)
    for a, b in zip(here, there):
        assert (a.t == b.t).all() and (a.y == b.y).all() and a.status == b.status


def test_ray_address_without_the_ray_executor_is_refused(capsys) -> None:
    from triplanar.cli import main
    code = main(["lab-data", "--out", "x.csv", "--ray-address", "127.0.0.1:1", "--executor", "serial"])
    assert code == 2 and "--ray-address 127.0.0.1:1: give --executor ray" in capsys.readouterr().err


def test_fit_gives_the_same_result_serial_and_on_ray(local_ray, tmp_path) -> None:
    """The laboratory dataset's first repeat at three loads (the whole 48 tests cost 8 s of the Ray workers' CPU and
    test nothing more), fitted by the same command serially and on Ray: the same ``fit.json``."""
    import json

    from triplanar.cli import main
    from triplanar.measurement import read_measurements, write_measurements
    tests = read_measurements(Path(__file__).resolve().parents[2] / "data" / "lab_traces.csv")
    data = tmp_path / "lab.csv"
    write_measurements(data, [t for t in tests if t.test_id in ("F27.8N-r1", "F40N-r1", "F55.6N-r1")])
    results = {}
    for executor in ("serial", "ray"):
        assert main(["fit", str(data), "--add", "end_friction", "--no-progress", "--out", str(tmp_path / executor),
                     "--executor", executor, "--no-plots"]) == 0
        results[executor] = json.loads((tmp_path / executor / "fit.json").read_text())
    assert results["serial"] == results["ray"]
    assert results["ray"]["steps"][-1]["added"] == "end_friction"
