"""The batch runner: real run processes (``tests/batch/batch_runners.py``), real files, real signals."""

from __future__ import annotations

import csv
import fcntl
import io
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from agentic_mpc import cli
from agentic_mpc.batch import BatchInputError, BatchSpec, ProgressBar, run_batch
from tests.batch.batch_runners import GATE_ENV, RUN_LOG_ENV, faulty_run, obstacle_run, quick_run, ran

REPO = Path(__file__).resolve().parents[2]
NETS = REPO / "sumo_nets"
RUNNERS = "tests.batch.batch_runners"


def scenario_yaml(directory: Path, name: str, variants: tuple[str, ...] = (), duration_s: float = 4.0,
                  extra: str = "") -> Path:
    text = (
        f"name: {name}\n"
        "simulation:\n"
        f"  net_file: {NETS / 'straight.net.xml'}\n"
        f"  route_files: [{NETS / 'straight.rou.xml'}]\n"
        "  road: straight\n"
        "specification:\n"
        "  path_tracking: {v_ref_mps: 15}\n"
        f"duration_s: {duration_s}\n{extra}"
    )
    if variants:
        text += "variants:\n" + "".join(f"  {v}: {{}}\n" for v in variants)
    file = directory / f"{name}.yaml"
    file.write_text(text)
    return file


def read_summary(out: Path) -> list[dict[str, str]]:
    with open(out / "summary.csv", newline="") as handle:
        return list(csv.DictReader(handle))


@pytest.fixture
def run_log(tmp_path, monkeypatch) -> Path:
    """Run processes inherit the environment: each run appends '<variant> <seed>' here when it starts."""
    log = tmp_path / "ran.txt"
    monkeypatch.setenv(RUN_LOG_ENV, str(log))
    return log


def test_real_simulations_one_process_each_sorted_summary_and_same_seed_same_result(tmp_path, run_log):
    file = scenario_yaml(tmp_path, "obstacle", ("no_message", "message_right", "message_left"))
    out = tmp_path / "out"
    started = time.perf_counter()
    result = run_batch(BatchSpec(files=(file,), trials=2, workers=2, out_dir=out), runner=obstacle_run, progress=False)
    elapsed_s = time.perf_counter() - started
    print(f"6 Scenario 1 runs, 2 workers: {elapsed_s:.1f} s")

    rows = read_summary(out)
    assert rows == result.rows and result.all_ok and result.ran == 6 and result.skipped == 0
    assert [(r["variant"], r["seed"]) for r in rows] == [
        (v, s) for v in ("message_left", "message_right", "no_message") for s in ("0", "1")
    ]
    assert list(rows[0])[:5] == ["scenario", "variant", "seed", "status", "error"]
    assert {r["status"] for r in rows} == {"ok"} and {r["scenario"] for r in rows} == {"obstacle"}
    for row in rows:  # the run function's columns come through, and each run left its files in its directory
        run_dir = out / "runs" / "obstacle" / row["variant"] / f"seed-{row['seed']}"
        assert (run_dir / "trajectory.csv").stat().st_size > 1000
        with open(run_dir / "summary.csv", newline="") as handle:
            assert list(csv.DictReader(handle)) == [row]
    assert {r["obstacle_side"] for r in rows if r["variant"] == "message_left"} == {"left"}
    assert {r["obstacle_side"] for r in rows if r["variant"] == "message_right"} == {"right"}
    pids = {r["pid"] for r in rows}
    assert len(pids) == 6 and str(os.getpid()) not in pids  # a fresh process per simulation
    assert not list(out.glob("runs/**/.seed-*"))  # no staging directories left

    # the same job again, alone, in another batch: the same result (the batch adds no randomness)
    again = run_batch(BatchSpec(files=(file,), trials=1, first_seed=1, variants=("message_left",), workers=1,
                                out_dir=tmp_path / "again"), runner=obstacle_run, progress=False).rows
    original = next(r for r in rows if r["variant"] == "message_left" and r["seed"] == "1")
    for key in ("obstacle_side", "min_clearance_m", "final_x_m"):
        assert again[0][key] == original[key]


def test_crashed_and_failed_runs_are_recorded_the_others_go_on_and_a_rerun_retries_only_them(tmp_path, run_log):
    file = scenario_yaml(tmp_path, "plain")
    out = tmp_path / "out"
    spec = BatchSpec(files=(file,), trials=6, workers=2, out_dir=out)
    result = run_batch(spec, runner=faulty_run, progress=False)

    rows = read_summary(out)
    assert [r["seed"] for r in rows] == ["0", "1", "2", "3", "4", "5"] and not result.all_ok
    status = {int(r["seed"]): (r["status"], r["error"]) for r in rows}
    assert status[0] == status[4] == status[5] == ("ok", "")
    assert status[1] == ("crashed", "run process exited with code 3; last output: libsumo: giving up")
    assert status[2] == ("crashed", "run process killed by signal SIGKILL")
    assert status[3] == ("failed", "ValueError: the ego left the road (seed 3)")
    assert "Traceback" in (out / "runs/plain/base/seed-3/worker.log").read_text()
    assert rows[0]["seed_squared"] == "0" and rows[1]["seed_squared"] == ""

    # resume (here with a run function that no longer fails): only the three unfinished runs run again
    ran_before = len(ran(run_log))
    result = run_batch(spec, runner=quick_run, progress=False)
    assert sorted(ran(run_log)[ran_before:]) == [("base", 1), ("base", 2), ("base", 3)]
    assert result.all_ok and result.skipped == 3 and result.ran == 3
    assert [r["status"] for r in read_summary(out)] == ["ok"] * 6
    assert not (out / "runs/plain/base/seed-3/worker.log").exists()  # the retry replaced the failed record


def test_runs_of_an_edited_scenario_file_are_not_taken_for_its_results(tmp_path, run_log):
    file = scenario_yaml(tmp_path, "plain")
    spec = BatchSpec(files=(file,), trials=2, workers=2, out_dir=tmp_path / "out")
    first = run_batch(spec, runner=quick_run, progress=False).rows
    assert run_batch(spec, runner=quick_run, progress=False).ran == 0  # unchanged: nothing to do
    file.write_text(file.read_text().replace("duration_s: 4.0", "duration_s: 5.0"))
    again = run_batch(spec, runner=quick_run, progress=False)
    assert again.ran == 2 and again.skipped == 0 and len(ran(run_log)) == 4
    assert list(again.rows[0])[-1] == "scenario_sha256"
    assert {r["scenario_sha256"] for r in again.rows}.isdisjoint({r["scenario_sha256"] for r in first})


def test_bad_input_fails_before_any_run_naming_file_variant_and_argument(tmp_path, run_log, capsys):
    good = scenario_yaml(tmp_path, "good", ("calm", "busy"))
    broken = scenario_yaml(tmp_path, "broken", extra="seed: -4\n")
    out = tmp_path / "out"

    def bad(*argv: str, out: Path = out) -> str:
        capsys.readouterr()
        code = cli.main(["batch", "--out", str(out), "--runner", f"{RUNNERS}:quick_run", "--no-progress", *argv])
        assert code == 2
        return capsys.readouterr().err

    error = bad(str(good), str(broken), str(tmp_path / "missing.yaml"), "--variants", "calm", "stormy", "--trials", "2")
    assert f"{good}: unknown variant 'stormy'; variants: calm, busy" in error
    assert "broken.yaml:9: seed: Input should be greater than or equal to 0" in error
    assert "missing.yaml: cannot read" in error
    twin = tmp_path / "twin"
    twin.mkdir()
    assert "scenario name 'good' is also the name of" in bad(str(good), str(scenario_yaml(twin, "good")), "--trials", "1")
    assert "cannot import the run function" in bad(str(good), "--trials", "1", "--runner", "nowhere:run")
    (tmp_path / "a_file").write_text("")
    assert "--out " + str(tmp_path / "a_file") + ": exists and is not a directory" in bad(
        str(good), "--trials", "1", out=tmp_path / "a_file"
    )
    assert not out.exists() and ran(run_log) == []  # nothing started
    assert "--executor dask needs --scheduler" in bad(str(good), "--trials", "1", "--executor", "dask")

    for argv, message in (
        (["--trials", "-3"], "argument --trials: must be at least 1, got -3"),
        (["--trials", "0"], "argument --trials: must be at least 1, got 0"),
        ([], "the following arguments are required: --trials"),
        (["--trials", "2", "--first-seed", "-1"], "argument --first-seed: must be at least 0, got -1"),
        (["--trials", "2", "--workers", "0"], "argument --workers: must be at least 1, got 0"),
    ):
        with pytest.raises(SystemExit) as exit_:
            cli.main(["batch", str(good), *argv, "--out", str(out)])
        assert exit_.value.code == 2 and message in capsys.readouterr().err
    assert not out.exists() and ran(run_log) == []  # nothing started


def test_the_spec_and_the_run_function_are_checked_too(tmp_path):
    with pytest.raises(BatchInputError) as error:
        BatchSpec(files=(), trials=-1, first_seed=-2, workers=0, scheduler="tcp://x:1")
    assert error.value.problems == [
        "no scenario file given", "--trials must be at least 1, got -1",
        "--first-seed must be 0 or more (seeds are non-negative), got -2", "--workers must be at least 1, got 0",
        "--scheduler is only used with --executor dask",
    ]
    file = scenario_yaml(tmp_path, "plain")
    with pytest.raises(BatchInputError, match="must be a module-level function"):
        run_batch(BatchSpec(files=(file,), trials=1, out_dir=tmp_path / "out"), runner=lambda *a: {})


def test_dask_executor_without_dask_says_how_to_install_it(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # what `import distributed` sees without the extra
    spec = BatchSpec(files=(scenario_yaml(tmp_path, "plain"),), trials=1, out_dir=tmp_path / "out",
                     executor="dask", scheduler="tcp://127.0.0.1:8786")
    with pytest.raises(BatchInputError, match=r'pip install "agentic-mpc\[dask\]"'):
        run_batch(spec, runner=quick_run)
    assert not (tmp_path / "out").exists()


def test_one_batch_per_output_directory(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    with open(out / ".batch.lock", "a") as held:
        fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)  # as a running batch holds it
        with pytest.raises(BatchInputError, match="another batch is running"):
            run_batch(BatchSpec(files=(scenario_yaml(tmp_path, "plain"),), trials=1, out_dir=out), runner=quick_run)


def test_progress_bar_counts_and_estimates():
    stream = io.StringIO()
    bar = ProgressBar(total=4, done=1, stream=stream)
    bar.draw(force=True)
    bar.add("ok")
    bar.add("crashed")
    lines = stream.getvalue().splitlines()
    assert lines[0].startswith("[#######.....................] 1/4 (1 already done)  ok 0  failed 0  crashed 0")
    assert lines[0].endswith("ETA --:--")
    assert "3/4 (1 already done)  ok 1  failed 0  crashed 1  0:00 elapsed  ETA 0:00" in lines[-1]

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    terminal = Terminal()
    bar = ProgressBar(total=2, done=0, stream=terminal)
    bar.add("ok")
    bar.add("failed")
    bar.close()
    assert terminal.getvalue().count("\r") == 3 and terminal.getvalue().endswith("ETA 0:00\x1b[K\n")  # one line


# ---------------------------------------------------------------------------------------------------------
# the command as a user runs it, interrupted and killed


def start_cli(tmp_path: Path, file: Path, out: Path, trials: int, gate: Path, log: Path) -> subprocess.Popen:
    # PYTHONFAULTHANDLER: a batch that does not stop can be made to print every thread's stack (below)
    env = {**os.environ, GATE_ENV: str(gate), RUN_LOG_ENV: str(log), "PYTHONPATH": str(REPO), "PYTHONFAULTHANDLER": "1"}
    return subprocess.Popen(
        [sys.executable, "-m", "agentic_mpc", "batch", str(file), "--trials", str(trials), "--workers", "2",
         "--out", str(out), "--runner", f"{RUNNERS}:gated_run"],
        cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )


def wait_for(condition, timeout_s: float = 30.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.05)


def gated_runs_started(out: Path, gate: Path) -> bool:
    """Seeds 0 and 1 finished, seeds 2 and 3 running (waiting at the gate)."""
    finished = all((out / f"runs/plain/base/seed-{s}/summary.csv").exists() for s in (0, 1))
    return finished and all((gate / f"started-{s}").exists() for s in (2, 3))


def alive(pid: int) -> bool:
    try:
        return not Path(f"/proc/{pid}/stat").read_text().split()[2] == "Z"
    except OSError:
        return False


def stacks_of(batch: subprocess.Popen) -> str:
    """The batch's threads' stacks (faulthandler on SIGABRT), with the processes it started, for a failure
    that happened once in a while in the full suite and never alone."""
    tree = subprocess.run(["ps", "-o", "pid,ppid,pgid,stat,etime,args", "--ppid", str(batch.pid)],
                          capture_output=True, text=True).stdout
    batch.send_signal(signal.SIGABRT)
    try:
        _, stderr = batch.communicate(timeout=10)
    except subprocess.TimeoutExpired:
        stderr = "(no stacks within 10 s of SIGABRT)"
    return f"{stderr[-6000:]}\nits children:\n{tree}"


@pytest.mark.timing
def test_ctrl_c_stops_the_runs_keeps_what_finished_and_the_rerun_resumes(tmp_path):
    file, out, gate, log = scenario_yaml(tmp_path, "plain"), tmp_path / "out", tmp_path / "gate", tmp_path / "ran.txt"
    gate.mkdir()
    batch = start_cli(tmp_path, file, out, 5, gate, log)
    try:
        wait_for(lambda: gated_runs_started(out, gate))
        pids = [int((gate / f"started-{s}").read_text()) for s in (2, 3)]
        interrupted_at = time.monotonic()
        batch.send_signal(signal.SIGINT)
        try:
            stdout, stderr = batch.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            pytest.fail(f"the batch did not stop within 20 s of Ctrl-C; where it was:\n{stacks_of(batch)}")
        stop_s = time.monotonic() - interrupted_at
    finally:
        (gate / "open").touch()
        batch.kill()
    print(f"Ctrl-C to exit: {stop_s:.2f} s")
    assert batch.returncode == 130, stderr
    assert "interrupted: run the same command again to resume" in stderr
    assert [(r["seed"], r["status"]) for r in read_summary(out)] == [("0", "ok"), ("1", "ok")]
    assert not any(alive(pid) for pid in pids)  # the runs in flight were stopped, not left running
    assert sorted(p.name for p in (out / "runs/plain/base").iterdir()) == ["seed-0", "seed-1"]  # no half runs

    rerun = start_cli(tmp_path, file, out, 5, gate, log)
    stdout, stderr = rerun.communicate(timeout=60)
    assert rerun.returncode == 0, stderr
    assert "5 of 5 runs recorded (5 ok); 3 ran now, 2 were already done" in stdout
    assert "5/5 (2 already done)" in stderr  # the progress bar
    assert sorted(ran(log)) == [("base", s) for s in range(5)]  # 0 and 1 were not run again
    assert [r["status"] for r in read_summary(out)] == ["ok"] * 5


def test_a_killed_batch_loses_no_finished_run(tmp_path):
    file, out, gate, log = scenario_yaml(tmp_path, "plain"), tmp_path / "out", tmp_path / "gate", tmp_path / "ran.txt"
    gate.mkdir()
    batch = start_cli(tmp_path, file, out, 5, gate, log)
    try:
        wait_for(lambda: gated_runs_started(out, gate))
        batch.kill()  # SIGKILL: no chance to write anything
        batch.communicate(timeout=10)
        (out / "summary.csv").unlink(missing_ok=True)  # even without the batch's summary
    finally:
        (gate / "open").touch()
    # the runs in flight outlive the batch and record their results
    wait_for(lambda: all((out / f"runs/plain/base/seed-{s}/summary.csv").exists() for s in (2, 3)))

    rerun = start_cli(tmp_path, file, out, 5, gate, log)
    stdout, stderr = rerun.communicate(timeout=60)
    assert rerun.returncode == 0, stderr
    assert "4 were already done" in stdout
    assert sorted(ran(log)) == [("base", s) for s in range(5)]  # nothing ran twice
    assert [(r["seed"], r["status"]) for r in read_summary(out)] == [(str(s), "ok") for s in range(5)]


def test_a_fork_server_that_dies_at_its_warm_up_costs_speed_not_runs(tmp_path):
    """The warm-up module raises (as an invalid configuration default did): the server dies before the first
    fork. The batch says so once and starts its runs in fresh interpreters; every run is recorded."""
    (tmp_path / "broken_warm_up.py").write_text("raise ValueError('a default that does not validate')\n")
    file, out = scenario_yaml(tmp_path, "plain"), tmp_path / "out"
    script = (
        "from agentic_mpc.batch import launch, BatchSpec, run_batch\n"
        "launch.WARM_START_MODULE = 'broken_warm_up'\n"
        f"spec = BatchSpec(files=({str(file)!r},), trials=3, workers=2, out_dir={str(out)!r})\n"
        f"result = run_batch(spec, runner='{RUNNERS}:quick_run', progress=False)\n"
        "print([row['status'] for row in result.rows])\n"
    )
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join((str(tmp_path), str(REPO)))}  # the server's too
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=REPO, timeout=120,
                          env=environment)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "['ok', 'ok', 'ok']"
    assert done.stderr.count("the fork server stopped") == 1
    assert "Traceback" not in done.stderr
    assert "import broken_warm_up" in done.stderr


# ---------------------------------------------------------------------------------------------------------
# Dask


@pytest.fixture(scope="module")
def dask_scheduler():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(processes=True, n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster:
        yield cluster.scheduler_address


def test_dask_cluster_runs_the_same_batch_with_crashes_recorded_and_files_shipped_back(tmp_path, dask_scheduler):
    file = scenario_yaml(tmp_path, "plain")
    out = tmp_path / "out"
    spec = BatchSpec(files=(file,), trials=5, out_dir=out, executor="dask", scheduler=dask_scheduler)
    result = run_batch(spec, runner=faulty_run, progress=False)
    status = {int(r["seed"]): (r["status"], r["error"]) for r in read_summary(out)}
    assert status == {
        0: ("ok", ""), 1: ("crashed", "run process exited with code 3; last output: libsumo: giving up"),
        2: ("crashed", "run process killed by signal SIGKILL"), 3: ("failed", "ValueError: the ego left the road (seed 3)"),
        4: ("ok", ""),
    }
    assert result.rows == read_summary(out)
    assert (out / "runs/plain/base/seed-4/result.txt").read_text() == "base 4\n"  # written on a worker, shipped back
    assert "Traceback" in (out / "runs/plain/base/seed-3/worker.log").read_text()

    result = run_batch(spec, runner=quick_run, progress=False)  # resume on the cluster
    assert result.all_ok and result.skipped == 2 and result.ran == 3


def test_dask_and_local_processes_give_the_same_simulation_result(tmp_path, dask_scheduler):
    file = scenario_yaml(tmp_path, "obstacle", ("message_left",), duration_s=3.0)
    rows = {}
    for executor, scheduler in (("process", None), ("dask", dask_scheduler)):
        spec = BatchSpec(files=(file,), trials=1, first_seed=7, workers=1, out_dir=tmp_path / executor,
                         executor=executor, scheduler=scheduler)
        rows[executor] = run_batch(spec, runner=obstacle_run, progress=False).rows
    assert len(rows["dask"]) == 1 and rows["dask"][0]["status"] == "ok"
    drop = {"pid", "wall_s"}
    assert {k: v for k, v in rows["dask"][0].items() if k not in drop} == {
        k: v for k, v in rows["process"][0].items() if k not in drop
    }
    assert (tmp_path / "dask/runs/obstacle/message_left/seed-7/trajectory.csv").read_bytes() == (
        tmp_path / "process/runs/obstacle/message_left/seed-7/trajectory.csv"
    ).read_bytes()


def test_unreachable_dask_scheduler_is_bad_input(tmp_path, monkeypatch):
    pytest.importorskip("distributed")
    from agentic_mpc.batch import executors

    monkeypatch.setattr(executors, "DASK_CONNECT_TIMEOUT_S", 1.0)  # the default waits 10 s for a slow cluster
    spec = BatchSpec(files=(scenario_yaml(tmp_path, "plain"),), trials=1, out_dir=tmp_path / "out",
                     executor="dask", scheduler="tcp://127.0.0.1:9")
    with pytest.raises(BatchInputError, match="cannot reach the Dask scheduler"):
        run_batch(spec, runner=quick_run)
    assert not (tmp_path / "out").exists()

