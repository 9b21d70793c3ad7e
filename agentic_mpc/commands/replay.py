"""``agentic-mpc replay DIR``: an animated replay of a run as one self-contained HTML page.

The page (default ``DIR/replay.html``) plays the run from its files: a bird's-eye view following the ego with
the road's lanes, every other vehicle's footprint (emergency vehicles flashing), stopped cars and J2's discs,
the MPPI plan where the run recorded one (plan.csv), the passenger's and observation messages and the agent's
tool calls as captions, speed, acceleration and the attached specification. Open it in any browser: no
server, no network. A run that crashed replays up to where its files end.
Exit status: 0 written, 2 DIR is not a run or its files cannot be read.
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
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from agentic_mpc.replay import ReplayInputError, load_run, render_page

    try:
        scene = load_run(args.directory)
    except ReplayInputError as error:
        print(f"agentic-mpc replay: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    out: Path = args.out if args.out is not None else args.directory / "replay.html"
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
