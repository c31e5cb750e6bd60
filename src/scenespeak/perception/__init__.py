"""Perception: pixels → 3-D objects.

Calibration, SIFT features, stereo matching and dense depth, recognition against the object
database, and object regions (points, hulls, heights). Its product is the object contract that
:mod:`scenespeak.spatial` reads; nothing in the spatial half imports from here.
"""
