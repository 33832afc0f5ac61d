"""Sweeps (closed_loop/sweep.py, sweep_spec.py, `manip sweep`): spec errors, reproducibility, failures, sockets.

* a bad spec is one line naming the file and the key, exit status 2, nothing written;
* the table of 1 worker and of 2 workers is the same, byte for byte (CSV) and value for value;
* the local process pool opens no socket at all, starts its workers and leaves none behind; a pool worker
  killed mid-sweep loses no case and counts none twice;
* on a real scheduler with two worker processes started here, a worker killed mid-sweep loses no case
  and counts none twice; an interrupted sweep resumes from the cases it wrote.
Cost: ~30 s on an idle machine, ~70 s at a load of 7 on its 2 cores (three small clusters start, each worker
imports python-control; the kernel is built once per session).
"""

from __future__ import annotations

import ipaddress
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from closed_loop.sweep import PARTS_DIR, run_cases, run_sweep
from closed_loop.sweep_spec import SweepSpecError, case_values, load_spec, spec_from_dict
from model.limits import MAX_SPEC_BYTES, MAX_SWEEP_CASES

from tests.support.process_tree import alive, interruptible, listening_ports, marked_env

BASE = {"robot": "scara", "controller": "ct", "samples": 24, "seed": 3, "method": "random", "bound": 0.0015,
        "batch": 3, "vary": {"payload_mass": [0.0, 3.0], "friction_scale": [0.5, 2.0], "link_mass_scale": [0.8, 1.2]}}


def _spec(**changes):
    data = {**BASE, **changes}
    return spec_from_dict(data, "test.toml")


# ------------------------------------------------------------------ spec errors
@pytest.mark.parametrize("changes, match", [
    ({"vary": {"payload_mas": [0, 1]}}, r"test.toml: vary.payload_mas: unknown quantity"),
    ({"vary": {"payload_mass": [2.0, 2.0]}}, r"test.toml: vary.payload_mass: empty range \[2, 2\]"),
    ({"vary": {"payload_mass": [3.0, 1.0]}}, r"empty range"),
    ({"vary": {"payload_mass": [-1.0, 1.0]}}, r"vary.payload_mass: expected values >= 0 kg"),
    ({"vary": {"link_mass_scale": [0.0, 1.0]}}, r"vary.link_mass_scale: expected values > 0"),
    ({"vary": {"payload_mass": [0, "x"]}}, r"vary.payload_mass: expected \[low, high\]"),
    ({"vary": {}}, r"test.toml: vary: expected a table"),
    ({"samples": 0}, r"test.toml: samples: expected a whole number >= 1, got 0"),
    ({"method": "grid", "samples": 1000}, r"samples: 1,000,000,000 cases \(1000 x 1000 x 1000\) exceed the sweep "
                                          r"limit of 1,000,000 cases"),
    ({"method": "latin"}, r"method: expected one of grid, random, sobol"),
    ({"controller": "lqr"}, r"controller: expected one of"),
    ({"sample": 10}, r"test.toml: sample: unknown key"),
])
def test_bad_specs_are_refused_naming_the_file_and_key(changes, match):
    with pytest.raises(SweepSpecError, match=match):
        _spec(**changes)


def test_spec_limits_and_friction_joint_are_checked(tmp_path):
    big = tmp_path / "big.toml"
    big.write_text("# " + "x" * MAX_SPEC_BYTES + "\n")
    with pytest.raises(SweepSpecError, match=rf"big.toml: .* larger than the sweep spec size limit of {MAX_SPEC_BYTES}"):
        load_spec(big)
    with pytest.raises(SweepSpecError, match="vary.friction_scale_5: unknown quantity"):
        spec_from_dict({**BASE, "vary": {"friction_scale_5": [0.5, 1.0]}}, "test.toml", n_joints=4)
    assert MAX_SWEEP_CASES >= 10_000


def test_manip_sweep_bad_spec_is_one_line_exit_2_and_writes_nothing(tmp_path):
    spec = tmp_path / "bad.toml"
    spec.write_text('robot = "scara"\nsamples = 10\n[vary]\nwind_speed = [0, 1]\n')
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "workbench.cli", "sweep", str(spec), "--out", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and str(spec) in lines[0] and "vary.wind_speed: unknown quantity" in lines[0], lines
    assert not out.exists()


# ------------------------------------------------------------------ cases and their values
def test_random_cases_are_seeded_per_case_and_grid_covers_every_combination():
    spec = _spec()
    all_values = case_values(spec)
    np.testing.assert_array_equal(case_values(spec, np.array([7, 2])), all_values[[7, 2]])
    np.testing.assert_array_equal(case_values(_spec(samples=48))[:24], all_values)  # independent of N
    assert not np.array_equal(case_values(_spec(seed=4)), all_values)
    grid = _spec(method="grid", samples=3, vary={"payload_mass": [0.0, 2.0], "delay": [0, 1]})
    v = case_values(grid)
    assert grid.n_cases == 6 and {tuple(r) for r in v.tolist()} == {(m, d) for m in (0.0, 1.0, 2.0) for d in (0.0, 1.0)}
    sobol = case_values(_spec(method="sobol", samples=16))
    assert sobol.shape == (16, 3) and np.all(sobol[:, 0] >= 0) and np.all(sobol[:, 0] <= 3)


# ------------------------------------------------------------------ the local process pool
def _tree_sockets(root: "psutil.Process") -> list:  # noqa: F821
    import psutil

    procs = [root]
    try:
        procs += root.children(recursive=True)
    except psutil.Error:
        pass
    found = []
    for p in procs:
        try:
            found += [(p.pid, c) for c in p.net_connections(kind="inet")]
        except psutil.Error:
            pass
    return found


@pytest.fixture(scope="module")
def one_worker(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep1")
    return run_sweep(_spec(), out, workers=1), out


@pytest.mark.cluster
def test_two_workers_equal_one_worker_bit_for_bit_and_open_no_socket(one_worker, tmp_path):
    import psutil

    ref, ref_out = one_worker
    me = psutil.Process()
    before = {c.laddr for c in me.net_connections(kind="inet") if c.status == psutil.CONN_LISTEN}
    seen, stop = [], threading.Event()
    pids: set[int] = set()

    def watch():
        while not stop.is_set():
            for pid, c in _tree_sockets(me):
                seen.append(c)
            pids.update(p.pid for p in me.children(recursive=True))
            time.sleep(0.05)

    watcher = threading.Thread(target=watch, daemon=True)
    watcher.start()
    try:
        two = run_sweep(_spec(), tmp_path, workers=2)
    finally:
        stop.set()
        watcher.join()
    assert two.workers == 2 and ref.workers == 1
    assert (tmp_path / "results.csv").read_bytes() == (ref_out / "results.csv").read_bytes()
    assert two.table.equals(ref.table)
    assert list(two.table["case"]) == list(range(24))
    # the rows are the kernel's for those cases, computed here in-process
    np.testing.assert_array_equal(two.table["max_error"].to_numpy(), run_cases(_spec(), np.arange(24))[:, 0])
    # two worker processes ran (the watcher saw them) and none opened a socket
    assert len(pids) >= 2, pids
    assert not seen, {c.laddr for c in seen}
    time.sleep(0.5)
    # no worker is left; multiprocessing's resource tracker (no sockets) lives as long as this process
    left = [p for p in me.children(recursive=True) if "multiprocessing.resource_tracker" not in " ".join(p.cmdline())]
    assert not left, [p.cmdline() for p in left]
    assert not _tree_sockets(me) or all(c.status != psutil.CONN_LISTEN for _, c in _tree_sockets(me))
    after = {c.laddr for c in me.net_connections(kind="inet") if c.status == psutil.CONN_LISTEN}
    assert after <= before
    # the outputs: table, summary with the exceedance probability, and the plots
    summary = json.loads((tmp_path / "summary.json").read_text())
    k = int(np.sum(ref.table["max_error"] > 0.0015))
    assert summary["bound"]["exceeded"] == k and summary["cases"] == 24
    assert summary["worst_case"]["max_error"] == ref.table["max_error"].max()
    for name in ("results.parquet", "hist_max_error.png", "scatter_max_error.png", "worst_case_tracking_error.png"):
        assert (tmp_path / name).stat().st_size > 0
    assert not (tmp_path / PARTS_DIR).exists()


# ------------------------------------------------------------------ a real scheduler and workers
@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """A Dask scheduler and two single-threaded worker processes on 127.0.0.1, started as a user would."""
    folder = tmp_path_factory.mktemp("dask")
    sched_file = folder / "scheduler.json"
    dask_cli = str(Path(sys.executable).parent / "dask")
    procs = [subprocess.Popen([dask_cli, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                               "--scheduler-file", str(sched_file)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        deadline = time.time() + 60
        while not sched_file.exists() and time.time() < deadline:
            time.sleep(0.2)
        address = json.loads(sched_file.read_text())["address"]
        workers = [subprocess.Popen([dask_cli, "worker", address, "--nthreads", "1", "--no-nanny", "--host", "127.0.0.1",
                                     "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                   for _ in range(2)]
        procs += workers
        from distributed import Client

        with Client(address) as client:
            client.wait_for_workers(2, timeout=60)
        yield address, workers
    finally:
        for p in reversed(procs):
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()


@pytest.mark.cluster
def test_an_interrupted_sweep_resumes_from_the_cases_it_wrote(cluster, one_worker, tmp_path):
    address, _ = cluster
    ref, _ = one_worker
    tasks = []

    def interrupt(n):
        tasks.append(n)
        if len(tasks) == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep(_spec(), tmp_path, scheduler=address, progress=interrupt)
    written = len(list((tmp_path / PARTS_DIR).glob("part-*.npz")))
    assert written >= 2 and not (tmp_path / "results.csv").exists()
    resumed = []
    result = run_sweep(_spec(), tmp_path, scheduler=address, resume=True, progress=resumed.append, plots=False)
    assert sum(resumed) == 24 - 3 * written  # only the cases not written before ran
    assert result.table.equals(ref.table)
    with pytest.raises(SweepSpecError, match="holds the cases of another spec"):
        (tmp_path / PARTS_DIR).mkdir()
        (tmp_path / PARTS_DIR / "spec.json").write_text(json.dumps({"digest": "other"}))
        run_sweep(_spec(), tmp_path, scheduler=address, resume=True, plots=False)


@pytest.mark.cluster
def test_a_worker_killed_mid_sweep_loses_no_case_and_counts_none_twice(cluster, tmp_path):
    address, workers = cluster
    spec = _spec(samples=120)  # 40 tasks of 3 cases: most are still to run when the first one reports
    counted = []

    def kill_first(n):
        counted.append(n)
        if len(counted) == 1:
            os.kill(workers[0].pid, signal.SIGKILL)

    result = run_sweep(spec, tmp_path, scheduler=address, progress=kill_first, plots=False)
    assert workers[0].wait(timeout=10) == -signal.SIGKILL
    assert len(counted) == 40 and sum(counted) == 120  # every task reported once
    assert list(result.table["case"]) == list(range(120))
    rows = run_cases(spec, np.arange(120))  # the same cases, in this process
    np.testing.assert_array_equal(result.table["max_error"].to_numpy(), rows[:, 0])
    np.testing.assert_array_equal(result.table["rms_error_quill"].to_numpy(), rows[:, 2 + 4 + 2])


def test_a_pool_worker_killed_mid_sweep_loses_no_case_and_counts_none_twice(tmp_path):
    import psutil

    spec = _spec(samples=120)  # 40 tasks of 3 cases: most are still to run when the first one reports
    counted, killed = [], []
    before = {p.pid for p in psutil.Process().children()}  # e.g. another test's scheduler and workers

    def kill_one(n):
        counted.append(n)
        if len(counted) == 1:
            workers = [p for p in psutil.Process().children() if p.pid not in before]
            assert workers, "no pool worker to kill"
            killed.append(workers[0].pid)
            os.kill(workers[0].pid, signal.SIGKILL)

    result = run_sweep(spec, tmp_path, workers=2, progress=kill_one, plots=False)
    assert killed and not psutil.pid_exists(killed[0]) or psutil.Process(killed[0]).status() == psutil.STATUS_ZOMBIE
    assert len(counted) == 40 and sum(counted) == 120  # every task reported once
    assert list(result.table["case"]) == list(range(120))
    rows = run_cases(spec, np.arange(120))  # the same cases, in this process
    np.testing.assert_array_equal(result.table["max_error"].to_numpy(), rows[:, 0])
    assert not [p for p in psutil.Process().children() if p.pid not in before]  # the pools are gone


def test_the_readme_spec_is_a_valid_spec():
    import re

    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover - Python 3.10
        import tomli as tomllib
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    block = re.search(r"```toml\n(.*?)```", readme, re.S)
    spec = spec_from_dict(tomllib.loads(block.group(1)), "README.md")
    assert spec.n_cases == 1000 and spec.quantities == ("payload_mass", "friction_scale", "link_mass_scale")


@pytest.mark.cluster
@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGKILL], ids=["ctrl-c", "kill-9"])
def test_a_stopped_manip_sweep_leaves_nothing_running_or_listening(tmp_path, stop):
    """Stopped mid-sweep, by Ctrl-C (exit status 130, one line) or killed outright (no ``finally`` runs: the
    workers notice their parent is gone): every process of its tree ends and no port stays open."""
    import psutil

    spec = tmp_path / "spec.toml"
    spec.write_text('robot = "scara"\ncontroller = "pd"\nsamples = 400\nbatch = 2\n[vary]\npayload_mass = [0, 3]\n')
    out, err_log = tmp_path / "out", tmp_path / "stderr.txt"
    env, mark = marked_env()  # every process of the command's tree, orphans included, carries the mark
    with open(err_log, "w") as fe:
        proc = subprocess.Popen([sys.executable, "-m", "workbench.cli", "sweep", str(spec), "--out", str(out),
                                 "--workers", "2", "--no-plots"], stdout=subprocess.DEVNULL, stderr=fe, text=True,
                                env=env, preexec_fn=interruptible)
        root = psutil.Process(proc.pid)
        pids, ports = {proc.pid}, set()
        workers_seen = 0
        deadline = time.monotonic() + 180
        started = False
        while not started and time.monotonic() < deadline and proc.poll() is None:
            started = "cases (" in err_log.read_text()  # the pool is up: one more look at its processes
            try:
                workers_seen = max(workers_seen, len(root.children(recursive=True)))
            except psutil.Error:
                pass
            for pid, c in _tree_sockets(root):
                pids.add(pid)
                if c.status == psutil.CONN_LISTEN:
                    ports.add(c.laddr.port)
                    assert ipaddress.ip_address(c.laddr.ip).is_loopback, c
            time.sleep(0.1)
        assert proc.poll() is None, err_log.read_text()  # still sweeping
        time.sleep(1.0)  # the workers are forked as the first tasks go out, after the "cases (" line
        workers_seen = max(workers_seen, len(root.children(recursive=True)))
        # negative control of the final check: the mark finds the command's tree (it and two workers) now
        assert proc.pid in alive(mark) and len(alive(mark)) >= 3, alive(mark)
        proc.send_signal(stop)
        proc.wait(timeout=60)
    err = err_log.read_text()
    if stop == signal.SIGINT:
        assert proc.returncode == 130, err
        assert err.strip().splitlines()[-1] == "manip sweep: interrupted" and "Traceback" not in err
    else:
        assert proc.returncode == -signal.SIGKILL, err
    assert workers_seen >= 2 and not ports  # two workers were seen, and nothing listened

    deadline = time.monotonic() + 30  # an orphaned worker checks its parent twice a second
    while alive(mark) and time.monotonic() < deadline:
        time.sleep(0.2)
    # the command's own tree only (the machine's other programs may reuse a port): no process, no listener
    assert not alive(mark)
    assert not listening_ports(mark)
    assert (out / PARTS_DIR).is_dir() and not (out / "results.csv").exists()  # kept for --resume


@pytest.mark.parametrize("kind", ["ct", "pid"])
def test_a_case_with_its_own_gains_equals_the_run_of_its_own_design(kind):
    """The sweep keeps one controller per rate and overrides its gains: the same run as a new design's controller."""
    from closed_loop.kernel import closed_loop_kernel
    from closed_loop.schedule import Schedule, default_substeps
    from control_design.design import design_robot
    from control_design.reference import task_trajectory
    from model.robot import load_robot

    spec = spec_from_dict({"robot": "scara", "controller": kind, "samples": 3, "seed": 5, "rate_hz": 500.0,
                           "vary": {"bandwidth": [20.0, 40.0], "damping": [0.5, 1.0]}}, "test.toml")
    rows = run_cases(spec, np.arange(3))
    robot = load_robot("scara")
    task = task_trajectory(robot, "pick-and-place")
    for case, (bw, zeta) in enumerate(case_values(spec)):
        controller = design_robot(robot, kind, bw, zeta, rate_hz=500.0, analyse=False).controller(500.0)
        sched = Schedule.build(robot, task, controller.dt)
        sched = Schedule.build(robot, task, controller.dt, substeps=default_substeps(robot, controller.dt, sched.q0))
        run = closed_loop_kernel(robot, kind).run(controller, sched, robot.parameters)
        np.testing.assert_array_equal(rows[case, 2:6], run.max_error)
        np.testing.assert_array_equal(rows[case, 6:10], run.rms_error)
    assert len(set(rows[:, 0])) == 3  # three designs, three different runs
