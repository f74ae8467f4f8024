"""Ctrl-C and SIGTERM as a request to stop at the next chunk boundary.

Inside ``with StopRequests() as stop:`` the first SIGINT or SIGTERM only records itself
(``stop.signal``): the training loop finishes the chunk in flight, saves its checkpoint, logs
the segment and exits with ``stop.exit_code`` (130 for SIGINT, 143 for SIGTERM, the shell's
128 + signal number).  A second SIGINT raises KeyboardInterrupt at once, abandoning the chunk
(the last checkpoint stays).  Outside the main thread, where Python cannot set signal handlers,
it does nothing.  The training loop tells it where the run stands (``at``) so that a second
Ctrl-C can still be reported in one line (``abandoned_line``).
"""
from __future__ import annotations

import contextlib
import signal
import threading
from typing import Optional

_SIGNALS = {signal.SIGINT: "SIGINT", signal.SIGTERM: "SIGTERM"}


class StopRequests:
    """Records the first SIGINT / SIGTERM; restores the previous handlers on exit."""

    def __init__(self):
        self.signal: Optional[str] = None
        self._old: dict = {}
        self.stage: Optional[str] = None  # the stage being trained and its last saved iteration
        self.saved: Optional[int] = None
        self._protected = 0  # depth of protected() blocks
        self._held = False  # a second Ctrl-C arrived inside one

    @property
    def requested(self) -> bool:
        return self.signal is not None

    @property
    def exit_code(self) -> int:
        return 128 + (signal.SIGTERM if self.signal == "SIGTERM" else signal.SIGINT)

    def at(self, stage: str, saved: Optional[int]) -> None:
        """The run is training ``stage``; its last checkpoint is iteration ``saved`` (None: none yet)."""
        self.stage, self.saved = stage, saved

    def abandoned_line(self) -> str:
        """The one line said when a second Ctrl-C abandoned the chunk in flight."""
        if self.stage is None or self.saved is None:
            where = "" if self.stage is None else f" at {self.stage}"
            return f"interrupted{where} before its first checkpoint; nothing of it was saved"
        return f"interrupted at {self.stage} iteration {self.saved}; --resume continues"

    @contextlib.contextmanager
    def protected(self):
        """A block that a second Ctrl-C must not cut (a checkpoint or metrics rows being
        written): its KeyboardInterrupt is held until the block ends."""
        self._protected += 1
        try:
            yield
        finally:
            self._protected -= 1
            if not self._protected and self._held:
                self._held = False
                raise KeyboardInterrupt

    def _handle(self, signum, frame) -> None:
        if self.signal is not None and signum == signal.SIGINT:
            if self._protected:
                self._held = True
                return
            raise KeyboardInterrupt
        if self.signal is None:
            self.signal = _SIGNALS[signum]

    def __enter__(self) -> "StopRequests":
        if threading.current_thread() is threading.main_thread():
            for s in _SIGNALS:
                self._old[s] = signal.signal(s, self._handle)
        return self

    def __exit__(self, *exc) -> None:
        for s, old in self._old.items():
            signal.signal(s, old)
        self._old = {}


__all__ = ["StopRequests"]
