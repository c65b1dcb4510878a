"""argparse value types shared by the `iguana` sub-commands: counts and positive numbers, one error line each."""
from __future__ import annotations

import argparse
import math


def count(minimum: int):
    """argparse type: an integer >= `minimum`."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f'expected an integer, got {text!r}') from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f'expected an integer >= {minimum}, got {value}')
        return value
    return parse


def positive(what: str):
    """argparse type: a positive, finite number called `what` in the error."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f'{what} must be a number, got {text!r}') from None
        if not 0 < value < math.inf:
            raise argparse.ArgumentTypeError(f'{what} must be a positive number, got {text!r}')
        return value
    return parse
