"""The ROS user's path: bags in (``bag``), the result out for ROS software
(``exports``: URDF, static transform, launch file, easy_handeye2, Kalibr).
"""
