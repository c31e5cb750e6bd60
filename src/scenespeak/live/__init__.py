"""Streams and the scene service: the working memory over frames (:mod:`.stream`), frame
sources (:mod:`.sources`: folders, videos, cameras, ROS 2 bags) and the HTTP service with its
viewer page (:mod:`.service`). See ``docs/live.md``."""
