"""Pure computation: camera model, triangulation, trajectory fits, metrics, gait analysis.

Arrays in, arrays out. Imports nothing from acquisition, services or api (checked by a test).
"""
