"""Helpers for tests that put graphs on DDS: a domain of their own, waiting, spinning in a thread."""

import threading
import time

from touch_lab.robustness.cases_stray import hold_test_domain

#: A domain id no other process of the suite (or the robustness report's floods) holds: one helper serves both.
allocate_domain = hold_test_domain


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
