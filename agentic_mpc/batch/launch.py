"""Starting, finishing and stopping run processes: a fresh interpreter or a fork of the warm fork server.

Run processes start in their own session: Ctrl-C reaches only the batch, which decides what to stop.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import shutil
import signal
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from agentic_mpc.batch.planning import BatchJob
from agentic_mpc.batch.records import WORKER_LOG, as_text, read_record, record_run
from agentic_mpc.batch.worker import worker_argv, worker_main

WORKER_MODULE = "agentic_mpc.batch"
"""``python -m`` this: a run process in a fresh interpreter (see ``__main__.py``)."""
WARM_START_MODULE = "agentic_mpc.scenario.warm_start"
_STOP_GRACE_S = 5.0
_warm_context: Any = None
_fork_server_failed = False


def _child_environment() -> dict[str, str]:
    # the run process must import what this one can (e.g. a run function next to the caller's code)
    paths = [p for p in sys.path if p and os.path.isdir(p)]
    return {**os.environ, "PYTHONPATH": os.pathsep.join(paths)}


@dataclass
class RunningJob:
    job: BatchJob
    process: subprocess.Popen | ForkedRun
    staging: Path
    final: Path
    log: IO[bytes]


def _forkserver() -> Any:
    """The fork server runs are forked from: it has imported everything once (see ``warm_start``)."""
    global _warm_context
    if _warm_context is None:
        from multiprocessing import forkserver

        context = multiprocessing.get_context("forkserver")
        context.set_forkserver_preload([WARM_START_MODULE])
        # The server and its resource tracker outlive a killed batch while runs are in flight: they must not
        # hold the batch's stdout/stderr open (whoever reads them would wait for the runs to end).
        with _stdio_on_devnull():
            forkserver.ensure_running()
        _warm_context = context
    return _warm_context


@contextlib.contextmanager
def _stdio_on_devnull() -> Iterator[None]:
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(fd) for fd in (0, 1, 2)]
    null = os.open(os.devnull, os.O_RDWR)
    try:
        for fd in (0, 1, 2):
            os.dup2(null, fd)
        yield
    finally:
        for fd, copy in zip((0, 1, 2), saved):
            os.dup2(copy, fd)
            os.close(copy)
        os.close(null)


class ForkedRun:
    """A run forked from the warm fork server, with the ``subprocess.Popen`` methods the batch uses."""

    def __init__(self, process: Any) -> None:
        self._process = process

    @property
    def pid(self) -> int:
        return self._process.pid

    @property
    def returncode(self) -> int | None:
        return self._process.exitcode

    def poll(self) -> int | None:
        return self._process.exitcode

    def wait(self, timeout: float | None = None) -> int:
        self._process.join(timeout)
        if self._process.exitcode is None:
            raise subprocess.TimeoutExpired("forked run", timeout or 0.0)
        return self._process.exitcode


def _forked_main(argv: list[str], log_path: str, environment: dict[str, str], cwd: str, path: list[str]) -> None:
    """A forked run: own session (Ctrl-C reaches only the batch), output into worker.log, then run.

    The fork server keeps the environment, directory and import path it started with; a run must see the
    batch's current ones (an API key set since, a run function next to the caller's code).
    """
    os.setsid()
    os.environ.clear()
    os.environ.update(environment)
    os.chdir(cwd)
    sys.path[:] = path
    log = os.open(log_path, os.O_WRONLY | os.O_APPEND)
    os.dup2(log, 1)
    os.dup2(log, 2)
    os.dup2(os.open(os.devnull, os.O_RDONLY), 0)
    code = worker_main(argv)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def _give_up_the_fork_server(error: BaseException) -> None:
    global _fork_server_failed
    _fork_server_failed = True
    print(f"agentic-mpc batch: the fork server stopped ({type(error).__name__}: {error}); the runs start in fresh "
          f"interpreters instead, about 1.7 s slower each (why it stopped: python -c 'import {WARM_START_MODULE}')",
          file=sys.stderr)


def start_run(job: BatchJob, runner_ref: str, staging: Path, final: Path, warm: bool = False) -> RunningJob:
    """Start one run process; its output goes to ``worker.log`` in the run directory.

    ``warm``: fork it from the fork server (about 1.7 s faster to start); otherwise a fresh interpreter,
    which is what Dask workers need (their daemonic processes cannot have multiprocessing children).
    """
    log = open(staging / WORKER_LOG, "wb")
    argv = worker_argv(job, runner_ref, staging, final)
    if warm and not _fork_server_failed:
        context = (argv, str(staging / WORKER_LOG), dict(os.environ), os.getcwd(), list(sys.path))
        try:
            process = _forkserver().Process(target=_forked_main, args=context, daemon=False)
            process.start()
            return RunningJob(job, ForkedRun(process), staging, final, log)
        except (EOFError, OSError) as error:  # the server died: its warm-up raised, or it was killed
            _give_up_the_fork_server(error)
    command = [sys.executable, "-m", WORKER_MODULE, *argv]
    # own session: Ctrl-C at the terminal reaches the batch only, which decides what to stop
    popen = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT,
                             env=_child_environment(), start_new_session=True)
    return RunningJob(job, popen, staging, final, log)


def finish_run(running: RunningJob) -> dict[str, str]:
    """After the process exited: its record, or a ``crashed`` record if it died before writing one."""
    running.log.close()
    code = running.process.returncode
    if not running.staging.exists():  # the process renamed it: its record is complete
        record = read_record(running.final)
        if record is not None:
            return record
        running.staging.mkdir(parents=True)
    if code is not None and code < 0:
        try:
            cause = f"killed by signal {signal.Signals(-code).name}"
        except ValueError:
            cause = f"killed by signal {-code}"
    else:
        cause = f"exited with code {code}"
    last = _last_line(running.staging / WORKER_LOG)
    error = f"run process {cause}" + (f"; last output: {last}" if last else "")
    record = running.job.record("crashed", error)
    record_run(record, running.staging, running.final)
    return read_record(running.final) or {key: as_text(value) for key, value in record.items()}


def _last_line(path: Path, max_chars: int = 300) -> str:
    try:
        with open(path, "rb") as handle:
            handle.seek(max(0, path.stat().st_size - 4096))
            lines = [line.strip() for line in handle.read().decode("utf-8", "replace").splitlines() if line.strip()]
    except OSError:
        return ""
    return lines[-1][:max_chars] if lines else ""


def stop_run(running: RunningJob) -> None:
    """Stop a run that will not be recorded (the batch was interrupted) and remove its staging directory."""
    if running.process.poll() is None:
        _signal_group(running.process, signal.SIGTERM)
        try:
            running.process.wait(_STOP_GRACE_S)
        except subprocess.TimeoutExpired:
            _signal_group(running.process, signal.SIGKILL)
            running.process.wait()
    running.log.close()
    shutil.rmtree(running.staging, ignore_errors=True)


def _signal_group(process: subprocess.Popen | ForkedRun, signum: int) -> None:
    # the run process leads its own session: signal the group, so anything it started stops too
    try:
        os.killpg(process.pid, signum)
    except (ProcessLookupError, PermissionError):
        # no such group yet: a run forked a moment ago that has not called setsid; signal the process itself
        try:
            os.kill(process.pid, signum)
        except (ProcessLookupError, PermissionError):
            pass
