"""Start the nodes of a launch plan in this process and spin them until shutdown.

A :class:`~touch_graph.launch.specs.NodeSpec`'s class comes from the ``social_touch.nodes``
entry points (name = ``exec``, distribution = ``pkg``) or an explicit registry, else from
``exec: module.path:Class``, else from ``pkg: module.path`` with ``exec: Class``. Nodes are
built as rclpy component containers build them (``cls(context=, cli_args=, parameter_overrides=)``);
a class with rclpy's plain ``__init__(self)`` gets the same arguments through
:func:`touch_graph.runtime.node.node_arguments`.

A callback that raises ends its node, as in rclpy: the runner reports it as ros2 launch
reports a dead process and spins the others on. In-process, ``param`` values are
``parameter_overrides`` and so win over ``from:`` files whatever their order (rclpy's precedence).
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import importlib.metadata
import importlib.util
import inspect
import math
import signal
import sys
import threading
import time
import traceback
import types
from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: a source checkout's nodes come from the installed metadata only
    tomllib = None

from ..errors import LaunchError, SocialTouchError
from ..yamlconf import did_you_mean
from .specs import NodeSpec

__all__ = ['ENTRY_POINT_GROUP', 'SLICE_S', 'LaunchRunner', 'entry_point_registry', 'rclpy_runtime',
           'resolve_node_class', 'source_tree_nodes']

#: Entry-point group mapping executable names to node classes (``module:Class``).
ENTRY_POINT_GROUP = 'social_touch.nodes'
#: ROS-time slice between checks for a stop request while spinning, in seconds.
SLICE_S = 0.1

#: ``(pkg, exec) -> node class`` or something with ``load() -> class`` (an EntryPoint).
Registry = Mapping[tuple[str, str], Any]


def _normalize(name: str) -> str:
    return name.replace('-', '_').lower()


def source_tree_nodes(pyproject: Path | None = None, package: str = 'social_touch',
                      group: str = ENTRY_POINT_GROUP) -> dict[tuple[str, str], importlib.metadata.EntryPoint]:
    """The ``group`` entry points of a source checkout's ``pyproject.toml`` (read, not installed).

    So ``launch`` finds a node added to the checkout before ``pip install -e .`` ran again.
    Returns an empty mapping when there is no such file or group, or no TOML reader (Python 3.10).
    """
    pyproject = pyproject or Path(__file__).resolve().parents[2] / 'pyproject.toml'
    if tomllib is None:
        return {}
    try:
        table = tomllib.loads(pyproject.read_text(encoding='utf-8'))['project']['entry-points'][group]
    except (OSError, ValueError, KeyError, TypeError):
        return {}
    if not isinstance(table, dict):
        return {}
    return {(_normalize(package), name): importlib.metadata.EntryPoint(name, value, group)
            for name, value in table.items() if isinstance(name, str) and isinstance(value, str)}


def entry_point_registry(group: str = ENTRY_POINT_GROUP, *, include_source_tree: bool = True,
                         ) -> dict[tuple[str, str], importlib.metadata.EntryPoint]:
    """``(package, executable) -> EntryPoint`` for every node executable (classes are not imported yet).

    Installed entry points win; with ``include_source_tree``, executables of this source
    checkout's ``pyproject.toml`` that are not installed fill the gaps (see :func:`source_tree_nodes`).
    """
    out = source_tree_nodes(group=group) if include_source_tree else {}
    for entry_point in importlib.metadata.entry_points(group=group):
        dist = getattr(entry_point, 'dist', None)
        package = dist.name if dist is not None else entry_point.module.split('.')[0]
        out[(_normalize(package), entry_point.name)] = entry_point
    return out


def resolve_node_class(spec: NodeSpec, registry: Registry, node_base: type | None = None) -> type:
    """The node class of ``spec`` (``node_base``: the class it must derive from, if given).

    Raises:
        LaunchError: at the node's line for an unknown package or executable (with the
            available ones and a did-you-mean), an import failure, or a class that is not a node.
    """
    where = spec.where
    key = (_normalize(spec.pkg), spec.exec)
    by_path = _module_path_target(spec, registry)
    if key not in registry and by_path is not None:
        return _check_node_class(spec, _load_module_class(spec, *by_path), node_base)
    if key not in registry:
        packages = sorted({pkg for pkg, _ in registry})
        if not registry:
            raise where.error(f"cannot start {spec.pkg}/{spec.exec}: no node executables are registered (entry-point "
                              f"group '{ENTRY_POINT_GROUP}' is empty); install the package: pip install -e . "
                              '(or colcon build and source install/setup.bash)')
        if key[0] not in packages:
            raise where.error(f"unknown package '{spec.pkg}'{did_you_mean(key[0], packages)}; packages with node "
                              f'executables: {", ".join(packages)}')
        executables = sorted(name for pkg, name in registry if pkg == key[0])
        raise where.error(f"package '{spec.pkg}' has no executable '{spec.exec}'{did_you_mean(spec.exec, executables)}"
                          f'; available: {", ".join(executables)}')
    target = registry[key]
    if not isinstance(target, type):
        try:
            target = target.load()
        except Exception as err:  # an import error inside the node's module: say which node and where
            raise where.error(f'cannot load {spec.pkg}/{spec.exec} ({getattr(registry[key], "value", target)}): '
                              f'{type(err).__name__}: {err}') from err
    return _check_node_class(spec, target, node_base)


def rclpy_runtime() -> types.SimpleNamespace:
    """What :class:`LaunchRunner` needs of a runtime, from real rclpy (when ``touch_graph.compat`` uses it).

    The context is rclpy's default one, which a node with rclpy's plain ``__init__(self)`` joins.
    """
    # rclpy or ours, chosen at run time: rclpy is imported only when compat uses it (a sourced ROS 2)
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from rclpy.node import Node  # rclpy: as above
    from rclpy.parameter import Parameter  # rclpy: as above
    from rclpy.utilities import get_default_context  # rclpy: as above
    return types.SimpleNamespace(Context=get_default_context, SingleThreadedExecutor=SingleThreadedExecutor,
                                 Node=Node, Parameter=Parameter, ExternalShutdownException=ExternalShutdownException,
                                 node_arguments=functools.partial(rclpy_node_arguments, Node))


@contextlib.contextmanager
def rclpy_node_arguments(node_class: type, **arguments: Any) -> Iterator[dict[str, Any]]:
    """:func:`touch_graph.runtime.node.node_arguments` for rclpy: the next ``node_class`` (rclpy's Node)
    this thread constructs without ``context``, ``cli_args`` and ``parameter_overrides`` gets ``arguments``.

    rclpy's plain-constructor node reads its remaps and parameters from the process's ``--ros-args``;
    several nodes of one launch share this process, so each gets its own this way (rclpy's own keywords).
    """
    pending = {'taken': False}
    thread = threading.get_ident()
    original = node_class.__init__

    def init(self: Any, node_name: str, *args: Any, **kwargs: Any) -> None:
        if not pending['taken'] and threading.get_ident() == thread and not any(
                kwargs.get(key) is not None for key in arguments):
            pending['taken'] = True  # only the class's own node, not nodes it makes inside
            kwargs.update(arguments)
        original(self, node_name, *args, **kwargs)

    node_class.__init__ = init
    try:
        yield pending
    finally:
        node_class.__init__ = original


def _check_node_class(spec: NodeSpec, target: Any, node_base: type | None) -> type:
    if not isinstance(target, type) or (node_base is not None and not issubclass(target, node_base)):
        raise spec.where.error(f'{spec.pkg}/{spec.exec} is {target!r}, not a Node subclass; name a class whose '
                               "__init__(self) calls super().__init__('name') (rclpy's shape), or that takes "
                               "**kwargs and passes them on: super().__init__('name', **kwargs)")
    return target


def _module_path_target(spec: NodeSpec, registry: Registry) -> tuple[str, str] | None:
    """``(module, class)`` when the spec names a class by module path (``exec: mod:Class``, or
    ``pkg: a.module`` that is no registered package and ``exec: Class``); else None."""
    if ':' in spec.exec:
        module, _, name = spec.exec.partition(':')
        return module, name
    packages = {pkg for pkg, _ in registry}
    if _normalize(spec.pkg) not in packages and spec.exec.isidentifier():
        try:
            found = importlib.util.find_spec(spec.pkg)
        except (ImportError, ValueError):  # a parent package that does not import, or a bad name
            found = None
        if found is not None:
            return spec.pkg, spec.exec
    return None


def _load_module_class(spec: NodeSpec, module_name: str, class_name: str) -> Any:
    try:
        module = importlib.import_module(module_name)
    except Exception as err:  # an import error inside the user's module: say which node and where
        raise spec.where.error(f'cannot import {module_name} for {spec.pkg}/{spec.exec}: '
                               f'{type(err).__name__}: {err}') from err
    try:
        return getattr(module, class_name)
    except AttributeError:
        classes = sorted(n for n, v in vars(module).items() if isinstance(v, type) and v.__module__ == module.__name__)
        raise spec.where.error(f"module {module_name} has no class '{class_name}'{did_you_mean(class_name, classes)}"
                               f'; its classes: {", ".join(classes) or "none"}') from None


def takes_node_arguments(cls: type) -> bool:
    """True when ``cls(context=..., cli_args=..., parameter_overrides=...)`` works: its ``__init__``
    takes ``**kwargs`` or those keywords; False for rclpy's plain ``__init__(self)``."""
    try:
        parameters = inspect.signature(cls).parameters.values()
    except (TypeError, ValueError):  # no signature to read: assume the keyword form
        return True
    names = {p.name for p in parameters}
    return any(p.kind is p.VAR_KEYWORD for p in parameters) or {'context', 'cli_args'} <= names


class LaunchRunner:
    """Owns the context, the executor and the nodes of one launch.

    Args:
        specs: the nodes to start, in order.
        registry: ``(pkg, exec) -> class``; default: :func:`entry_point_registry`.
        runtime: the module with ``Context``, ``SingleThreadedExecutor``, ``Parameter`` and ``Node``;
            default :mod:`touch_graph.runtime` (tests may pass a stand-in).
        sim_time: run on a simulated clock (``Context(clock_mode='sim', rate=rate)``).
        rate: simulated seconds per wall second (``math.inf``: as fast as possible); only with ``sim_time``.
        network: join the DDS domain, so other processes and machines see the graph (``social-touch
            topic echo``, ``record``, ROS 2 nodes); None leaves it to the context (a wall clock joins,
            a simulated one does not).
        strict_params: a parameter in the launch file or a parameter file that no node declares (a
            typo) is an error instead of a warning.

    Use as a context manager, or call :meth:`start`, :meth:`spin` and :meth:`shutdown`.
    """

    def __init__(self, specs: Iterable[NodeSpec], *, registry: Registry | None = None,
                 runtime: types.ModuleType | Any = None, sim_time: bool = False, rate: float | None = None,
                 network: bool | None = None, strict_params: bool = False) -> None:
        if rate is not None and not sim_time:
            raise ValueError('rate applies to simulated time only; pass sim_time=True as well')
        if rate is not None and not (rate > 0):  # also rejects NaN
            raise ValueError(f'rate must be > 0 (math.inf: as fast as possible), got {rate!r}')
        self.specs = list(specs)
        self.registry = registry
        self.runtime = runtime
        self.sim_time = sim_time
        self.rate = math.inf if rate is None else rate
        self.context: Any = None
        self.executor: Any = None
        self.nodes: list[Any] = []
        self.network = network
        self.strict_params = strict_params
        self._stop = threading.Event()
        self._signals = 0
        #: ``'<node>: <Exception>: <text>'`` for each node a raising callback ended.
        self.died: list[str] = []

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> list[Any]:
        """Resolve every class, then create the context, the nodes and the executor."""
        if self.runtime is None:
            from .. import runtime  # deferred: the parser and --print-description do not need the graph
            self.runtime = runtime
        registry = entry_point_registry() if self.registry is None else self.registry
        classes = [resolve_node_class(spec, registry, getattr(self.runtime, 'Node', None)) for spec in self.specs]
        kwargs = {} if self.network is None else {'network': self.network}
        if self.sim_time:
            self.context = self.runtime.Context(clock_mode='sim', rate=self.rate, **kwargs)
        else:
            self.context = self.runtime.Context(**kwargs)
        self.context.init([])  # not sys.argv: real rclpy would take launch arguments for remap rules
        try:
            for spec, cls in zip(self.specs, classes, strict=True):
                self.nodes.append(self._create(spec, cls))
            self._check_parameters()
            self.executor = self.runtime.SingleThreadedExecutor(context=self.context)
            for node in self.nodes:
                self.executor.add_node(node)
        except BaseException as err:
            try:
                self.shutdown()
            except LaunchError as cleanup:  # keep the first error; mention the second
                err.add_note(str(cleanup))
            raise
        return self.nodes

    def _create(self, spec: NodeSpec, cls: type) -> Any:
        try:
            overrides = []
            for value in spec.parameter_values():
                param = self.runtime.Parameter(value.name, value=value.value)
                if value.where is not None:
                    param.source = value.where  # where the launch file wrote it, for errors and warnings
                overrides.append(param)
            if takes_node_arguments(cls):
                return cls(context=self.context, cli_args=spec.cli_args(), parameter_overrides=overrides)
            return self._create_plain(spec, cls, overrides)
        except SocialTouchError as err:
            who = spec.full_name or f'{spec.pkg}/{spec.exec}'
            raise spec.where.error(f'node {who} ({spec.pkg}/{spec.exec}) failed to start: {err}') from err
        except Exception as err:  # a bug in the node: keep the exception, say which launch entry it was
            err.add_note(f'while starting {spec.pkg}/{spec.exec} from {spec.where}')
            raise

    def _create_plain(self, spec: NodeSpec, cls: type, overrides: list[Any]) -> Any:
        """A node class with rclpy's ``__init__(self)``: its arguments go through ``node_arguments``."""
        node_arguments = getattr(self.runtime, 'node_arguments', None)
        if node_arguments is None:
            # lazy: a launcher whose nodes all run in processes imports this module without the runtime
            from ..runtime.node import node_arguments
        with node_arguments(context=self.context, cli_args=spec.cli_args(),
                            parameter_overrides=overrides) as pending:
            node = cls()
        if not pending['taken']:  # nothing joined this graph (a node made with its own context is not ours)
            raise spec.where.error(f'{spec.pkg}/{spec.exec}: {cls.__name__}.__init__ made no node of this graph '
                                   "(does it call super().__init__('name')?)")
        return node

    def _check_parameters(self) -> None:
        """Warn about (``strict_params``: refuse) launch or file parameters that no node declares."""
        from ..runtime.logging import get_logger  # lazy: as in _create_plain
        from ..runtime.override_check import check_overrides  # lazy: as in _create_plain
        ours = [node for node in self.nodes if hasattr(node, 'override_origins')]  # not under real rclpy
        try:
            check_overrides(ours, get_logger('launch'), strict=self.strict_params)
        except SocialTouchError as err:
            raise LaunchError(str(err)) from err

    def request_stop(self) -> None:
        """Ask :meth:`spin` to return after the current callback (safe from a signal handler or thread)."""
        self._stop.set()

    def spin(self, duration: float | None = None, *, handle_signals: bool = True,
             every_slice: Callable[[], None] | None = None) -> None:
        """Run the graph until a stop request, the context's shutdown or ``duration`` seconds of ROS time.

        With ``handle_signals`` (and in the main thread), SIGINT/SIGTERM request a stop while
        spinning; the previous handlers come back afterwards. ``every_slice()`` runs between
        slices of :data:`SLICE_S` (the launcher watches its node processes there).
        """
        if self.executor is None:
            raise LaunchError('spin() before start(): call start() first (or use the runner as a context manager)')
        if duration is not None and not (duration >= 0):
            raise ValueError(f'duration must be >= 0 seconds, got {duration!r}')
        external_shutdown = getattr(self.runtime, 'ExternalShutdownException', ())  # a class, or none
        external_shutdown = external_shutdown if isinstance(external_shutdown, tuple) else (external_shutdown,)
        ros_time = hasattr(self.executor, 'spin_until_time')  # ours; real rclpy's executor spins in wall time
        now = self.context.now_ns if ros_time else time.monotonic
        end = None if duration is None else now() + (round(duration * 1e9) if ros_time else duration)
        previous = self._install_signal_handlers() if handle_signals else {}
        try:
            while not self._stop.is_set() and self.context.ok() and (end is None or now() < end):
                try:
                    if ros_time:  # short slices of ROS time, so a stop request is seen between callbacks
                        slice_end = now() + round(SLICE_S * 1e9)
                        self.executor.spin_until_time(slice_end if end is None else min(slice_end, end))
                    else:
                        self.executor.spin_once(timeout_sec=SLICE_S)
                except (KeyboardInterrupt, SystemExit, *external_shutdown):
                    raise
                except Exception as err:
                    if not self._node_died(err):
                        break
                if every_slice is not None:
                    every_slice()
        except external_shutdown:  # another thread shut the context down: a normal end
            pass
        finally:
            for signum, handler in previous.items():
                signal.signal(signum, handler)

    def _node_died(self, err: Exception) -> bool:
        """Report the node whose callback raised ``err`` as dead and destroy it; False when none is left.

        Which node: our executor's ``last_failure``; rclpy's executor does not say, so with several
        nodes on rclpy the exception ends the whole launch (as it ends rclpy's spin).
        """
        failure = getattr(self.executor, 'last_failure', None)
        node = failure[0] if failure is not None else (self.nodes[0] if len(self.nodes) == 1 else None)
        if failure is not None:
            self.executor.last_failure = None  # the next failure is another node's
        if node is None or node not in self.nodes:
            raise err
        name = node.get_fully_qualified_name()
        trace = ''.join(traceback.format_exception(err)).rstrip()
        sys.stderr.write(f'[ERROR] [launch]: node {name} has died: a callback raised {type(err).__name__}: {err}'
                         f' (as under rclpy, an exception in a callback ends the node)\n{trace}\n')
        sys.stderr.flush()
        self.died.append(f'{name}: {type(err).__name__}: {err}')
        self.nodes.remove(node)
        self.executor.remove_node(node)
        try:
            node.destroy_node()
        except Exception as cleanup:  # keep the first error; mention the second
            sys.stderr.write(f'[ERROR] [launch]: destroying {name} failed too: {type(cleanup).__name__}: {cleanup}\n')
        if not self.nodes:
            sys.stderr.write('[ERROR] [launch]: every node of this process has died\n')
            return False
        return True

    def _install_signal_handlers(self) -> dict[int, Any]:
        if threading.current_thread() is not threading.main_thread():
            return {}

        def on_signal(signum: int, frame: Any) -> None:
            self._signals += 1
            if self._signals > 1:
                raise KeyboardInterrupt  # a second Ctrl-C: stop now, even inside a callback
            self.request_stop()

        return {signum: signal.signal(signum, on_signal) for signum in (signal.SIGINT, signal.SIGTERM)}

    def shutdown(self) -> None:
        """Destroy the nodes (last started first), stop the executor, shut the context down; safe twice."""
        errors = []
        for node in reversed(self.nodes):
            try:
                node.destroy_node()
            except Exception as err:  # keep destroying the others; report at the end
                name = node.get_fully_qualified_name() if hasattr(node, 'get_fully_qualified_name') else repr(node)
                errors.append(f'{name}: {type(err).__name__}: {err}')
        self.nodes = []
        if self.executor is not None:
            self.executor.shutdown()
            self.executor = None
        if self.context is not None:
            self.context.try_shutdown()
        if errors:
            raise LaunchError('errors while destroying nodes: ' + '; '.join(errors))

    def __enter__(self) -> LaunchRunner:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.shutdown()
