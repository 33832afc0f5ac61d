"""Parameter sweeps: thousands of compiled closed loops in local processes or on Dask, with their table and summary.

:func:`run_sweep` runs every case of a :class:`~closed_loop.sweep_spec.SweepSpec` with the
compiled closed loop (:mod:`closed_loop.kernel`): the plant's payload, friction and
link masses are kernel inputs, the control rate changes the schedule, a bandwidth or
damping a design per case. Cases are grouped into tasks of a few hundred
milliseconds and run, by default, in a pool of processes forked from this one
(:mod:`closed_loop.sweep_pool`: one per core, no socket, started in milliseconds; one worker
runs in this process), or by ``dask.distributed``: an existing cluster given by its
scheduler address, or an embedded ``LocalCluster`` listening on a ``host`` other than
loopback. The kernel is built once, before any worker starts (forked workers inherit it,
Dask workers on this machine load it from the disk cache; a remote worker builds it once
into its own cache).

Each finished task is written at once, atomically, to ``DIR/.sweep-parts/`` (its
cases and metrics), so a worker killed mid-sweep costs only its unfinished tasks,
which the scheduler runs again, and an interrupted sweep resumes (``resume=True``)
from the cases already written; the table is assembled by case number, each case
once. A case's result depends on its values only (random cases are seeded per case),
so the table is identical whatever the number of workers or the order of completion.

Outputs (``DIR``): ``results.csv`` and ``results.parquet`` (one row per case: ``case``,
the varied quantities, ``max_error`` (worst joint, in its unit), ``diverged``, then
per joint ``max_error_J``, ``rms_error_J``, ``peak_tau_m_J``, ``peak_qd_m_J``,
``saturated_J``), ``summary.json`` (:func:`summarise`) and the plots of
:mod:`closed_loop.sweep_plots`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import os
import sys
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterator, TextIO

import numpy as np

from model.files import atomic_path, write_atomic
from model.errors import ToolchainError

from .sweep_spec import SweepSpec, SweepSpecError, case_values, check_joints

__all__ = ["PARTS_DIR", "SweepResult", "SweepProgress", "assemble", "case_setup", "local_cluster", "metric_columns",
           "nominal_run", "rerun_case", "rerun_case_through_fmu", "run_cases", "run_sweep", "summarise"]

#: Folder (inside the output folder) of the finished tasks of a running or interrupted sweep.
PARTS_DIR = ".sweep-parts"
_METRICS = ("max_error", "rms_error", "peak_tau_m", "peak_qd_m", "saturated")
_LOOPBACK = ("127.0.0.1", "localhost", "::1")


def metric_columns(joints: tuple[str, ...]) -> list[str]:
    """The per-joint metric columns, metric by metric."""
    return [f"{m}_{j}" for m in _METRICS for j in joints]


@dataclass
class _Setup:
    robot: Any
    trajectory: Any
    kernel: Any
    joint_model: Any
    controllers: dict
    schedules: dict


_SETUPS: dict[str, _Setup] = {}


def case_setup(spec: SweepSpec) -> _Setup:
    """The robot, trajectory and compiled kernel of ``spec``, made once per process."""
    key = spec.digest()
    if key not in _SETUPS:
        from control_design.reference import task_trajectory
        from model.robot import load_robot

        from .kernel import closed_loop_kernel

        from control_design.joint_model import decoupled_model
        from control_design.reference import reference_task, reference_task_name

        robot = load_robot(spec.robot)
        traj = task_trajectory(robot, spec.task, spec.waypoints, spec.segment_time)
        # the design's decoupled model (design_robot's default), computed once for every design of the sweep
        jm = (None if spec.controller == "cascade"  # the cascade's gains are the robot file's: no design
              else decoupled_model(robot, reference_task(robot), reference_name=reference_task_name(robot)))
        _SETUPS[key] = _Setup(robot, traj, closed_loop_kernel(robot, spec.controller), jm, {}, {})
    return _SETUPS[key]


def _case_inputs(spec: SweepSpec, setup: _Setup, values: dict[str, float]) -> tuple[Any, Any, Any, float, bool, Any]:
    """The controller, schedule, plant parameters, link-mass scale, delay and gain overrides of one case.

    One controller per control rate; a case whose bandwidth or damping varies keeps it and overrides its
    gains (``Kp``, ``Kd``, ``Ki``) with those of its own design (the other parameters of a design, its
    limits and feed-forward, do not depend on them).
    """
    from control_design.design import DEFAULT_RATE_HZ
    from control_design.loops import gains_arrays
    from model.drive_train import drive_substeps

    from .schedule import Schedule, default_substeps

    robot = setup.robot
    cascade = spec.controller == "cascade"  # the robot file's P-PI cascade, at its [cascade] rate by default
    rate = values.get("rate_hz", spec.rate_hz or (None if cascade else DEFAULT_RATE_HZ))
    bw = values.get("bandwidth", spec.bandwidth)
    zeta = values.get("damping", spec.damping)

    def design(bandwidth: float | None, damping: float | None) -> Any:
        return _case_design(spec, setup, rate, bandwidth, damping)

    controller = setup.controllers.get(rate)
    if controller is None:
        if cascade:
            from control_design.cascade import cascade_from_robot

            controller = cascade_from_robot(robot, rate)
        else:
            controller = design(spec.bandwidth, spec.damping).controller(rate, saturate=spec.saturate)
        if len(setup.controllers) < 64:
            setup.controllers[rate] = controller
    gains = None
    if bw != spec.bandwidth or zeta != spec.damping:
        Kp, Kd, Ki = gains_arrays(design(bw, zeta).loops)
        gains = {"Kp": Kp, "Kd": Kd, **({"Ki": Ki} if spec.controller == "pid" else {})}
    p = robot.parameters
    if "payload_mass" in values or any(q.startswith("payload_com") for q in values):
        com = [values.get(f"payload_com_{a}", 0.0) for a in "xyz"]
        p = p.with_payload(values.get("payload_mass", 0.0), com)
    scale = np.ones(robot.n)
    if "friction_scale" in values:
        scale[:] = values["friction_scale"]
    for j in range(robot.n):
        scale[j] = values.get(f"friction_scale_{j + 1}", scale[j])
    if np.any(scale != 1.0):
        p = p.with_friction(*(scale * p.field(f) for f in ("viscous_friction", "coulomb_friction_pos",
                                                           "coulomb_friction_neg")))
    mass_scale = values.get("link_mass_scale", 1.0)
    plant = robot.with_parameters(p)
    sched = setup.schedules.get(rate)
    if sched is None:  # the instants and reference samples of one rate, built once
        sched = Schedule.build(robot, setup.trajectory, controller.dt, rate_hz=controller.rate_hz, substeps=1)
        if len(setup.schedules) < 64:
            setup.schedules[rate] = sched
    # The sub-steps of the Python loop for this plant; scaled links: B_s >= min(s, 1) B, so the friction
    # rate is at most 1 / min(s, 1) times that of the unscaled plant.
    # Drive trains: the Python loop's sub-steps for their fastest rate (drive_substeps).
    sub = (drive_substeps(robot.description, controller.dt)
           or default_substeps(plant, controller.dt, sched.q0, rate_factor=1.0 / min(mass_scale, 1.0)))
    sched = dataclasses.replace(sched, substeps=sub)
    delay = bool(values.get("delay", 1.0 if spec.delay else 0.0) >= 0.5)
    return controller, sched, p, mass_scale, delay, gains


def _case_design(spec: SweepSpec, setup: _Setup, rate: float, bandwidth: float | None, damping: float | None) -> Any:
    """The design of a case: ``spec``'s controller kind on the sweep's robot at ``rate`` Hz, bandwidth and damping."""
    from control_design.design import design_robot

    kwargs = {} if bandwidth is None else {"bandwidth": bandwidth}
    return design_robot(setup.robot, spec.controller, damping=damping, rate_hz=rate, analyse=False,
                        joint_model=setup.joint_model, **kwargs)


def _run_case(spec: SweepSpec, setup: _Setup, values: dict[str, float], record: bool = False) -> Any:
    """The :class:`~closed_loop.kernel.KernelRun` of one case (its varied ``values`` by quantity)."""
    controller, sched, p, mass_scale, delay, gains = _case_inputs(spec, setup, values)
    return setup.kernel.run(controller, sched, p, link_mass_scale=mass_scale, delay=delay, record=record, values=gains)


def run_cases(spec: SweepSpec, cases: np.ndarray) -> np.ndarray:
    """(len(cases), 2 + 5 n) rows ``[max_error, diverged, per-joint metrics...]`` of ``cases`` (the Dask task)."""
    setup = case_setup(spec)
    values = case_values(spec, cases)
    n = setup.robot.n
    rows = np.empty((len(cases), 2 + len(_METRICS) * n))
    for r, vals in enumerate(values):
        run = _run_case(spec, setup, dict(zip(spec.quantities, vals)))
        per_joint = np.concatenate([run.max_error, run.rms_error, run.peak_motor_torque, run.peak_motor_velocity,
                                    run.saturated_fraction])
        if run.diverged:
            per_joint[:4 * n] = np.inf
        rows[r, 0] = np.max(per_joint[:n])
        rows[r, 1] = float(run.diverged)
        rows[r, 2:] = per_joint
    return rows


def nominal_run(spec: SweepSpec) -> Any:
    """The :class:`~closed_loop.kernel.KernelRun` of ``spec``'s design on the exact plant (nothing varied)."""
    return _run_case(spec, case_setup(spec), {})


def rerun_case(spec: SweepSpec, case: int) -> Any:
    """The samples of one case (a :class:`~closed_loop.result.TrackingResult`), re-run by the compiled loop."""
    vals = case_values(spec, np.array([case]))[0]
    return _run_case(spec, case_setup(spec), dict(zip(spec.quantities, vals)), record=True).result


def rerun_case_through_fmu(spec: SweepSpec, case: int, workdir: str | Path) -> Any:
    """One case re-run through the plant FMU (a :class:`~closed_loop.result.TrackingResult`): the case's plant
    exported as it is (its payload and friction the FMU parameters' start values, its link masses scaled in
    the exported description) and driven by the case's Python controller through FMPy (its one-period delay
    included). The FMU integrates the plant the sweep's kernel does, with the same rule: its ``max_error`` is
    the table's, to rounding. The FMU is written into ``workdir``. A cascade sweep is refused (SweepSpecError): the
    FMU master does not hand the controller the rotor states nor start in the drive trains' equilibrium.
    """
    from control_design.computed_torque import ModelMismatch, plant_with_mismatch
    from fmu.build import export_fmu

    from .delay import OnePeriodDelay
    from .master import run_closed_loop

    if spec.controller == "cascade":  # the FMU master hands a controller q, qd and starts the plant at rest
        raise SweepSpecError(f"{spec.source}: controller: 'cascade': the FMU master does not read the rotor states "
                             f"or start in the drive trains' equilibrium yet; re-run the case in the Python loop "
                             f"(simulate_tracking)", parameter="controller")
    setup = case_setup(spec)
    values = dict(zip(spec.quantities, case_values(spec, np.array([case]))[0]))
    controller, sched, p, mass_scale, delay, gains = _case_inputs(spec, setup, values)
    if gains is not None:  # the case's own design: its gains, the same limits and feed-forward
        controller = _case_design(spec, setup, controller.rate_hz, values.get("bandwidth", spec.bandwidth),
                                  values.get("damping", spec.damping)).controller(controller.rate_hz,
                                                                                  saturate=spec.saturate)
    robot = setup.robot
    body = robot if mass_scale == 1.0 else plant_with_mismatch(robot, ModelMismatch(link_mass_scale=mass_scale))
    plant = body.with_parameters(p)
    folder = Path(workdir)
    folder.mkdir(parents=True, exist_ok=True)
    path = export_fmu(plant, folder / f"{robot.description.identifier}_case{case}.fmu", step=sched.dt)
    return run_closed_loop(path, OnePeriodDelay(controller) if delay else controller, setup.trajectory, plant=plant,
                           substeps=sched.substeps)


class SweepProgress:
    """``sweep: 1200/10000 cases (12 %), 850 cases/s, 10 s left`` on a stream, at most every ``every`` s."""

    def __init__(self, total: int, stream: TextIO | None = None, every: float = 1.0, done: int = 0) -> None:
        self.total, self.done, self.every = total, done, every
        self.stream = stream if stream is not None else sys.stderr
        self._start, self._first, self._last = time.perf_counter(), done, -math.inf

    def __call__(self, n_new: int) -> None:
        self.done += n_new
        now = time.perf_counter()
        if now - self._last < self.every and self.done < self.total:
            return
        self._last = now
        rate = (self.done - self._first) / max(now - self._start, 1e-9)
        left = (self.total - self.done) / rate if rate > 0 else math.inf
        print(f"sweep: {self.done}/{self.total} cases ({100 * self.done / self.total:.0f} %), {rate:.0f} cases/s, "
              f"{left:.0f} s left", file=self.stream, flush=True)


@contextlib.contextmanager
def local_cluster(workers: int, host: str = "127.0.0.1") -> Iterator[Any]:
    """An embedded ``LocalCluster`` of ``workers`` single-threaded processes and its client, closed on exit.

    Scheduler (with its HTTP endpoints), nannies and workers listen on ``host`` (loopback unless the caller
    asks otherwise) on free ports; no dashboard. Closed in a ``finally``: after Ctrl-C or an error nothing is left listening.
    """
    import logging

    from distributed import Client, LocalCluster

    if host not in _LOOPBACK:
        warnings.warn(f"the sweep's Dask cluster listens on {host}, not only on this machine", RuntimeWarning,
                      stacklevel=3)
    cluster = None
    client = None
    try:
        # no dashboard; the scheduler's HTTP endpoints (health, metrics) on a free port of ``host``, not 8787.
        # Logs: critical only (a failing case raises through its future; the shutdown of workers whose
        # scheduler closed first, after Ctrl-C, would otherwise print heartbeat tracebacks).
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host=host, scheduler_port=0,
                               dashboard_address=None, scheduler_kwargs={"dashboard_address": f"{host}:0"},
                               silence_logs=logging.CRITICAL)
        client = Client(cluster)
        yield client
    except BaseException:
        # Interrupted (Ctrl-C) or failed: closing cuts the comms of operations in flight, which the scheduler
        # would log as tracebacks; the exception itself says what happened.
        for name in ("distributed", "asyncio"):  # asyncio: "Task exception was never retrieved" of those comms
            logging.getLogger(name).setLevel(logging.CRITICAL)
        raise
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()


def _batch_size(spec: SweepSpec, n_todo: int, workers: int) -> int:
    if spec.batch:
        return spec.batch
    return max(1, min(100, math.ceil(n_todo / (8 * max(workers, 1)))))


def _read_parts(parts: Path) -> dict[int, np.ndarray]:
    done: dict[int, np.ndarray] = {}
    for f in sorted(parts.glob("part-*.npz")):
        with np.load(f) as z:
            for c, row in zip(z["cases"], z["rows"]):
                done[int(c)] = row
    return done


def _prepare_parts(spec: SweepSpec, out: Path, resume: bool) -> tuple[Path, dict[int, np.ndarray]]:
    parts = out / PARTS_DIR
    stamp = parts / "spec.json"
    if parts.is_dir() and resume:
        try:
            recorded = json.loads(stamp.read_text())["digest"]
        except (OSError, ValueError, KeyError):
            recorded = None
        if recorded != spec.digest():
            raise SweepSpecError(f"{spec.source}: --resume: {parts} holds the cases of another spec; "
                                 f"remove it or run without --resume")
        return parts, _read_parts(parts)
    if parts.is_dir():
        for f in parts.iterdir():
            f.unlink()
    parts.mkdir(parents=True, exist_ok=True)
    write_atomic(stamp, json.dumps({"digest": spec.digest(), "spec": spec.to_dict()}))
    return parts, {}


def _write_part(parts: Path, cases: np.ndarray, rows: np.ndarray) -> None:
    with atomic_path(parts / f"part-{int(cases[0]):08d}-{int(cases[-1]):08d}.npz") as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, cases=cases, rows=rows)


@dataclass(frozen=True)
class SweepResult:
    """A finished sweep: the table (a pandas DataFrame, one row per case, by case), its summary and files."""

    spec: SweepSpec
    table: Any
    summary: dict[str, Any]
    wall_time: float
    workers: int
    files: tuple[Path, ...] = ()


def assemble(spec: SweepSpec, joints: tuple[str, ...], done: dict[int, np.ndarray]) -> Any:
    """The table of the cases in ``done`` (case -> row of :func:`run_cases`), sorted by case."""
    import pandas as pd

    cases = np.array(sorted(done), dtype=np.int64)
    values = case_values(spec, cases)
    rows = np.array([done[int(c)] for c in cases]).reshape(len(cases), -1)
    table = pd.DataFrame({"case": cases})
    for j, q in enumerate(spec.quantities):
        table[q] = values[:, j]
    table["max_error"] = rows[:, 0]
    table["diverged"] = rows[:, 1].astype(bool)
    for k, col in enumerate(metric_columns(joints)):
        table[col] = rows[:, 2 + k]
    return table


def summarise(spec: SweepSpec, table: Any, units: tuple[str, ...], bound: float | None = None) -> dict[str, Any]:
    """Quantiles of ``max_error``, P(max_error > bound) with its 95 % Clopper-Pearson interval, the worst case.

    ``bound`` defaults to the spec's; without one the exceedance is left out.
    """
    from scipy.stats import beta

    err = table["max_error"].to_numpy()
    qs = (0.05, 0.25, 0.5, 0.75, 0.95, 0.99)
    finite = err[np.isfinite(err)]
    worst = int(np.argmax(np.where(np.isfinite(err), err, np.inf)))
    row = table.iloc[worst]
    out: dict[str, Any] = {
        "robot": spec.robot, "controller": spec.controller, "cases": int(len(table)), "method": spec.method,
        "seed": spec.seed, "varied": {q: list(r) for q, r in spec.vary.items()},
        "max_error_unit": units[0] if len(set(units)) == 1 else " or ".join(sorted(set(units))),
        "diverged": int(table["diverged"].sum()),
        "max_error_quantiles": {f"{q:g}": float(np.quantile(finite, q)) if finite.size else None for q in qs},
        "max_error_mean": float(finite.mean()) if finite.size else None,
        "worst_case": {"case": int(row["case"]), "max_error": float(row["max_error"]),
                       "parameters": {q: float(row[q]) for q in spec.quantities}},
    }
    b = spec.bound if bound is None else bound
    if b is not None:
        n, k = len(err), int(np.sum(~(err <= b)))  # a diverged case exceeds every bound
        lo = 0.0 if k == 0 else float(beta.ppf(0.025, k, n - k + 1))
        hi = 1.0 if k == n else float(beta.ppf(0.975, k + 1, n - k))
        out["bound"] = {"max_error": b, "exceeded": k, "probability": k / n, "ci95": [lo, hi]}
    return out


def _client(scheduler: str) -> Any:
    """A Dask client of the scheduler at ``scheduler``; ToolchainError naming it when it cannot be reached."""
    from distributed import Client

    try:
        return Client(scheduler)
    except (OSError, ValueError, TypeError) as exc:  # OSError: timed out or refused; ValueError: a bad address
        raise ToolchainError(f"cannot connect to the Dask scheduler at {scheduler!r}: {exc}", parameter="scheduler") from None


def run_sweep(spec: SweepSpec, out: str | Path | None = None, *, workers: int | None = None,
          scheduler: str | None = None, host: str = "127.0.0.1", resume: bool = False,
          progress: Callable[[int], None] | None = None, stream: TextIO | None = None,
          plots: bool = True) -> SweepResult:
    """Run every case of ``spec`` (local processes or Dask); write the table, summary and plots into ``out`` (if given).

    Parameters
    ----------
    spec
        The sweep (:func:`~closed_loop.sweep_spec.load_spec` or :func:`~closed_loop.sweep_spec.spec_from_dict`).
    out
        Output folder (created); None keeps the finished tasks in a temporary folder and writes nothing.
    workers
        Worker processes on this machine (default: the machine's cores; 1 runs in this process); ignored with
        ``scheduler``.
    scheduler
        Address of an existing Dask scheduler (``tcp://host:port``) instead of the embedded cluster.
    host
        Loopback (the default): the local process pool. Another interface: an embedded Dask cluster listening
        on it (warns).
    resume
        Keep the cases already written in ``out`` by an interrupted run of the same spec.
    progress
        Called with the number of cases of each finished task (default a :class:`SweepProgress` on ``stream``).

    Returns
    -------
    SweepResult
    """
    import tempfile

    t0 = time.perf_counter()
    stream = stream if stream is not None else sys.stderr
    setup = case_setup(spec)  # builds (or loads) the kernel here, once, before any worker needs it
    robot = setup.robot
    check_joints(spec, robot.n)
    joints = tuple(lk.name or f"joint{i + 1}" for i, lk in enumerate(robot.description.links))
    units = tuple("rad" if lk.is_revolute else "m" for lk in robot.description.links)
    # a case that cannot be set up (e.g. a rate too slow for a bandwidth) fails here, before the cluster starts
    for corner in _corners(spec):
        _case_inputs(spec, setup, corner)
    if spec.task is None and spec.waypoints is None:  # said once the spec is known to be good
        from control_design.reference import reference_task_name, reference_task_rule

        print(f"sweep: no task in the spec: following {reference_task_name(robot)!r} ({reference_task_rule(robot)})",
              file=stream, flush=True)
    tmp = None
    if out is None:
        tmp = tempfile.TemporaryDirectory(prefix="manip-sweep-")
        out_dir = Path(tmp.name)
    else:
        out_dir = Path(out)
        out_dir.mkdir(parents=True, exist_ok=True)
    try:
        parts, done = _prepare_parts(spec, out_dir, resume)
        todo = np.array([c for c in range(spec.n_cases) if c not in done], dtype=np.int64)
        n_workers = workers or os.cpu_count() or 1
        report = progress or SweepProgress(spec.n_cases, stream, done=len(done))
        run_time = 0.0
        if todo.size:
            if scheduler or host not in _LOOPBACK:
                run_time, n_workers = _run_on_dask(spec, todo, done, parts, report, stream, n_workers, scheduler, host)
            else:
                run_time = _run_local(spec, todo, done, parts, report, stream, n_workers)
        table = assemble(spec, joints, done)
        if len(table) != spec.n_cases:  # pragma: no cover - every task either returned or raised
            raise ToolchainError(f"sweep: {len(table)} of {spec.n_cases} cases finished: the Dask cluster lost the others")
        summary = summarise(spec, table, units)
        summary["wall_time_s"] = time.perf_counter() - t0
        summary["run_time_s"] = run_time  # from the first task submitted to the last result, cluster start excluded
        summary["workers"] = n_workers
        files: list[Path] = []
        if out is not None:
            files = _write_outputs(spec, table, summary, out_dir, plots)
            for f in parts.iterdir():
                f.unlink()
            parts.rmdir()
        return SweepResult(spec, table, summary, time.perf_counter() - t0, n_workers, tuple(files))
    finally:
        if tmp is not None:
            tmp.cleanup()


def _collect(spec: SweepSpec, finished: Iterator[tuple[np.ndarray, np.ndarray]], done: dict[int, np.ndarray],
             parts: Path, report: Callable[[int], None]) -> None:
    """Write each finished task's part at once and record its rows."""
    for cases, rows in finished:
        _write_part(parts, cases, rows)
        for c, row in zip(cases, rows):
            done[int(c)] = row
        report(len(cases))


def _run_local(spec: SweepSpec, todo: np.ndarray, done: dict[int, np.ndarray], parts: Path,
               report: Callable[[int], None], stream: TextIO, n_workers: int) -> float:
    """The cases of ``todo`` in this process (1 worker) or a forked pool (:mod:`closed_loop.sweep_pool`);
    the run time, s."""
    from .sweep_pool import local_pool

    size = spec.batch or max(1, min(100, math.ceil(todo.size / (32 * n_workers))))
    batches = [todo[i:i + size] for i in range(0, todo.size, size)]
    where = "this process" if n_workers == 1 else "a local process pool"
    print(f"sweep: {spec.n_cases} cases ({spec.n_cases - todo.size} already done) in {len(batches)} tasks on "
          f"{n_workers} workers ({where})", file=stream, flush=True)
    t_run = time.perf_counter()
    with local_pool(n_workers) as pool:
        _collect(spec, pool.run(run_cases, spec, batches), done, parts, report)
    return time.perf_counter() - t_run


def _run_on_dask(spec: SweepSpec, todo: np.ndarray, done: dict[int, np.ndarray], parts: Path,
                 report: Callable[[int], None], stream: TextIO, n_workers: int, scheduler: str | None,
                 host: str) -> tuple[float, int]:
    """The cases of ``todo`` on the Dask scheduler at ``scheduler``, or on an embedded cluster listening on
    ``host``; the run time, s, and the number of workers."""
    from distributed import as_completed

    with (contextlib.nullcontext(_client(scheduler)) if scheduler else local_cluster(n_workers, host)) as client:
        try:
            if scheduler:
                n_workers = max(1, len(client.scheduler_info()["workers"]))
            size = _batch_size(spec, todo.size, n_workers)
            batches = [todo[i:i + size] for i in range(0, todo.size, size)]
            print(f"sweep: {spec.n_cases} cases ({spec.n_cases - todo.size} already done) in {len(batches)} tasks on "
                  f"{n_workers} workers ({'scheduler ' + scheduler if scheduler else 'local cluster'})",
                  file=stream, flush=True)
            t_run = time.perf_counter()
            spec_f = client.scatter(spec, broadcast=True)
            futures = {client.submit(run_cases, spec_f, b, pure=False, retries=2): b for b in batches}

            def finished() -> Iterator[tuple[np.ndarray, np.ndarray]]:
                for fut in as_completed(futures):
                    yield futures[fut], fut.result()
                    fut.release()

            _collect(spec, finished(), done, parts, report)
            return time.perf_counter() - t_run, n_workers
        finally:
            if scheduler:
                client.close()


def _corners(spec: SweepSpec) -> list[dict[str, float]]:
    """The cases of the extreme rate and bandwidth (the ones whose design may be refused)."""
    keys = [q for q in ("rate_hz", "bandwidth", "damping") if q in spec.vary]
    if not keys:
        return [{}]
    combos: list[dict[str, float]] = [{}]
    for q in keys:
        combos = [{**c, q: v} for c in combos for v in spec.vary[q]]
    return combos


def _write_outputs(spec: SweepSpec, table: Any, summary: dict[str, Any], out: Path, plots: bool) -> list[Path]:
    files = [out / "results.csv", out / "results.parquet", out / "summary.json"]
    with atomic_path(files[0]) as tmp:
        table.to_csv(tmp, index=False, float_format="%.17g")
    with atomic_path(files[1]) as tmp:
        table.to_parquet(tmp, index=False)
    write_atomic(files[2], json.dumps(summary, indent=1))
    if plots:
        from .sweep_plots import sweep_figures

        worst = rerun_case(spec, summary["worst_case"]["case"])
        for name, fig in sweep_figures(spec, table, summary, worst).items():
            path = out / f"{name}.png"
            with atomic_path(path) as tmp:
                fig.savefig(tmp, dpi=110)
            files.append(path)
    return files
