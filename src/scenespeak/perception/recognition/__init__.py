"""Stage 4: recognition — labelled SIFT descriptors in a SQLite file, and labelling.

The paper matches the scene's keypoints "to a database of known objects ... If a keypoint is
not matched, it is held as part of an unknown object". Here that database is one SQLite file:

* ``meta``: ``application`` = ``scenespeak-object-database``, ``schema_version`` = ``3`` and a
  ``generation`` counter bumped by every write. A file without them is "not a scenespeak object
  database".
* ``objects``: one row per label (``id``, ``label`` unique, ``added`` as ISO-8601 UTC).
* ``views``: one row per training image: its source name, width and height, the number of
  keypoints, the descriptors as one ``uint8`` ``(N, 128)`` BLOB, the keypoints as one
  ``float32`` ``(N, 4)`` BLOB (x, y, size, angle) and the object's outline in that image as a
  ``float32`` ``(M, 2)`` BLOB (the largest contour of the mask, or the image border).
* ``view_colours`` (version 2; a version-1 file is upgraded when opened for writing): per view
  learnt with a mask from a colour image, its colour signature and chromatic-box aspect
  (:mod:`~scenespeak.perception.recognition.colour`), and (version 3, NULL in older rows) its
  grey signature and object-box aspect (:mod:`~scenespeak.perception.recognition.grey`).

Every write is one transaction (features are extracted *before* it opens), so an exception or
Ctrl-C in the middle of :meth:`ObjectDatabase.add_object` leaves the file as it was.

On the first :meth:`ObjectDatabase.label` the descriptors are loaded into a nearest-neighbour
index (:func:`build_index`): exact brute force for small databases, an inverted-file index
in NumPy/BLAS (k-means coarse quantiser over ``uint8`` lists, cached in the file) for large
ones (searched by FAISS instead when ``faiss-cpu`` is installed: same cells, same answers).
Descriptors stay ``uint8`` in memory: 500,000 of them take 64 MB.

Labelling (:meth:`ObjectDatabase.label`) is Lowe's recipe: a ratio test whose second
neighbour is the nearest descriptor *of a different object* (several views of one object hold
near-copies of the same descriptor; comparing against those would reject exactly the good
matches), then per training view a RANSAC homography (a similarity where there are few matches)
between the training keypoints and the scene's, with each inlier's SIFT scale and orientation
checked against the model; an object is accepted only with ``min_inliers`` inliers, so a few
stray matches never make an object (a small, far one, whose outline covers at most
``small_area`` pixels, with ``min_inliers_small`` inliers at distinct positions). A query's
matches into every view of its object are checked, not only its single nearest neighbour's, so
matches split between near-identical views are pooled. Query keypoints keep the label ``-1``
unless they are inliers of an accepted detection.

>>> import numpy as np
>>> from skimage import data
>>> from scenespeak.perception.recognition import ObjectDatabase
>>> from scenespeak.perception.features import detect
>>> import tempfile, pathlib
>>> path = pathlib.Path(tempfile.mkdtemp()) / "objects.db"
>>> with ObjectDatabase.open(path, create=True) as db:
...     info = db.add_object("astronaut", [data.astronaut()[40:300, 120:380]])
...     result = db.label(detect(data.astronaut()))
>>> info.label, [d.label for d in result.detections]
('astronaut', ['astronaut'])

The package's modules: :mod:`~.schema` (the file's tables and checks), :mod:`~.store`
(:class:`ObjectDatabase`: opening, reading, transactions), :mod:`~.views` (training-view
extraction), :mod:`~.index` and :mod:`~.ivf` (exact / inverted-file / FAISS search),
:mod:`~.verify` (RANSAC geometric checks), :mod:`~.label` (the labelling) with its
:class:`LabelOptions` (:mod:`~.options`), and :mod:`~.results`.
"""

from __future__ import annotations

from scenespeak.perception.recognition.index import (
    DescriptorIndex,
    ExactIndex,
    IndexKind,
    build_index,
)
from scenespeak.perception.recognition.ivf import FaissIndex, IVFIndex
from scenespeak.perception.recognition.options import LabelOptions
from scenespeak.perception.recognition.results import (
    Detection,
    Labelling,
    ObjectInfo,
    TrainingView,
)
from scenespeak.perception.recognition.schema import APPLICATION, SCHEMA_VERSION
from scenespeak.perception.recognition.store import ObjectDatabase
from scenespeak.perception.recognition.views import outline_from_mask

__all__ = [
    "APPLICATION",
    "SCHEMA_VERSION",
    "DescriptorIndex",
    "Detection",
    "ExactIndex",
    "FaissIndex",
    "IVFIndex",
    "IndexKind",
    "LabelOptions",
    "Labelling",
    "ObjectDatabase",
    "ObjectInfo",
    "TrainingView",
    "build_index",
    "outline_from_mask",
]
