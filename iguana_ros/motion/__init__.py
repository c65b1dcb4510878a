"""Motion data: synthetic capture, C3D, full-body IK, stride clips, the motion graph."""
