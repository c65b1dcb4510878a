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

"""Node parameter declarations (msg_configs/parameters.yaml) and the standard params file agree."""
import pytest
import yaml

from iguana_ros.config import config_path
from iguana_ros.errors import InputError
from iguana_ros.executables import NODE_EXECUTABLES, SIM_TIME_NODES
from iguana_ros.parameters import load_parameters, node_parameters, ParamSpec


def test_params_file_holds_every_declared_default():
    declared = load_parameters()
    params = yaml.safe_load(config_path('params', 'iguana.yaml').read_text())
    common = params['/**']['ros__parameters']
    assert common == {name: spec.default for name, spec in declared['common'].items()}
    assert set(declared) == {'common', *NODE_EXECUTABLES}
    for node in NODE_EXECUTABLES:
        values = (params.get(f'/**/{node}') or {}).get('ros__parameters', {})
        # plus rclpy's own use_sim_time (every node declares it by itself) for the nodes that read their clock
        assert values.pop('use_sim_time', False) is (node in SIM_TIME_NODES), node
        assert values == {name: spec.default for name, spec in declared[node].items()}, node
        for name, value in values.items():
            assert node_parameters(node)[name].check(value) == value


def test_checks_type_range_and_choices():
    spec = ParamSpec('x', 'double', 1.0, range=(0.0, 2.0))
    assert spec.check(2) == 2.0
    with pytest.raises(InputError, match='outside'):
        spec.check(3.0)
    with pytest.raises(InputError, match='expected double'):
        spec.check('a')
    mode = node_parameters('simulator_node')['mode']
    with pytest.raises(InputError, match='lockstep, realtime'):
        mode.check('fast')
    assert node_parameters('planner_node')['scene'].default == 'hills'


def test_bad_declaration_file_is_named(tmp_path):
    bad = tmp_path / 'p.yaml'
    bad.write_text('planner_node: {goal_radius: {type: float, default: 1}}')
    with pytest.raises(InputError, match='p.yaml.*goal_radius'):
        load_parameters(bad)


@pytest.mark.parametrize('namespace', ['', '/iguana1', '/zoo/iguana2'])
def test_the_params_file_sections_match_the_nodes_in_any_namespace(namespace):
    import rclpy

    from iguana_ros.ros.endpoints import release_context
    context = rclpy.Context()
    remap = ['-r', f'__ns:={namespace}'] if namespace else []
    rclpy.init(args=['--ros-args', '--params-file', str(config_path('params', 'iguana.yaml')), *remap],
               context=context)
    try:
        node = rclpy.create_node('planner_node', context=context, automatically_declare_parameters_from_overrides=True)
        assert node.get_fully_qualified_name() == f'{namespace}/planner_node'
        assert node.get_parameter('use_sim_time').value is True                  # the planner's own section
        assert node.get_parameter('blend_frames').value == node_parameters('planner_node')['blend_frames'].default
        assert node.get_parameter('scene').value == 'hills'                      # the section of every node
        node.destroy_node()
    finally:
        release_context(context)
