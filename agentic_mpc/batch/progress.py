"""The batch's progress bar."""

from __future__ import annotations

import sys
import time
from typing import IO


class ProgressBar:
    """``[####....] 12/40  ok 10  failed 1  crashed 1  0:32 elapsed  ETA 1:10``: redrawn in place on a
    terminal, one line per finished run otherwise (logs)."""

    def __init__(self, total: int, done: int, stream: IO[str] | None = None, enabled: bool = True) -> None:
        self.total, self.done_before = total, done
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.tty = enabled and self.stream.isatty()
        self.started = time.monotonic()
        self.counts = {"ok": 0, "failed": 0, "crashed": 0}
        self.ran = 0
        self._last_draw = 0.0

    def add(self, status: str) -> None:
        self.ran += 1
        self.counts[status] = self.counts.get(status, 0) + 1
        self.draw(force=True)

    def line(self) -> str:
        done = self.done_before + self.ran
        elapsed = time.monotonic() - self.started
        remaining = self.total - done
        eta = _clock(elapsed / self.ran * remaining) if self.ran and remaining else ("0:00" if not remaining else "--:--")
        filled = round(28 * done / self.total) if self.total else 28
        skipped = f" ({self.done_before} already done)" if self.done_before else ""
        counts = "  ".join(f"{status} {n}" for status, n in self.counts.items())
        return (f"[{'#' * filled}{'.' * (28 - filled)}] {done}/{self.total}{skipped}  {counts}  "
                f"{_clock(elapsed)} elapsed  ETA {eta}")

    def draw(self, force: bool = False) -> None:
        if not self.enabled or (not force and (not self.tty or time.monotonic() - self._last_draw < 0.5)):
            return
        self._last_draw = time.monotonic()
        self.stream.write(f"\r{self.line()}\x1b[K" if self.tty else f"{self.line()}\n")
        self.stream.flush()

    def close(self) -> None:
        if self.tty:
            self.draw(force=True)
            self.stream.write("\n")
            self.stream.flush()


def _clock(seconds: float) -> str:
    seconds = int(round(seconds))
    hours, rest = divmod(seconds, 3600)
    return f"{hours}:{rest // 60:02d}:{rest % 60:02d}" if hours else f"{rest // 60}:{rest % 60:02d}"
