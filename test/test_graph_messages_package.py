"""``from social_touch_msgs.msg import X``: the ROS way to import our messages, and deferring to rosidl's."""

import subprocess
import sys
import textwrap

import pytest

from touch_graph.messages import get_message, interface_names


def test_every_message_imports_the_ros_way_as_the_same_class():
    import social_touch_msgs.msg as msgs
    for full in interface_names():
        name = full.rsplit('/', 1)[1]
        assert getattr(msgs, name) is get_message(full)
        assert name in dir(msgs) and name in msgs.__all__
    from social_touch_msgs.msg import SymbolicGesture
    assert SymbolicGesture(gesture='hug').gesture == 'hug'


def test_an_unknown_message_is_an_import_error_that_lists_the_known_ones():
    import social_touch_msgs.msg as msgs
    with pytest.raises(AttributeError, match=r"no message 'SymbolicGestures'.*SymbolicGesture"):
        msgs.SymbolicGestures  # noqa: B018
    with pytest.raises(ImportError):
        from social_touch_msgs.msg import Nope  # noqa: F401


def test_a_rosidl_generated_package_further_along_the_path_wins(tmp_path):
    generated = tmp_path / 'social_touch_msgs'
    (generated / 'msg').mkdir(parents=True)
    (generated / '__init__.py').write_text('GENERATED = True\n')
    (generated / 'msg' / '__init__.py').write_text('from ._symbolic_gesture import SymbolicGesture  # noqa\n')
    (generated / 'msg' / '_symbolic_gesture.py').write_text('class SymbolicGesture:\n    rosidl = True\n')
    code = textwrap.dedent(f"""
        import sys
        sys.path.append({str(tmp_path)!r})        # after our own package, as a ROS overlay may be
        import social_touch_msgs
        from social_touch_msgs.msg import SymbolicGesture
        print(getattr(social_touch_msgs, 'GENERATED', False), getattr(SymbolicGesture, 'rosidl', False))
    """)
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, check=True, timeout=60)
    assert out.stdout.split() == ['True', 'True']
