"""Feed ``bear_gestures`` frames with one impossible level (synthetic) and count what it makes of them."""

from __future__ import annotations

import numpy as np

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.node import BearGesturesNode
from touch_graph.messages import get_message
from touch_graph.runtime import Context, Node, Parameter, SingleThreadedExecutor

__all__ = ['feed_levels']

RATE_HZ = 3.4
EPOCH_S = 1_700_000_000


def feed_levels(level: float, seconds: float = 2.0, channel: int = 5) -> tuple[int, int]:
    """``level`` on ``channel`` for ``seconds`` of bear frames at 3.4 Hz, between two quiet frames.
    Returns (frames the node skipped, /touch/subtype and /touch/symbolic messages it published)."""
    BearFrame = get_message('BearFrame')
    Header = get_message('std_msgs/msg/Header')
    Time = get_message('builtin_interfaces/msg/Time')
    fitted = BodyMap.default().fitted_mask().tolist()  # bool[64]: Python bools, as rclpy needs
    ctx = Context('sim')
    ctx.init()
    try:
        node = BearGesturesNode(context=ctx, namespace='bear',
                                parameter_overrides=[Parameter('subtype_classifier', value='rule')])
        feeder = Node('feeder', context=ctx)
        pub = feeder.create_publisher(BearFrame, '/bear/frame', 100)
        events: list = []
        for topic, kind in (('subtype', 'TouchSubtype'), ('symbolic', 'SymbolicGesture')):
            feeder.create_subscription(get_message(kind), f'/touch/{topic}', events.append, 1000)
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(node)
        executor.add_node(feeder)
        n = int(seconds * RATE_HZ) + 2
        for i in range(n):
            levels = np.zeros(64, np.float32)
            if 0 < i < n - 1:
                levels[channel] = level
            ns = round(i / RATE_HZ * 1e9)
            header = Header(stamp=Time(sec=EPOCH_S + ns // 10**9, nanosec=ns % 10**9), frame_id='bear_link')
            pub.publish(BearFrame(header=header, sequence=i, level=levels, active=(levels >= 0.3).tolist(),
                                  fitted=fitted, faults=np.zeros(64, np.uint8)))
            executor.spin_for(0.0)
        skipped = sum(node.skipped.values())
        node.destroy_node()
    finally:
        ctx.shutdown()
    return skipped, len(events)
