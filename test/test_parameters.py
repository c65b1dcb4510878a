"""Node parameter declarations (msg_configs/parameters.yaml) and the standard params file agree."""
import pytest
import yaml

from iguana_ros.config import config_path
from iguana_ros.errors import InputError
from iguana_ros.executables import NODE_EXECUTABLES
from iguana_ros.parameters import ParamSpec, load_parameters, node_parameters


def test_params_file_holds_every_declared_default():
    declared = load_parameters()
    params = yaml.safe_load(config_path('params', 'iguana.yaml').read_text())
    common = params['/**']['ros__parameters']
    # plus rclpy's own use_sim_time (every node declares it by itself): all nodes follow the simulator's /clock
    assert common == {'use_sim_time': True, **{name: spec.default for name, spec in declared['common'].items()}}
    assert set(declared) == {'common', *NODE_EXECUTABLES}
    for node in NODE_EXECUTABLES:
        values = (params.get(node) or {}).get('ros__parameters', {})
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
