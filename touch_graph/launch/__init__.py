"""ROS 2 YAML launch files for the in-process graph::

    plan = evaluate_launch('launch/demo.launch.yaml', {'rate': '30.0'})
    with LaunchRunner(plan.nodes, sim_time=True) as runner:
        runner.spin(5.0)
"""

from .entities import collect_arguments, evaluate_launch
from .parser import LaunchFile, parse_launch_file
from .runner import LaunchRunner, entry_point_registry, resolve_node_class
from .specs import DeclaredArgument, LaunchPlan, NodeSpec, ParamFile, ParamValue, prefix_namespace

__all__ = [
    'DeclaredArgument', 'LaunchFile', 'LaunchPlan', 'LaunchRunner', 'NodeSpec', 'ParamFile', 'ParamValue',
    'collect_arguments', 'entry_point_registry', 'evaluate_launch', 'parse_launch_file', 'prefix_namespace',
    'resolve_node_class',
]
