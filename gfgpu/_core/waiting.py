"""One line on stderr when a step the caller cannot see (a kernel build) runs long: a first build on
a machine can take a minute with nothing on screen, while one served from a disk cache takes
milliseconds and says nothing."""

from __future__ import annotations

import sys
import threading
from contextlib import contextmanager

__all__ = ["notice_after"]

_said = set()
_LOCK = threading.Lock()


def _say(text, once):
    with _LOCK:
        if once in _said:
            return
        _said.add(once)
    print(text() if callable(text) else text, file=sys.stderr, flush=True)


@contextmanager
def notice_after(seconds, text, once):
    """Print ``text`` (a string, or a callable returning one) on stderr if the block still runs after
    ``seconds``; at most once per process for each key ``once``."""
    timer = threading.Timer(seconds, _say, (text, once))
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()
