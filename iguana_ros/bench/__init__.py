"""Benchmarks (`iguana bench sim|tradeoff|stability|pipeline`): the simulator's workload and speed, stability at
the extremes, the node pipeline's speed next to the library loop."""
