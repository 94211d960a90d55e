"""Parameter sweeps, locally or on a Ray cluster.

``octoarm.sweep(sweep_file, out, ray=None)`` runs a sweep file (see the README's "Sweeps") the
way ``octoarm sweep`` does: the plan, the output folder (``runs/<id>/``, ``results.csv``,
``results.npz``, ``sweep.json``) and ``--resume`` are the application's Rust code
(:class:`octoarm._octoarm.Sweep`); the runs execute

* locally (``ray=None``): in Rust threads, one scenario per core;
* on Ray (``ray="auto"`` for the running cluster, ``"local"`` for a new one on this machine,
  or an address ``"HOST:PORT"``): each run is a Ray task calling :func:`octoarm.run_scenario`
  on a worker (so its ``trajectory.npz`` is bit-identical to ``octoarm run``'s); the worker
  returns the run's files, the driver commits them into ``runs/<id>/``. A run whose worker
  dies is submitted once more; if that dies too it is recorded as ``lost``. Workers need the
  octoarm package installed; they need no shared file system.

``python -m octoarm.sweep serve --address A`` is the Ray executor of the command line
(``octoarm sweep --ray A``), speaking JSON lines on stdin/stdout (see ``crates/app/src/sweep/
ray.rs``). ``python -m octoarm.sweep SWEEP --out DIR [--ray A]`` is ``octoarm.sweep`` from a
shell.

Figures are drawn only by the command line (the extension module carries no plotting).
"""

from __future__ import annotations

import json
import os
import queue
import shutil
import signal
import sys
import tempfile
import threading
import time
import types
from typing import Any, Callable, Dict, Iterator, Optional, Tuple

__all__ = ["sweep", "execute_on_ray", "connect"]

# A run handed to an executor: (plan index, id, scenario path, scenario text).
Run = Tuple[int, str, str, str]


def _run_one(path: str, source: str) -> Dict[str, Any]:
    """The Ray task: run one scenario (text ``source``, named ``path``) into a temporary
    folder on the worker and return its files, or why it could not run."""
    import octoarm

    tmp = tempfile.mkdtemp(prefix="octoarm-run-")
    try:
        out = os.path.join(tmp, "run")
        try:
            octoarm.run_scenario(path, out, source=source)
        except ValueError as e:  # the scenario or its build failed: nothing written
            return {"status": "invalid", "message": str(e)}
        except RuntimeError as e:  # unstable or controller failure: outputs are written
            if not hasattr(e, "report"):
                return {"status": "error", "message": str(e)}
        except OSError as e:
            return {"status": "error", "message": f"on worker {os.uname().nodename}: {e}"}
        files = {}
        for name in sorted(os.listdir(out)):
            p = os.path.join(out, name)
            if not name.startswith(".") and os.path.isfile(p):
                with open(p, "rb") as f:
                    files[name] = f.read()
        return {"status": "ran", "files": files}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def connect(address: str) -> bool:
    """Connect to Ray: ``"auto"`` (a running cluster), ``"local"`` (start one here) or an
    address. Returns True if this call started Ray (the caller then shuts it down). Reuses a
    connection this process already has."""
    if address == "local":
        # Loopback only: Ray's single-machine mode (else it binds the routable address). Read
        # when ray is first imported.
        os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
    import ray

    if ray.is_initialized():
        return False
    quiet: Dict[str, Any] = {"log_to_driver": False, "logging_level": "ERROR"}
    if address == "local":
        ray.init(include_dashboard=False, _node_ip_address="127.0.0.1", **quiet)
    else:
        ray.init(address=address, **quiet)
    return True


def execute_on_ray(
    next_run: Callable[[], Any],
    stage: str,
    emit: Callable[[Dict[str, Any]], None],
    should_stop: Callable[[], bool] = lambda: False,
) -> bool:
    """Run scenarios as Ray tasks (Ray must be connected). ``next_run()`` returns the next
    :data:`Run`, ``None`` when there are no more, or ``...`` when none is available yet. At most
    one run per cluster CPU is in flight. Each outcome is emitted as a dict with ``event``:
    ``started``; ``done`` (its files written to ``stage/<id>/``, key ``staged``); ``failed``
    (``status`` "invalid", "lost" or "error", ``message``); ``retry`` (its worker died; it is
    submitted once more). Returns False if ``should_stop()`` ended it early (runs in flight are
    cancelled and not reported)."""
    import ray
    from ray.exceptions import RayError, RayTaskError

    task = ray.remote(num_cpus=1, max_retries=0)(_run_one)
    cpus = max(1, int(ray.cluster_resources().get("CPU", 1)))
    in_flight: Dict[Any, Tuple[Run, int]] = {}
    exhausted = False

    def submit(run: Run, attempt: int) -> None:
        ref = task.remote(run[2], run[3])
        in_flight[ref] = (run, attempt)

    while True:
        while not exhausted and len(in_flight) < cpus:
            run = next_run()
            if run is None:
                exhausted = True
            elif run is ...:
                break
            else:
                submit(run, 0)
                emit({"event": "started", "index": run[0]})
        if should_stop():
            for ref in in_flight:
                ray.cancel(ref, force=True)
            return False
        if not in_flight:
            if exhausted:
                return True
            time.sleep(0.02)
            continue
        ready, _ = ray.wait(list(in_flight), num_returns=1, timeout=0.2)
        for ref in ready:
            run, attempt = in_flight.pop(ref)
            index, run_id = run[0], run[1]
            try:
                result = ray.get(ref)
            except RayTaskError as e:
                emit({"event": "failed", "index": index, "status": "error", "message": str(e)})
                continue
            except RayError as e:  # the worker (or its node) died
                why = f"{type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''}"
                if attempt == 0:
                    emit({"event": "retry", "index": index, "message": why})
                    submit(run, 1)
                else:
                    emit({"event": "failed", "index": index, "status": "lost",
                          "message": f"its Ray worker died twice ({why})"})
                continue
            if result["status"] != "ran":
                emit({"event": "failed", "index": index, "status": result["status"],
                      "message": result["message"]})
                continue
            folder = os.path.join(stage, run_id)
            shutil.rmtree(folder, ignore_errors=True)
            os.makedirs(folder)
            for name, data in result["files"].items():
                with open(os.path.join(folder, name), "wb") as f:
                    f.write(data)
            emit({"event": "done", "index": index, "staged": folder})


def sweep(
    sweep_file: str | os.PathLike[str],
    out: str | os.PathLike[str] | None = None,
    *,
    ray: Optional[str] = None,
    resume: bool = False,
    threads: Optional[int] = None,
    duration: Optional[float] = None,
    verbose: bool = False,
) -> Dict[str, Any]:
    """Run the sweep file ``sweep_file`` into ``out`` (default results/<file stem>), exactly
    as ``octoarm sweep`` does but without figures. ``ray``: None (this machine's cores,
    ``threads`` of them), ``"auto"``, ``"local"`` or a Ray address. ``resume``: continue an
    earlier sweep in ``out``, skipping its complete runs. ``duration`` [s] overrides every
    run's. Returns the report (out, total, completed, failed, interrupted, not_run, skipped,
    wall_seconds, rows). A bad sweep file raises ValueError (file:line:col), an unusable
    ``out`` OSError; failed runs do not raise (see ``report["failed"]`` and results.csv).
    Ctrl-C stops the sweep, writes the table of what ended and raises KeyboardInterrupt."""
    from ._octoarm import Sweep

    s = Sweep(os.fspath(sweep_file), None if out is None else os.fspath(out),
              resume=resume, duration=duration)

    def log(row: Dict[str, Any]) -> None:
        if verbose or row["status"] not in ("completed", "interrupted"):
            msg = f": {row['error']}" if row["error"] else ""
            print(f"run {row['run']} ({row['id']}) {row['status']}{msg}", file=sys.stderr)

    interrupted = False
    if ray is None:
        interrupted = s.run_local(threads)
        executor: Dict[str, Any] = {"kind": "local",
                                    "threads": threads or os.cpu_count() or 1}
    else:
        import ray as ray_module

        started = connect(ray)
        try:
            pending = iter(s.pending)
            stage = str(s.stage_dir())

            def next_run() -> Any:
                i = next(pending, None)
                return None if i is None else (i, *s.run_source(i))

            def emit(ev: Dict[str, Any]) -> None:
                if ev["event"] == "done":
                    log(s.commit_staged(ev["index"], ev["staged"]))
                elif ev["event"] == "failed":
                    log(s.record_failure(ev["index"], ev["status"], ev["message"]))
                elif ev["event"] == "retry":
                    print(f"run {ev['index']}: {ev['message']}; running it again",
                          file=sys.stderr)

            try:
                execute_on_ray(next_run, stage, emit)
            except KeyboardInterrupt:
                interrupted = True
            executor = {"kind": "ray", "address": ray_module.get_runtime_context().gcs_address,
                        "cpus": int(ray_module.cluster_resources().get("CPU", 1))}
        finally:
            if started:
                ray_module.shutdown()
    report = s.finish(json.dumps(executor))
    if interrupted:
        raise KeyboardInterrupt(
            f"sweep interrupted: {report['completed']} of {report['total']} runs completed; "
            "continue with resume=True")
    return report


def _serve(address: str) -> int:
    """The command line's Ray executor (JSON lines; see the module docstring)."""
    out_lock = threading.Lock()

    def emit(ev: Dict[str, Any]) -> None:
        with out_lock:
            sys.stdout.write(json.dumps(ev) + "\n")
            sys.stdout.flush()

    stop = threading.Event()
    # SIGINT (Ctrl-C, or the command line interrupting us) stops the sweep cleanly.
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    if address == "local":
        os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
    try:
        import ray
        import octoarm  # noqa: F401
    except ImportError as e:
        emit({"event": "error", "message": f"{e} (Python {sys.executable}); "
              "install with `pip install ./crates/python ray`"})
        return 3
    try:
        started = connect(address)
    except Exception as e:  # any failure to reach the cluster
        emit({"event": "error", "message": f"cannot connect to Ray: {type(e).__name__}: {e}"})
        return 3
    try:
        emit({"event": "ready", "cpus": int(ray.cluster_resources().get("CPU", 1)),
              "address": ray.get_runtime_context().gcs_address})
        runs: "queue.Queue[Any]" = queue.Queue()
        header: Dict[str, Any] = {}
        got_header = threading.Event()

        def read() -> None:
            for line in sys.stdin:
                msg = json.loads(line)
                if "stage" in msg:
                    header.update(msg)
                    got_header.set()
                elif msg.get("end"):
                    runs.put(None)
                    return
                else:
                    runs.put((msg["index"], msg["id"], msg["path"], msg["source"]))
            stop.set()  # the command line went away before sending everything

        threading.Thread(target=read, daemon=True).start()
        while not got_header.wait(0.1):
            if stop.is_set():
                emit({"event": "interrupted"})
                return 0

        def next_run() -> Any:
            try:
                return runs.get_nowait()
            except queue.Empty:
                return ...

        finished = execute_on_ray(next_run, header["stage"], emit, stop.is_set)
        emit({"event": "end" if finished else "interrupted"})
        return 0
    finally:
        if started:
            ray.shutdown()


def _main(argv: Optional[list] = None) -> int:
    import argparse

    p = argparse.ArgumentParser(prog="python -m octoarm.sweep", description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="command")
    serve = sub.add_parser("serve", help="the command line's Ray executor (JSON lines)")
    serve.add_argument("--address", default="auto")
    run = sub.add_parser("run", help="run a sweep file (as octoarm.sweep)")
    run.add_argument("sweep_file")
    run.add_argument("--out")
    run.add_argument("--ray")
    run.add_argument("--resume", action="store_true")
    run.add_argument("--threads", type=int)
    a = p.parse_args(argv)
    if a.command == "serve":
        return _serve(a.address)
    if a.command == "run":
        report = sweep(a.sweep_file, a.out, ray=a.ray, resume=a.resume, threads=a.threads)
        report.pop("rows")
        print(json.dumps(report, default=str))
        return 1 if report["failed"] else 0
    p.print_help()
    return 2


class _CallableModule(types.ModuleType):
    """Lets ``octoarm.sweep(...)`` call :func:`sweep` while ``octoarm.sweep`` stays this
    module (``python -m octoarm.sweep``, ``octoarm.sweep.execute_on_ray``)."""

    def __call__(self, *args: Any, **kwargs: Any) -> Dict[str, Any]:
        return sweep(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule

if __name__ == "__main__":
    # Through the imported module, so that Ray pickles the task by reference.
    from octoarm.sweep import _main as _real_main

    sys.exit(_real_main())
