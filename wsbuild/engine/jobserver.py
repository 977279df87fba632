"""The GNU make jobserver every package's build shares: one job budget for the whole run (the
local cores; with distributed compiles, the cores plus the remote hosts' slots). wsbuild may
hold tokens back (`hold`) and hand them out one by one (`release`): the memory governor
(engine/memory.py) decides every token that way."""

from __future__ import annotations

import os
import select
import threading
from pathlib import Path


class Jobserver:
    """A GNU make jobserver shared by every package, so N workers never run N×N compilers.

    The tokens live in a named FIFO: GNU make 4.3 gets it as inherited descriptors
    (`makeflags`), Ninja ≥ 1.13 opens it by name (`fifo`, the only form its client takes)."""

    def __init__(self, jobs: int, *, implicit_slot: bool = True) -> None:
        import tempfile

        self._dir = Path(tempfile.mkdtemp(prefix="wsbuild-jobserver-"))
        self.fifo = self._dir / "fifo"
        os.mkfifo(self.fifo, 0o600)
        # read-write: opening does not wait for a writer, and reads block like a pipe's
        self.read_fd = os.open(self.fifo, os.O_RDWR)
        self.write_fd = os.open(self.fifo, os.O_WRONLY)
        os.set_inheritable(self.read_fd, True)
        os.set_inheritable(self.write_fd, True)
        # each running make holds one implicit slot; the FIFO holds the rest of the budget.
        # A gate that is no make (distcc's local gate) has no implicit slot: all in the FIFO
        #: the tokens of the FIFO (the budget less the implicit slot of a make)
        self.tokens = max(0, jobs - 1 if implicit_slot else jobs)
        os.write(self.write_fd, b"+" * self.tokens)
        self._lock = threading.Lock()
        self._to_withhold = 0
        self._withheld = 0
        #: tokens wsbuild holds back, out of circulation (`hold`, `release`, `reclaim`)
        self._held = 0
        self._reader: int | None = None
        self._closing = threading.Event()
        self._taker: threading.Thread | None = None

    def withhold(self, count: int) -> None:
        """Shrink the budget by `count` jobs: that many tokens are taken out of circulation as
        make and Ninja give them back, and kept until `close()` (a build host was lost)."""
        with self._lock:
            self._to_withhold += count
            if self._taker is None:
                self._taker = threading.Thread(target=self._take, name="jobserver-withhold",
                                               daemon=True)
                self._taker.start()

    @property
    def withheld(self) -> int:
        with self._lock:
            return self._withheld

    def hold(self) -> int:
        """Take every token out of the FIFO before any make or Ninja runs: from now on only
        what `release` hands out circulates. Returns how many are held."""
        return self.reclaim(self.tokens)

    def release(self, count: int) -> int:
        """Hand out up to `count` held tokens (into the FIFO); how many went out."""
        with self._lock:
            count = max(0, min(count, self._held))
            self._held -= count
        if count:
            os.write(self.write_fd, b"+" * count)
        return count

    def reclaim(self, count: int) -> int:
        """Take up to `count` tokens that wait unused in the FIFO back (never one a make or
        Ninja holds: those come back when their jobs end); how many were taken."""
        if count <= 0:
            return 0
        with self._lock:
            if self._reader is None:
                self._reader = os.open(self.fifo, os.O_RDONLY | os.O_NONBLOCK)
            try:
                taken = len(os.read(self._reader, count))
            except BlockingIOError:
                taken = 0
            self._held += taken
        return taken

    @property
    def circulating(self) -> int:
        """Tokens out of wsbuild's hands: in the FIFO, or held by a make or Ninja."""
        with self._lock:
            return self.tokens - self._held - self._withheld

    @property
    def held(self) -> int:
        with self._lock:
            return self._held

    def _take(self) -> None:
        fd = os.open(self.fifo, os.O_RDONLY | os.O_NONBLOCK)
        try:
            while not self._closing.is_set():
                with self._lock:
                    wanted = self._to_withhold - self._withheld
                if wanted <= 0:
                    self._closing.wait(0.2)
                    continue
                readable, _, _ = select.select([fd], [], [], 0.2)
                if not readable:
                    continue
                try:
                    taken = len(os.read(fd, wanted))
                except BlockingIOError:  # a make or Ninja was quicker
                    continue
                with self._lock:
                    self._withheld += taken
        finally:
            os.close(fd)

    @property
    def makeflags(self) -> str:
        return f"-j --jobserver-auth={self.read_fd},{self.write_fd}"

    @property
    def fds(self) -> tuple[int, int]:
        return (self.read_fd, self.write_fd)

    def close(self) -> None:
        self._closing.set()
        if self._taker is not None:
            self._taker.join()
        if self._reader is not None:
            os.close(self._reader)
        os.close(self.read_fd)
        os.close(self.write_fd)
        import shutil

        shutil.rmtree(self._dir, ignore_errors=True)
