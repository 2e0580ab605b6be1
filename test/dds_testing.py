"""Helpers for tests that put graphs on DDS: a domain of their own, waiting, spinning in a thread."""

import contextlib
import fcntl
import os
import random
import threading
import time
from pathlib import Path

#: Domain ids tests take; 0 (the default a robot uses) and the low ones people pick by hand are left alone.
TEST_DOMAINS = range(100, 233)
LOCK_DIR = Path('/tmp/social_touch_test_domains')


@contextlib.contextmanager
def allocate_domain():
    """Hold a domain id no other test process on this machine holds (an flock per id); yields it."""
    LOCK_DIR.mkdir(mode=0o700, exist_ok=True)
    candidates = list(TEST_DOMAINS)
    random.shuffle(candidates)
    for domain in candidates:
        fd = os.open(LOCK_DIR / f'{domain}.lock', os.O_CREAT | os.O_RDWR, 0o600)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            continue
        try:
            yield domain
        finally:
            fcntl.flock(fd, fcntl.LOCK_UN)
            os.close(fd)
        return
    raise RuntimeError(f'every test domain id in {TEST_DOMAINS} is held by another test process')


def wait_until(predicate, timeout_s=20.0, what='condition', every_s=0.02):
    """Poll ``predicate`` until true; AssertionError naming ``what`` after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(every_s)
    raise AssertionError(f'timed out after {timeout_s} s waiting for {what}')


class SpinningGraph:
    """A networked context whose executor spins in a thread of its own (for in-process peers)."""

    def __init__(self, clock='wall', **context_kwargs):
        from touch_graph.runtime import Context, SingleThreadedExecutor
        self.context = Context(clock, network=True, **context_kwargs)
        self.context.init()
        self.executor = SingleThreadedExecutor(context=self.context)
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self):
        from touch_graph.runtime import ExternalShutdownException
        try:
            while self.context.ok():
                self.executor.spin_once(0.05)
        except ExternalShutdownException:
            pass

    def call(self, fn, *args):
        """Run ``fn(*args)`` in the executor thread and return its result."""
        done, box = threading.Event(), []

        def run():
            try:
                box.append(fn(*args))
            finally:
                done.set()
        self.executor.call_soon_threadsafe(run)
        assert done.wait(10), 'executor did not run the call'
        return box[0] if box else None

    def add_node(self, name, **kwargs):
        from touch_graph.runtime import Node

        def make():
            node = Node(name, context=self.context, **kwargs)
            self.executor.add_node(node)
            return node
        return self.call(make)

    def view(self):
        return self.context.transport.graph.view()

    def close(self):
        self.context.try_shutdown()
        self.thread.join(10)
