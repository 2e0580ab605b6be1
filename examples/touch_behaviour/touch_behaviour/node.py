"""``touch_behaviour``: what a social robot does with what it feels, in the rclpy idiom.

- a hug (``/touch/symbolic``, START of ``hug``) -> says hello on ``/behaviour/say``;
- a poke (``/touch/subtype`` changes to ``poke``) -> looks at the touch: the centroid of the
  ``/touch/sensor_level`` of the same bear frame, as a ``geometry_msgs/PointStamped`` on ``/behaviour/look_at``
  (frame ``bear_link``; with tf2, transform it into the gaze's frame);
- stroking (the patch's ``stroke`` on ``/touch/gesture``, or ``pet``/``rub`` on a bear sensor)
  -> calms down: ``arousal`` (0 calm .. 1 excited) on ``/behaviour/mood`` goes down;
- a haptic command (``/touch/haptic_command``) -> obeys it: ``/behaviour/action``;
- a region on ``/behaviour/query`` (``std_msgs/String``, empty = everything) -> asks
  ``/touch/get_state`` and says what the robot feels there.

Names come from ``touch_graph.compat``: real rclpy on a ROS 2 machine, social_touch's runtime
(the same API) everywhere else. There is no top-level ``rclpy`` module in social_touch on
purpose: it would hide the real one once ROS 2 is sourced.
"""

from __future__ import annotations

from touch_graph.compat import Node, get_message, get_service, rclpy

Header = get_message('std_msgs/msg/Header')
String = get_message('std_msgs/msg/String')
Float32 = get_message('std_msgs/msg/Float32')
PointStamped = get_message('geometry_msgs/msg/PointStamped')
SensorLevel = get_message('social_touch_msgs/msg/SensorLevel')
SymbolicGesture = get_message('social_touch_msgs/msg/SymbolicGesture')
TouchSubtype = get_message('social_touch_msgs/msg/TouchSubtype')
GestureEvent = get_message('social_touch_msgs/msg/GestureEvent')
HapticCommand = get_message('social_touch_msgs/msg/HapticCommand')
GetTouchState = get_service('social_touch_msgs/srv/GetTouchState')

#: How much each touch excites (+) or calms (-) the robot; arousal stays in [0, 1].
AROUSAL_STEP = {'hug': 0.2, 'poke': 0.3, 'stroke': -0.3}
SOOTHING_SUBTYPES = ('pet', 'rub')


class TouchBehaviour(Node):
    """Reacts to touch; see the module docstring for the topics."""

    def __init__(self):
        super().__init__('touch_behaviour')
        self.arousal = self.declare_parameter('arousal', 0.5).value
        self.last_level = None
        self.look_for = None    # stamp of a poke whose sensor-level message has not arrived yet
        self.say_pub = self.create_publisher(String, '/behaviour/say', 10)
        self.look_pub = self.create_publisher(PointStamped, '/behaviour/look_at', 10)
        self.mood_pub = self.create_publisher(Float32, '/behaviour/mood', 10)
        self.action_pub = self.create_publisher(String, '/behaviour/action', 10)
        self.create_subscription(SensorLevel, '/touch/sensor_level', self.on_level, 10)
        self.create_subscription(SymbolicGesture, '/touch/symbolic', self.on_symbolic, 10)
        self.create_subscription(TouchSubtype, '/touch/subtype', self.on_subtype, 50)
        self.create_subscription(GestureEvent, '/touch/gesture', self.on_patch_gesture, 10)
        self.create_subscription(HapticCommand, '/touch/haptic_command', self.on_command, 10)
        self.create_subscription(String, '/behaviour/query', self.on_query, 10)
        self.state_client = self.create_client(GetTouchState, '/touch/get_state')

    # -------------------------------------------------------------- reactions
    def on_level(self, msg):
        self.last_level = msg
        if self.look_for is not None and msg.header.stamp == self.look_for:
            self.look_for = None
            self.look_at(msg)

    def on_symbolic(self, msg):
        # START is the decided hug; CANDIDATE (a first word, with its confidence) and WITHDRAWN come before
        # a decision, and this behaviour waits for it.
        if msg.gesture == 'hug' and msg.state == SymbolicGesture.START:
            self.say('Hello! Thank you for the hug.')
            self.feel(AROUSAL_STEP['hug'])

    def on_subtype(self, msg):
        if msg.subtype == 'poke':
            # Both come from the same bear frame (same stamp); over the network either may arrive first.
            level = self.last_level
            if level is not None and level.header.stamp == msg.header.stamp:
                self.look_at(level)
            else:
                self.look_for = msg.header.stamp
            self.feel(AROUSAL_STEP['poke'])
        elif msg.subtype in SOOTHING_SUBTYPES:
            self.feel(AROUSAL_STEP['stroke'])

    def on_patch_gesture(self, msg):
        if msg.gesture == 'stroke':
            self.feel(AROUSAL_STEP['stroke'])

    def on_command(self, msg):
        self.action_pub.publish(String(data=msg.command))
        self.say(f'OK: {msg.command}.')

    def on_query(self, msg):
        if not self.state_client.service_is_ready():
            self.say('I cannot feel anything: /touch/get_state is not running.')
            return
        future = self.state_client.call_async(GetTouchState.Request(region=msg.data))
        future.add_done_callback(self.on_state)    # never wait inside a callback: rclpy would deadlock

    def on_state(self, future):
        if future.exception() is not None:
            self.say(f'/touch/get_state failed: {future.exception()}')
            return
        answer = future.result()
        if answer is None:
            self.say('No answer from /touch/get_state.')
        elif not answer.success:
            self.say(answer.message)
        else:
            state = answer.state
            sensors = ', '.join(s.name for s in state.sensors) or 'nothing'
            gestures = ', '.join(g.gesture for g in state.gestures) or 'no gesture'
            self.say(f'I feel {sensors} ({gestures}) {"on my " + state.region if state.region else ""}'.strip())

    # -------------------------------------------------------------- outputs
    def look_at(self, level):
        """Turn to the touch: the centroid of the touched sensors, in the body frame."""
        if not level.has_centroid:
            return
        header = Header(stamp=level.header.stamp, frame_id=level.frame_id)   # the centroid's frame: bear_link
        self.look_pub.publish(PointStamped(header=header, point=level.centroid))

    def feel(self, step):
        self.arousal = min(1.0, max(0.0, self.arousal + step))
        self.mood_pub.publish(Float32(data=self.arousal))

    def say(self, text):
        self.get_logger().info(text)
        self.say_pub.publish(String(data=text))


def main(args=None):
    """``touch_behaviour`` in a terminal: join the graph, react until Ctrl-C."""
    rclpy.init(args=args)
    node = TouchBehaviour()
    try:
        rclpy.spin(node)
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
