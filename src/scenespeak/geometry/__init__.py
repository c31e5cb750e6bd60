"""Geometry underneath both halves: polygons (area, convexity, clipping, intersection) and frames.

Nothing here knows of cameras, images or words; both :mod:`scenespeak.perception` and
:mod:`scenespeak.spatial` build on it.
"""
