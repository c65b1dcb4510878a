"""Soft-body simulation (paper Section V): forces, implicit integration, ground contact; ROS-free.

Public entry point: `iguana_ros.physics.simulator.SoftBodySimulator`; presets in `iguana_ros.physics.fidelity`.
"""
