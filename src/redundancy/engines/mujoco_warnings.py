"""MuJoCo's warnings collected per thread instead of printed and written to MUJOCO_LOG.TXT.

MuJoCo's warning callback is process-wide; `captured_warnings` (re-exported by
`redundancy.engines.mujoco`) swaps in a relay that hands each warning to the capture of the
thread that warned.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
from collections.abc import Callable, Iterator

import mujoco

__all__ = ["captured_warnings"]


class _WarningRelay:
    """MuJoCo's warning callback while any thread captures warnings.

    The callback is process-wide; MuJoCo calls it in the thread that warns. The relay is
    installed by the first capture and the user's callback put back by the last (a lock and
    a count, so any number of threads leave it exactly as the user had it). A warning from
    a thread that is not capturing goes where it would have gone without the relay: the
    user's callback, or MuJoCo's default (MUJOCO_LOG.TXT and a line on stdout).
    """

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.captures: dict[int, list[list[str]]] = {}  # thread id -> nested captures
        self.count = 0
        self.users: Callable[[str], object] | None = None

    def __call__(self, msg: str) -> None:
        stack = self.captures.get(threading.get_ident())
        if stack:
            stack[-1].append(str(msg).strip())
        elif self.users is not None:
            self.users(msg)
        else:
            mujoco.mju_writeLog("WARNING", str(msg))
            sys.stdout.write(f"WARNING: {msg}\n\n")

    @contextlib.contextmanager
    def capture(self) -> Iterator[list[str]]:
        messages: list[str] = []
        me = threading.get_ident()
        with self.lock:
            if self.count == 0:
                self.users = mujoco.get_mju_user_warning()
                mujoco.set_mju_user_warning(self)
            self.count += 1
            self.captures.setdefault(me, []).append(messages)
        try:
            yield messages
        finally:
            with self.lock:
                stack = self.captures[me]
                stack.pop()
                if not stack:
                    del self.captures[me]
                self.count -= 1
                # A callback the user set meanwhile is theirs to keep.
                if self.count == 0 and mujoco.get_mju_user_warning() is self:
                    mujoco.set_mju_user_warning(self.users)
                if self.count == 0:
                    self.users = None

    def after_fork(self) -> None:
        """In a forked child: only the forking thread survives, with its own captures."""
        self.lock = threading.Lock()  # another thread may have held it at the fork
        mine = self.captures.get(threading.get_ident(), [])
        self.captures = {threading.get_ident(): mine} if mine else {}
        self.count = len(mine)
        if self.count == 0 and mujoco.get_mju_user_warning() is self:
            mujoco.set_mju_user_warning(self.users)
            self.users = None


_RELAY = _WarningRelay()
os.register_at_fork(after_in_child=_RELAY.after_fork)


def captured_warnings() -> contextlib.AbstractContextManager[list[str]]:
    """Collect MuJoCo's warnings instead of letting it print them and write MUJOCO_LOG.TXT.

    Only this thread's warnings are collected; MuJoCo's callback is the user's again when
    the last capture in any thread ends.
    """
    return _RELAY.capture()
