"""`iguana bench faults SUITE`: the fault-injection suites, one module each (listed in SUITES) adding its
sub-command to the `faults` group."""
from __future__ import annotations

import argparse
import importlib

SUITES = (
    # (name, module exposing `register(suites)`); a suite is imported only when listed here.
    ('scenes', 'iguana_ros.cli.bench_faults_scenes'),
    ('bags', 'iguana_ros.cli.bench_faults_bags'),
    ('processes', 'iguana_ros.cli.bench_faults_processes'),
    ('topics', 'iguana_ros.cli.bench_faults_topics'),
)


def faults_group(sub: argparse._SubParsersAction) -> argparse._SubParsersAction:
    """The sub-command action of `iguana bench faults` under the bench sub-commands `sub`, created on first use
    (an existing `faults` group is reused, so suites registered from elsewhere join it)."""
    parser = sub.choices.get('faults')
    if parser is None:
        parser = sub.add_parser('faults', help='fault-injection suites: bad scenes, damaged bags, killed processes, '
                                               'bad topic messages')
        return parser.add_subparsers(dest='suite', metavar='SUITE', required=True)
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))


def register(sub: argparse._SubParsersAction) -> None:
    """Add `faults` with every suite of SUITES to the bench sub-commands `sub`."""
    suites = faults_group(sub)
    for _name, module in SUITES:
        importlib.import_module(module).register(suites)
