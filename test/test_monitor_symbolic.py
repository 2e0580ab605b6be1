"""The monitor says a bear gesture's decisions (START, END), not its first word (CANDIDATE, WITHDRAWN)."""
import io

from touch_gestures.monitor_node import TouchMonitorNode
from touch_graph.messages import get_message
from touch_graph.runtime import Context

SymbolicGesture = get_message('SymbolicGesture')


def test_candidates_and_withdrawals_are_not_said_to_have_ended():
    context = Context('sim')
    context.init()
    node = TouchMonitorNode(stream=io.StringIO(), context=context)
    try:
        for state in (SymbolicGesture.CANDIDATE, SymbolicGesture.WITHDRAWN, SymbolicGesture.START,
                      SymbolicGesture.END):
            node._on_symbolic(SymbolicGesture(gesture='hug', state=state, duration_s=2.0))
        assert [line.split('bear', 1)[1].strip() for line in node.lines] == ['hug started ()',
                                                                            'hug ended after 2.0 s']
    finally:
        node.destroy_node()
        context.shutdown()
