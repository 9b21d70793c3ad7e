"""The replay page as a file: self-contained, small, written by run, the CLI and batch --replay."""

import re
import subprocess
import sys

from agentic_mpc.replay import write_replay

MAX_BYTES_40S = 2_000_000


def test_run_writes_a_self_contained_page(emergency_run):
    page = emergency_run / "replay.html"
    assert page.is_file()  # outputs.replay is on by default
    text = page.read_text(encoding="utf-8")
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", text, re.I)
    assert "@import" not in text and "url(" not in text
    assert "<script src" not in text and "<link" not in text
    assert "window.replayState" in text and "window.replaySeek" in text
    assert '"ambulance"' in text
    # 15 s here; a 40 s run scales about linearly and must stay well under 2 MB
    assert page.stat().st_size * 40 / 15 < MAX_BYTES_40S / 4


def test_data_cannot_close_the_script_element(plain_run, tmp_path):
    import shutil

    run = tmp_path / "run"
    shutil.copytree(plain_run, run)
    events = (run / "events.csv").read_text()
    (run / "events.csv").write_text(events.replace("Let's try", "</script><script>alert(1)</script> Let's try"))
    text = write_replay(run, tmp_path / "page.html").read_text()
    assert text.count("</script>") == 2  # the data's and the code's own


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "agentic_mpc", "replay", *map(str, args)], capture_output=True,
                          text=True, timeout=120)


def test_cli_writes_the_page(plain_run, tmp_path):
    out = tmp_path / "sub" / "r.html"
    result = _cli(plain_run, "--out", out)
    assert result.returncode == 0, result.stderr
    assert out.is_file() and str(out) in result.stdout


def test_cli_bad_input(tmp_path):
    result = _cli(tmp_path)
    assert result.returncode == 2
    assert "not a run directory" in result.stderr and "trajectory.csv" in result.stderr
    result = _cli(tmp_path / "missing")
    assert result.returncode == 2 and "missing" in result.stderr
    (tmp_path / "trajectory.csv").write_text("time_s,x_m,y_m,phi_rad,v_mps\n0.0,1.0,")
    result = _cli(tmp_path)
    assert result.returncode == 2 and "trajectory.csv" in result.stderr


def test_batch_writes_replays_only_on_request(tmp_path):
    from agentic_mpc.scenario.runner import run_to_directory, run_to_directory_with_replay
    from tests.replay.conftest import SCENARIOS

    file = SCENARIOS / "paper_steering_preference_plain.yaml"
    plain, with_replay = tmp_path / "plain", tmp_path / "with"
    run_to_directory(file, "no_message", 0, plain)
    run_to_directory_with_replay(file, "no_message", 0, with_replay)
    assert not (plain / "replay.html").exists()
    assert (with_replay / "replay.html").is_file()
