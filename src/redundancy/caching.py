"""The one per-object cache: a value computed once per object, never keeping the object alive.

Example:
    >>> _checkers = PerObject(lambda arm: CollisionChecker(arm))
    >>> _checkers.get(arm)   # built on first use, then shared; dropped with the arm
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Callable
from typing import Generic, TypeVar

K = TypeVar("K")
V = TypeVar("V")


class PerObject(Generic[K, V]):
    """A thread-safe cache of ``factory(key)`` per key object, held weakly by the key.

    The value must not refer to its key strongly (it would keep it alive through the
    cache); give it a ``weakref.proxy`` or the parts of the key it needs. Two threads asking
    for the same key at once get the same value: the factory runs once per key.

    Args:
        factory: Builds the value for a key.
    """

    def __init__(self, factory: Callable[[K], V]) -> None:
        self._factory = factory
        self._values: weakref.WeakKeyDictionary[K, V] = weakref.WeakKeyDictionary()
        self._lock = threading.Lock()

    def get(self, key: K) -> V:
        """The value for ``key``, built on first use."""
        with self._lock:
            value = self._values.get(key)
            if value is None:
                value = self._values[key] = self._factory(key)
        return value
