"""Tools beside the pipeline: the scene generator, the evaluation and the figures."""
