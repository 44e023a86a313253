"""A serial arm's calibration: kinematics (DH and modified DH, the parameter Jacobian, gravity
torques), its identification problems (points in an instrument's frame, a tracker's spherical
readings, a length bar's cones), posture design and the screening of bad rows.
"""
