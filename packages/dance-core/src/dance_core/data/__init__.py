"""Training data: clip sources, feature stacks, normalization statistics and segment sampling."""

from dance_core.data.sources import Clip, ClipSource

__all__ = ["Clip", "ClipSource"]
