# Copyright 2026 iguana_ros developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
The part of ROS 2 Jazzy's `launch` / `launch_ros` Python API that a launch file may use, as recording stand-ins.

`launch` and `launch_ros` are not on PyPI, so a test cannot import them. JAZZY_EXPORTS lists the public names of
the modules a launch file imports from (the `__all__` of launch 3.4 and launch_ros 0.26, the Jazzy releases);
the classes below take exactly the keyword arguments of the real constructors (copied from those releases), so a
misspelt or removed argument fails with TypeError as it would under `ros2 launch`, and they record what the launch
file asked for. Substitutions resolve through `Resolver` (launch arguments, a package's share directory).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
import sys
import types

JAZZY_EXPORTS = {
    'launch': {'actions', 'conditions', 'descriptions', 'events', 'frontend', 'logging', 'substitutions', 'Action',
               'Condition', 'Event', 'EventHandler', 'InvalidLaunchFileError', 'LaunchContext', 'LaunchDescription',
               'LaunchDescriptionEntity', 'LaunchDescriptionSource', 'LaunchIntrospector', 'LaunchService',
               'SomeEntitiesType', 'SomeEntitiesType_types_tuple', 'SomeSubstitutionsType',
               'SomeSubstitutionsType_types_tuple', 'Substitution'},
    'launch.actions': {'AppendEnvironmentVariable', 'DeclareLaunchArgument', 'EmitEvent', 'ExecuteLocal',
                       'ExecuteProcess', 'GroupAction', 'IncludeLaunchDescription', 'LogInfo', 'OpaqueCoroutine',
                       'OpaqueFunction', 'PopEnvironment', 'PopLaunchConfigurations', 'PushEnvironment',
                       'PushLaunchConfigurations', 'RegisterEventHandler', 'ResetEnvironment',
                       'ResetLaunchConfigurations', 'SetEnvironmentVariable', 'SetLaunchConfiguration', 'Shutdown',
                       'TimerAction', 'UnregisterEventHandler', 'UnsetEnvironmentVariable',
                       'UnsetLaunchConfiguration'},
    'launch.conditions': {'evaluate_condition_expression', 'IfCondition', 'LaunchConfigurationEquals',
                          'LaunchConfigurationNotEquals', 'UnlessCondition'},
    'launch.substitutions': {'AllSubstitution', 'AndSubstitution', 'AnonName', 'AnySubstitution', 'Command',
                             'EnvironmentVariable', 'EqualsSubstitution', 'FileContent', 'FindExecutable',
                             'IfElseSubstitution', 'LaunchConfiguration', 'LaunchLogDir', 'LocalSubstitution',
                             'NotEqualsSubstitution', 'NotSubstitution', 'OrSubstitution', 'PathJoinSubstitution',
                             'PythonExpression', 'SubstitutionFailure', 'TextSubstitution', 'ThisLaunchFile',
                             'ThisLaunchFileDir'},
    'launch_ros.actions': {'ComposableNodeContainer', 'LifecycleNode', 'LifecycleTransition', 'LoadComposableNodes',
                           'Node', 'PushROSNamespace', 'PushRosNamespace', 'ROSTimer', 'RosTimer', 'SetParameter',
                           'SetParametersFromFile', 'SetRemap', 'SetROSLogDir', 'SetUseSimTime'},
    'launch_ros.parameter_descriptions': {'Parameter', 'ParameterFile', 'ParameterValue'},
    'launch_ros.substitutions': {'ExecutableInPackage', 'FindPackage', 'FindPackagePrefix', 'FindPackageShare',
                                 'Parameter'},
}
"""Public names of the Jazzy modules (launch 3.4.x, launch_ros 0.26.x)."""


@dataclass
class Resolver:
    """What substitutions resolve to: launch argument values and package share directories."""

    arguments: dict[str, str] = field(default_factory=dict)
    shares: dict[str, Path] = field(default_factory=dict)

    def text(self, value) -> str:
        """Return a substitution, a list of them or plain text, as text."""
        if isinstance(value, (list, tuple)):
            return ''.join(self.text(v) for v in value)
        return value.perform(self) if hasattr(value, 'perform') else str(value)


class LaunchDescription:
    """launch.LaunchDescription(initial_entities=None, *, deprecated_reason=None)."""

    def __init__(self, initial_entities=None, *, deprecated_reason=None) -> None:
        self.entities = list(initial_entities or [])


class _Action:
    """launch.Action: `condition` is the one keyword every action takes."""

    def __init__(self, *, condition=None) -> None:
        self.condition = condition


class DeclareLaunchArgument(_Action):
    """launch.actions.DeclareLaunchArgument."""

    def __init__(self, name, *, default_value=None, description=None, choices=None, **kwargs) -> None:
        super().__init__(**kwargs)
        self.name, self.default_value, self.description, self.choices = name, default_value, description, choices


class Shutdown(_Action):
    """launch.actions.Shutdown."""

    def __init__(self, *, reason='reason not given', **kwargs) -> None:
        super().__init__(**kwargs)
        self.reason = reason


class ExecuteProcess(_Action):
    """launch.actions.ExecuteProcess: a process to run (its command resolved by `command`)."""

    created: list[ExecuteProcess] = []

    def __init__(self, *, cmd, prefix=None, name=None, cwd=None, env=None, additional_env=None, shell=False,
                 sigterm_timeout=None, sigkill_timeout=None, emulate_tty=False, output='log', output_format=None,
                 cached_output=False, log_cmd=False, on_exit=None, respawn=False, respawn_delay=None,
                 respawn_max_retries=-1, **kwargs) -> None:
        super().__init__(**kwargs)
        self.cmd, self.on_exit = list(cmd), on_exit
        ExecuteProcess.created.append(self)

    def command(self, resolver: Resolver) -> list[str]:
        """Return the command line, resolved."""
        return [resolver.text(part) for part in self.cmd]

    def runs(self, resolver: Resolver) -> bool:
        """Return whether the process is started (its condition, if any, holds)."""
        return self.condition is None or self.condition.evaluate(resolver)


class IfCondition:
    """launch.conditions.IfCondition(predicate_expression): true for 'true' / '1', false for 'false' / '0'."""

    def __init__(self, predicate_expression) -> None:
        self.predicate_expression = predicate_expression

    def evaluate(self, resolver: Resolver) -> bool:
        """Return the expression's truth as launch reads it (anything else is an error)."""
        text = resolver.text(self.predicate_expression).strip().lower()
        if text not in ('true', '1', 'false', '0'):
            raise ValueError(f'{text!r} is not a condition expression')
        return text in ('true', '1')


class UnlessCondition(IfCondition):
    """launch.conditions.UnlessCondition(predicate_expression): the negation of IfCondition."""

    def evaluate(self, resolver: Resolver) -> bool:
        """Return the negated truth of the expression."""
        return not super().evaluate(resolver)


class EqualsSubstitution:
    """launch.substitutions.EqualsSubstitution(left, right): 'true' if both sides read alike, else 'false'."""

    def __init__(self, left, right) -> None:
        self.left, self.right = left, right

    def perform(self, resolver: Resolver) -> str:
        """Return 'true' or 'false'."""
        return str(resolver.text(self.left) == resolver.text(self.right)).lower()


class LaunchConfiguration:
    """launch.substitutions.LaunchConfiguration: a launch argument's value."""

    def __init__(self, variable_name, *, default=None) -> None:
        self.variable_name, self.default = variable_name, default

    def perform(self, resolver: Resolver) -> str:
        """Return the argument's value (the launch file's default when not given)."""
        return resolver.arguments.get(self.variable_name, self.default)


class PathJoinSubstitution:
    """launch.substitutions.PathJoinSubstitution."""

    def __init__(self, substitutions) -> None:
        self.substitutions = list(substitutions)

    def perform(self, resolver: Resolver) -> str:
        """Return the parts joined as a path."""
        return str(Path(*(resolver.text(part) for part in self.substitutions)))


class FindPackageShare:
    """launch_ros.substitutions.FindPackageShare."""

    def __init__(self, package) -> None:
        self.package = package

    def perform(self, resolver: Resolver) -> str:
        """Return the package's share directory."""
        return str(resolver.shares[resolver.text(self.package)])


class ParameterValue:
    """launch_ros.parameter_descriptions.ParameterValue."""

    def __init__(self, value, *, value_type=None) -> None:
        self.value, self.value_type = value, value_type

    def perform(self, resolver: Resolver):
        """Return the value coerced to `value_type` as launch_ros does (bool from 'true' / 'false')."""
        text = resolver.text(self.value)
        if self.value_type is bool:
            if text.lower() not in ('true', 'false'):
                raise ValueError(f'{text!r} is not a bool')
            return text.lower() == 'true'
        return self.value_type(text) if self.value_type is not None else text


class Node(_Action):
    """launch_ros.actions.Node: its own keywords, then ExecuteProcess's and ExecuteLocal's (Jazzy)."""

    created: list[Node] = []

    def __init__(self, *, executable, package=None, name=None, namespace=None, exec_name=None, parameters=None,
                 remappings=None, ros_arguments=None, arguments=None,
                 prefix=None, cwd=None, env=None, additional_env=None,
                 shell=False, sigterm_timeout=None, sigkill_timeout=None, emulate_tty=False, output='log',
                 output_format=None, cached_output=False, log_cmd=False, on_exit=None, respawn=False,
                 respawn_delay=None, respawn_max_retries=-1, **kwargs) -> None:
        super().__init__(**kwargs)
        self.executable, self.package, self.name, self.namespace = executable, package, name, namespace
        self.parameters, self.arguments, self.on_exit = list(parameters or []), arguments, on_exit
        self.remappings = list(remappings or [])
        Node.created.append(self)

    def parameter_files(self, resolver: Resolver) -> list[Path]:
        """Return the params files given to the node, resolved."""
        return [Path(resolver.text(p)) for p in self.parameters if not isinstance(p, dict)]

    def parameter_values(self, resolver: Resolver) -> dict:
        """Return the parameters given as a dict, resolved."""
        values: dict = {}
        for entry in self.parameters:
            if isinstance(entry, dict):
                values.update({k: v.perform(resolver) if hasattr(v, 'perform') else v for k, v in entry.items()})
        return values


_CLASSES = {
    'launch': [LaunchDescription],
    'launch.actions': [DeclareLaunchArgument, ExecuteProcess, Shutdown],
    'launch.conditions': [IfCondition, UnlessCondition],
    'launch.substitutions': [EqualsSubstitution, LaunchConfiguration, PathJoinSubstitution],
    'launch_ros.actions': [Node],
    'launch_ros.parameter_descriptions': [ParameterValue],
    'launch_ros.substitutions': [FindPackageShare],
}


def install(monkeypatch) -> None:
    """Put the stand-in modules in sys.modules (undone by `monkeypatch` after the test)."""
    for name in ('launch', 'launch_ros'):
        monkeypatch.setitem(sys.modules, name, types.ModuleType(name))
    for module_name, classes in _CLASSES.items():
        module = types.ModuleType(module_name)
        for cls in classes:
            setattr(module, cls.__name__, cls)
        monkeypatch.setitem(sys.modules, module_name, module)
        parent, _, child = module_name.rpartition('.')
        if parent:
            setattr(sys.modules[parent], child, module)
    monkeypatch.setattr(Node, 'created', [])
    monkeypatch.setattr(ExecuteProcess, 'created', [])
