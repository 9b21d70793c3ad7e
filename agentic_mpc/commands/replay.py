"""``agentic-mpc replay DIR``: an animated replay of a run as one self-contained HTML page.

The page (default ``DIR/replay.html``) plays the run from its files: a bird's-eye view following the ego with
the road's lanes, every other vehicle's footprint (emergency vehicles flashing), stopped cars and J2's discs,
the MPPI plan where the run recorded one (plan.csv), the passenger's and observation messages and the agent's
tool calls as captions, speed, acceleration and the attached specification. Open it in any browser: no
server, no network. A run that crashed replays up to where its files end.
With --gif FILE (or --mp4 FILE) the run is written instead as a short animation at --fps frames a second
(default 10): the bird's-eye view following the ego, vehicles as footprints, the latest caption. GIFs need
nothing more; MP4 needs ffmpeg on PATH.
Exit status: 0 written, 2 DIR is not a run or its files cannot be read, or ffmpeg missing for --mp4.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

EXIT_BAD_INPUT = 2


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("replay", help="write an animated HTML replay of a run directory",
                                   description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("directory", type=Path, metavar="DIR", help="a run directory (has trajectory.csv)")
    parser.add_argument("--out", type=Path, default=None, metavar="FILE", help="output file (default DIR/replay.html)")
    parser.add_argument("--gif", type=Path, default=None, metavar="FILE", help="write an animated GIF instead")
    parser.add_argument("--mp4", type=Path, default=None, metavar="FILE", help="write an MP4 instead (needs ffmpeg)")
    parser.add_argument("--fps", type=float, default=10.0, help="frames per second of --gif/--mp4 (default 10)")
    parser.set_defaults(handler=run)


def _animate(args: argparse.Namespace) -> int:
    from agentic_mpc.replay import ReplayInputError
    from agentic_mpc.replay.animation import MissingToolError, write_animation

    if args.fps <= 0:
        print("agentic-mpc replay: --fps must be positive", file=sys.stderr)
        return EXIT_BAD_INPUT
    for out in (args.gif, args.mp4):
        if out is None:
            continue
        try:
            frames = write_animation(args.directory, out, fps=args.fps)
        except (ReplayInputError, MissingToolError) as error:
            print(f"agentic-mpc replay: {error}", file=sys.stderr)
            return EXIT_BAD_INPUT
        except OSError as error:
            print(f"agentic-mpc replay: cannot write {out}: {error}", file=sys.stderr)
            return EXIT_BAD_INPUT
        print(f"wrote {out} ({out.stat().st_size / 1e6:.2f} MB, {frames} frames at {args.fps:g} fps)")
    return 0


def run(args: argparse.Namespace) -> int:
    if args.gif is not None or args.mp4 is not None:
        return _animate(args)
    from agentic_mpc.replay import ReplayInputError, load_run, render_page
    from agentic_mpc.run.files import REPLAY

    try:
        scene = load_run(args.directory)
    except ReplayInputError as error:
        print(f"agentic-mpc replay: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    out: Path = args.out if args.out is not None else args.directory / REPLAY
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(render_page(scene), encoding="utf-8")
    except OSError as error:
        print(f"agentic-mpc replay: cannot write {out}: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    for note in scene["notes"]:
        print(f"note: {note}", file=sys.stderr)
    seconds = scene["ego"]["track"][-1][0] - scene["ego"]["track"][0][0]
    print(f"wrote {out} ({out.stat().st_size / 1e6:.2f} MB, {seconds:.1f} s of simulation)")
    return 0
