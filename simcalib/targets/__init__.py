"""Calibration targets and all OpenCV marker code: ArUco marker walls (``markers``) and
ChArUco / AprilTag boards (``boards``): dictionaries, images, detection, PnP.
"""
