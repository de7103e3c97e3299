"""Ctrl-C and SIGTERM during training: finish the epoch in flight, save it, then stop.

The jitted epoch donates its input carry, so a KeyboardInterrupt raised inside it leaves no
carry to save: every epoch since the last checkpoint would be lost. `deferred_stop` turns
the first SIGINT / SIGTERM into a request the host loop reads between epochs; a second one
stops at once (losing only the epoch in flight and what the last checkpoint lacks), except
while a checkpoint is written (`StopRequest.shielded`): then it stops once the checkpoint
and its digest are whole.
"""

from __future__ import annotations

import contextlib
import signal
import sys
import threading
from collections.abc import Iterator

SIGNALS = (signal.SIGINT, signal.SIGTERM)


INTERRUPTED = 130
"""Exit status of a command stopped by Ctrl-C or SIGTERM before its work was done (128 +
SIGINT): train, build_library and sweep."""


class StopRequest:
    """Set by the first SIGINT / SIGTERM: `signal` holds its number (None until then)."""

    def __init__(self) -> None:
        self.signal: int | None = None
        self._shielded = False
        self._held = False

    def __bool__(self) -> bool:
        return self.signal is not None

    def handle(self, signum: int, frame) -> None:
        if self.signal is not None:  # the second signal: stop now (or once shielded work ends)
            if not self._shielded:
                raise KeyboardInterrupt
            self._held = True
            print("stopping once the checkpoint is written", file=sys.stderr, flush=True)
            return
        self.signal = signum
        print(
            f"\n{signal.Signals(signum).name}: stopping after the epoch in progress, then "
            "saving it (send it again to stop at once, losing that epoch)",
            file=sys.stderr,
            flush=True,
        )

    @contextlib.contextmanager
    def shielded(self) -> Iterator[None]:
        """Within (a checkpoint being written): a second signal waits for the end of the
        block, then raises KeyboardInterrupt; a half-written checkpoint is never left."""
        self._shielded = True
        try:
            yield
        finally:
            self._shielded = False
        if self._held:
            raise KeyboardInterrupt


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
