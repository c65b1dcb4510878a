"""Fault-injection suites (`iguana bench faults scenes|bags|processes|topics`): damaged scene and bag files, killed
processes, bad messages on every subscribed topic."""
