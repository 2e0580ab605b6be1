"""``node.create_guard_condition``: a trigger from another thread runs the callback in the executor's thread."""

from __future__ import annotations

import threading

from touch_graph.runtime import Context, Node, SingleThreadedExecutor


def _graph():
    ctx = Context('wall', network=False)
    ctx.init()
    node = Node('guarded', context=ctx)
    executor = SingleThreadedExecutor(context=ctx)
    return ctx, node, executor


def test_a_trigger_from_another_thread_runs_the_callback_in_the_spinning_thread() -> None:
    ctx, node, executor = _graph()
    try:
        ran_in: list[int] = []
        guard = node.create_guard_condition(lambda: ran_in.append(threading.get_ident()))
        executor.add_node(node)
        threading.Thread(target=guard.trigger).start()
        assert executor.spin_until(lambda: bool(ran_in), timeout_sec=5.0)
        assert ran_in == [threading.get_ident()]
    finally:
        ctx.shutdown()


def test_triggers_before_the_executor_takes_them_are_one_call() -> None:
    ctx, node, executor = _graph()
    try:
        calls = []
        guard = node.create_guard_condition(lambda: calls.append(1))
        for _ in range(5):
            guard.trigger()                 # before the node joins an executor: run once it does
        executor.add_node(node)
        executor.spin_for(0.05)
        assert calls == [1]
        guard.trigger()
        executor.spin_for(0.05)
        assert calls == [1, 1]
    finally:
        ctx.shutdown()


def test_a_destroyed_condition_runs_nothing() -> None:
    ctx, node, executor = _graph()
    try:
        calls = []
        guard = node.create_guard_condition(lambda: calls.append(1))
        executor.add_node(node)
        assert node.destroy_guard_condition(guard) and not node.destroy_guard_condition(guard)
        guard.trigger()
        executor.spin_for(0.05)
        assert calls == []
    finally:
        ctx.shutdown()
