"""``bear_sensor_frames``: every bear sensor's frame on ``/tf_static``, so a robot's gaze can look at the touch.

Publishes one ``tf2_msgs/TFMessage`` on ``/tf_static`` with ROS 2's static broadcaster QoS
(reliable, TRANSIENT_LOCAL, keep last 1: latched, as ``static_transform_publisher`` and
``tf2_ros.StaticTransformBroadcaster`` do), so a tf2 buffer started at any time receives it:

- ``parent_frame`` -> the body map's body frame (``bear_link``), from the parameters ``x``,
  ``y``, ``z`` (m) and ``roll``, ``pitch``, ``yaw`` (rad, fixed axes X then Y then Z, as
  ``static_transform_publisher --roll --pitch --yaw``), where the bear sits on the robot; left
  out when ``parent_frame`` is empty;
- the body frame -> ``<frame_prefix><sensor name>`` (``bear_head2``...) for every sensor with a
  position in the body map: a translation, identity rotation (the map gives no orientation).

The body map is the one the recognisers use (``body_map`` parameter, default
``config/bear_body.yaml``); its positions are approximate (see the file).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from touch_driver.bear.body_map import BodyMap
from touch_graph.compat import Node, ParameterDescriptor, get_message, latched_qos, stamp_now
from touch_graph.errors import ParameterError
from touch_graph.node_main import run_node

__all__ = ['BearSensorFramesNode', 'main', 'quaternion_from_rpy']

TFMessage = get_message('tf2_msgs/msg/TFMessage')
TransformStamped = get_message('geometry_msgs/msg/TransformStamped')
Transform = get_message('geometry_msgs/msg/Transform')
Vector3 = get_message('geometry_msgs/msg/Vector3')
Quaternion = get_message('geometry_msgs/msg/Quaternion')
Header = get_message('std_msgs/msg/Header')


def quaternion_from_rpy(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """``(x, y, z, w)`` of the rotation by ``roll`` about X, then ``pitch`` about Y, then ``yaw`` about Z (rad).

    tf2's ``Quaternion.setRPY`` (fixed axes), which ``static_transform_publisher`` uses.

    >>> [round(v, 4) for v in quaternion_from_rpy(0.0, 0.0, math.pi / 2)]
    [0.0, 0.0, 0.7071, 0.7071]
    """
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)


class BearSensorFramesNode(Node):
    """Latched static transforms of the bear's body frame and of each sensor's frame.

    Attributes:
        transforms: the ``TransformStamped`` list it published.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('bear_sensor_frames', **kwargs)

        def param(name: str, default: Any, description: str) -> Any:
            return self.declare_parameter(name, default, ParameterDescriptor(description=description,
                                                                             read_only=True)).value

        path = param('body_map', '', 'body map YAML (default: config/bear_body.yaml)')
        parent = param('parent_frame', '', "frame the bear's body frame hangs from (e.g. base_link); empty: none")
        prefix = param('frame_prefix', 'bear_', "sensor frames are '<frame_prefix><sensor name>'")
        pose = {k: param(k, 0.0, f'{k} of the body frame in parent_frame, ' + ('m' if k in 'xyz' else 'rad'))
                for k in ('x', 'y', 'z', 'roll', 'pitch', 'yaw')}
        fqn = self.get_fully_qualified_name()
        if path and not Path(path).is_file():
            raise ParameterError(f"parameter 'body_map' of {fqn} must name an existing file; no such file: {path} "
                                 f'(relative paths start at {Path.cwd()})')
        bad = [k for k, v in pose.items() if not math.isfinite(v)]
        if bad:
            raise ParameterError(f'parameters {", ".join(bad)} of {fqn} must be finite numbers')
        body = BodyMap.load(path) if path else BodyMap.default()
        self.get_logger().info(f'body map {body.source}')
        stamp = stamp_now(self)
        self.transforms: list[Any] = []
        if parent:
            self.transforms.append(_transform(stamp, parent, body.frame_id, (pose['x'], pose['y'], pose['z']),
                                              quaternion_from_rpy(pose['roll'], pose['pitch'], pose['yaw'])))
        placed = [s for s in body.sensors if s.position is not None]
        self.transforms += [_transform(stamp, body.frame_id, prefix + s.name, s.position, (0.0, 0.0, 0.0, 1.0))
                            for s in placed]
        self.publisher = self.create_publisher(TFMessage, '/tf_static', latched_qos(1))
        self.publisher.publish(TFMessage(transforms=self.transforms))
        self.get_logger().info(f'{len(placed)} sensor frames {prefix}* in {body.frame_id}'
                               + (f', {body.frame_id} in {parent}' if parent else '') + ' on /tf_static')


def _transform(stamp: Any, parent: str, child: str, xyz: tuple[float, float, float],
               quaternion: tuple[float, float, float, float]) -> Any:
    x, y, z = xyz
    qx, qy, qz, qw = quaternion
    return TransformStamped(header=Header(stamp=stamp, frame_id=parent), child_frame_id=child,
                            transform=Transform(translation=Vector3(x=x, y=y, z=z),
                                                rotation=Quaternion(x=qx, y=qy, z=qz, w=qw)))


def main(args: list[str] | None = None) -> int:
    """``ros2 run social_touch bear_sensor_frames`` / the console script."""
    return run_node(BearSensorFramesNode, args)
