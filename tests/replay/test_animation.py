"""``agentic-mpc replay DIR --gif``: a short real run as an animated GIF (agentic_mpc.replay.animation)."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from agentic_mpc.cli import main
from agentic_mpc.replay import load_run
from agentic_mpc.replay.animation import frame_times

EGO_GREEN = np.array([0x16, 0xA3, 0x4A])


def test_a_gif_of_a_short_run_has_one_frame_per_tick_and_every_frame_shows_the_road_and_the_ego(plain_run, tmp_path,
                                                                                                   capsys):
    out = tmp_path / "run.gif"
    assert main(["replay", str(plain_run), "--gif", str(out), "--fps", "5"]) == 0
    assert "frames at 5 fps" in capsys.readouterr().out
    scene = load_run(plain_run)
    track = scene["ego"]["track"]
    expected = int((track[-1][0] - track[0][0]) * 5 + 1e-9) + 1
    assert len(frame_times(scene, 5.0)) == expected >= 15  # 4 s of driving
    with Image.open(out) as gif:
        assert gif.n_frames == expected
        assert out.stat().st_size < 1_000_000
        for index in (0, gif.n_frames // 2, gif.n_frames - 1):
            gif.seek(index)
            pixels = np.asarray(gif.convert("RGB")).reshape(-1, 3).astype(int)
            assert len(np.unique(pixels, axis=0)) > 8  # not blank: road lines, text, footprints
            green = np.abs(pixels - EGO_GREEN).sum(axis=1) < 60
            assert green.sum() > 30  # the ego's footprint is in every frame (the view follows it)


def test_mp4_without_ffmpeg_names_the_missing_tool_and_exits_2(plain_run, tmp_path, monkeypatch, capsys):
    import shutil

    monkeypatch.setattr(shutil, "which", lambda name: None)
    out = tmp_path / "run.mp4"
    assert main(["replay", str(plain_run), "--mp4", str(out)]) == 2
    err = capsys.readouterr().err
    assert "ffmpeg" in err and "--gif" in err and not out.exists()


def test_a_gif_of_a_directory_that_is_not_a_run_exits_2(tmp_path, capsys):
    assert main(["replay", str(tmp_path), "--gif", str(tmp_path / "x.gif")]) == 2
    assert "not a run directory" in capsys.readouterr().err


@pytest.mark.parametrize("fps", ["0", "-1"])
def test_the_frame_rate_must_be_positive(plain_run, tmp_path, fps):
    assert main(["replay", str(plain_run), "--gif", str(tmp_path / "x.gif"), "--fps", fps]) == 2
