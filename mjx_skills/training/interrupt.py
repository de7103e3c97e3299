"""Ctrl-C and SIGTERM during training: finish the epoch in flight, save it, then stop.

The jitted epoch donates its input carry, so a KeyboardInterrupt raised inside it leaves no
carry to save: every epoch since the last checkpoint would be lost. `deferred_stop` turns
the first SIGINT / SIGTERM into a request the host loop reads between epochs; a second one
stops at once (losing only the epoch in flight and what the last checkpoint lacks).
"""

from __future__ import annotations

import contextlib
import signal
import sys
import threading
from collections.abc import Iterator

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class StopRequest:
    """Set by the first SIGINT / SIGTERM: `signal` holds its number (None until then)."""

    def __init__(self) -> None:
        self.signal: int | None = None

    def __bool__(self) -> bool:
        return self.signal is not None

    def handle(self, signum: int, frame) -> None:
        if self.signal is not None:  # the second signal: stop now
            raise KeyboardInterrupt
        self.signal = signum
        print(
            f"\n{signal.Signals(signum).name}: stopping after the epoch in progress, then "
            "saving it (send it again to stop at once, losing that epoch)",
            file=sys.stderr,
            flush=True,
        )


@contextlib.contextmanager
def deferred_stop() -> Iterator[StopRequest]:
    """Within: SIGINT / SIGTERM set the yielded request instead of raising (only in the main
    thread, where Python delivers signals; elsewhere the request stays unset)."""
    request = StopRequest()
    if threading.current_thread() is not threading.main_thread():
        yield request
        return
    previous = {s: signal.signal(s, request.handle) for s in SIGNALS}
    try:
        yield request
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
