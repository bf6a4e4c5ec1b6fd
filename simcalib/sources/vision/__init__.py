"""The vision stack of the pose sources: render each camera frame, degrade it
(``camera_effects``), detect the targets and solve PnP (``stream``); its config section.
"""
