"""The image chain: the pinhole camera with Brown-Conrady distortion, chessboard corners and circle
centres to sub-pixel accuracy, a planar target's pose, and Zhang's calibration with its std.
"""
