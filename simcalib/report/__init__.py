"""What a run or a calibration writes for people and programs: results.json, TUM
trajectories, the console table, output folders and the rerun recording.
"""
