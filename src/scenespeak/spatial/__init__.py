"""Spatial language: regions → words.

The Histogram of Forces (:mod:`~scenespeak.spatial.forces`), its degrees of truth
(:mod:`~scenespeak.spatial.degrees`) and the fuzzy rule base with its sentences
(:mod:`~scenespeak.spatial.language`). It takes regions (polygons or masks with heights) from
any source and imports nothing from :mod:`scenespeak.perception`.
"""
