"""Fan-out of worker events to any number of subscribers, with a bounded history for late joiners."""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import queue
import threading
import time
from collections import deque
from typing import Any

from robot.interface import Event, Level

HISTORY = 500
SUBSCRIBER_QUEUE = 2000


class Subscription:
    """A subscriber's queue. A slow subscriber loses its oldest events, never blocks the publisher."""

    def __init__(self, bus: EventBus) -> None:
        self._bus = bus
        self._queue: queue.Queue[Event] = queue.Queue(maxsize=SUBSCRIBER_QUEUE)

    def put(self, event: Event) -> None:
        while True:
            try:
                self._queue.put_nowait(event)
                return
            except queue.Full:
                with contextlib.suppress(queue.Empty):
                    self._queue.get_nowait()

    def get(self, timeout: float | None = None) -> Event | None:
        try:
            return self._queue.get(timeout=timeout)
        except queue.Empty:
            return None

    def close(self) -> None:
        self._bus.unsubscribe(self)


class EventBus:
    def __init__(self, sim_clock: Any = None) -> None:
        self._lock = threading.Lock()
        self._seq = itertools.count(1)
        self._subscribers: list[Subscription] = []
        self._history: deque[Event] = deque(maxlen=HISTORY)
        self._sim_clock = sim_clock or (lambda: 0.0)

    def publish(self, kind: str, message: str, level: Level = Level.OK, **data: Any) -> Event:
        with self._lock:
            event = Event(next(self._seq), kind, message, level, time.time(), float(self._sim_clock()), data)
            self._history.append(event)
            subscribers = list(self._subscribers)
        for subscriber in subscribers:
            subscriber.put(event)
        return event

    def forward(self, event: Event, renumber: bool = False) -> Event:
        """Re-publish an event that was made elsewhere (e.g. by the worker in its own process). `renumber`: give it
        this bus's next number (a restarted producer numbers from 1 again; subscribers must never see a number
        twice)."""
        with self._lock:
            if renumber:
                event = dataclasses.replace(event, seq=next(self._seq))
            self._history.append(event)
            subscribers = list(self._subscribers)
        for subscriber in subscribers:
            subscriber.put(event)
        return event

    def clear_history(self) -> None:
        """Late joiners from now on start from here (a new session after a restart does not inherit the old one's)."""
        with self._lock:
            self._history.clear()

    def subscribe(self) -> Subscription:
        subscription = Subscription(self)
        with self._lock:
            self._subscribers.append(subscription)
        return subscription

    def unsubscribe(self, subscription: Subscription) -> None:
        with self._lock:
            if subscription in self._subscribers:
                self._subscribers.remove(subscription)

    def history(self) -> list[Event]:
        with self._lock:
            return list(self._history)
