"""Headless rendering of recorded runs (ROS-free): cameras, a z-buffered software rasterizer, image writers.

`iguana_ros.bag.frames` turns a bag into a `RecordedRun` of numpy arrays; `Renderer` draws it frame by frame
from a camera preset (`camera_presets`), and `output` writes PNG, GIF or MP4.
"""
