"""A one-line progress display: episodes done, rate, time left, success so far, errors."""
from __future__ import annotations

import sys
import time
from typing import Optional, TextIO


def _duration(seconds: float) -> str:
    seconds = int(max(0, seconds))
    h, rest = divmod(seconds, 3600)
    m, s = divmod(rest, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m:02d}:{s:02d}"


class Progress:
    def __init__(self, total: int, already: int = 0, stream: Optional[TextIO] = None, enabled: bool = True,
                 clock=time.monotonic):
        self.total, self.already = total, already
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = enabled
        self.clock = clock
        self.start = clock()
        self.done = self.ok = self.success = self.errors = self.unavailable = 0

    def update(self, row: dict) -> None:
        self.done += 1
        status = row.get("status")
        if status == "ok":
            self.ok += 1
            self.success += int(bool(row.get("success")))
        elif status == "unavailable":
            self.unavailable += 1
        else:
            self.errors += 1
        if self.enabled:
            end = "\n" if self.done == self.total or not self.stream.isatty() else ""
            self.stream.write("\r" + self.line() + end)
            self.stream.flush()

    def line(self) -> str:
        elapsed = self.clock() - self.start
        rate = self.done / elapsed * 3600 if elapsed > 0 else 0.0
        left = (self.total - self.done) / (self.done / elapsed) if self.done and elapsed > 0 else float("nan")
        sr = f"{100 * self.success / self.ok:.1f}% of {self.ok}" if self.ok else "-"
        eta = _duration(left) if left == left else "--:--"
        extra = f", {self.errors} error(s)" if self.errors else ""
        extra += f", {self.unavailable} unavailable" if self.unavailable else ""
        return (f"episodes {self.done + self.already}/{self.total + self.already} | {rate:.0f}/h | "
                f"left {eta} | success {sr}{extra}")
