"""dance-core: plugin registry, recipes, protocols, training and composition loops.

The names exported here are the **stable API** for plugins: the first-party plugins import only
these (and ``dance_core.testing`` in tests). Everything else in ``dance_core`` is internal and may
change between minor versions. Names load on first use, so ``import dance_core`` stays light (no
torch, no numpy until a protocol or media type is touched).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from dance_core.config import ComponentConfig
from dance_core.errors import CheckpointError, DanceError, DataError, PluginError, RecipeError, TrainingError
from dance_core.hookspecs import hookimpl
from dance_core.version import __version__

#: public name -> the module that defines it (imported on first use)
_LAZY: dict[str, str] = {
    # protocols and the data they pass around
    **dict.fromkeys(
        ("Window", "TrainContext", "SongInputs", "Conditioner", "Encoder", "OutputHead", "FeatureExtractor",
         "SpanFeatureExtractor", "AudioReader", "MotionData", "MotionFormat", "MotionRepresentation", "Dataset",
         "Schedule", "JointClip", "MetricResult", "Metric"),
        "dance_core.protocols",
    ),
    # what a builder receives besides its config
    **dict.fromkeys(("ConditionerContext", "EncoderContext", "HeadContext", "DatasetContext", "FormatOptions"),
                    "dance_core.contexts"),
    # media
    **dict.fromkeys(("Audio", "FeatureInputs", "TextSpan", "frame_count"), "dance_core.media"),
    # text spans as tables: a song's (SpanTable) and a batch's (TextSpans, what heads read)
    **dict.fromkeys(("SpanTable", "TextSpans", "span_index"), "dance_core.spans"),
    **dict.fromkeys(("ClipSource",), "dance_core.data.sources"),
    **dict.fromkeys(("Motion", "Skeleton"), "dance_core.motion"),
    # one quaternion slerp for every package (scalar-last, shorter arc, broadcasting weights)
    **dict.fromkeys(("quat_slerp",), "dance_core.motion.rotations"),
    # the registry
    **dict.fromkeys(("Registry", "Entry", "get_registry"), "dance_core.registry"),
    # helpers plugins need: audio in, files out
    **dict.fromkeys(("load_audio", "check_audio_path"), "dance_core.data.features"),
    **dict.fromkeys(("atomic_path", "pid_alive", "write_bytes", "write_text"), "dance_core.atomic"),
    # per-row random streams: heads draw noise through draw_rows (songs composed in one batch)
    **dict.fromkeys(("RowGenerators", "draw_rows"), "dance_core.row_generators"),
    # command-line checks for plugin commands (register_commands): ranges while parsing, paths before work
    **dict.fromkeys(
        ("bounded_number", "check_input_file", "check_input_dir", "check_output_file", "check_output_dir"),
        "dance_core.checks",
    ),
    # what a plugin command says it did: nothing under -q
    **dict.fromkeys(("say",), "dance_core.progress"),
}

__all__ = [
    "CheckpointError",
    "ComponentConfig",
    "DanceError",
    "DataError",
    "PluginError",
    "RecipeError",
    "TrainingError",
    "__version__",
    "hookimpl",
    *_LAZY,
]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'dance_core' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)


if TYPE_CHECKING:  # for type checkers and editors; at run time the names load lazily
    from dance_core.atomic import atomic_path, pid_alive, write_bytes, write_text  # noqa: F401
    from dance_core.checks import (  # noqa: F401
        bounded_number,
        check_input_dir,
        check_input_file,
        check_output_dir,
        check_output_file,
    )
    from dance_core.contexts import (  # noqa: F401
        ConditionerContext,
        DatasetContext,
        EncoderContext,
        FormatOptions,
        HeadContext,
    )
    from dance_core.data.features import check_audio_path, load_audio  # noqa: F401
    from dance_core.data.sources import ClipSource  # noqa: F401
    from dance_core.media import Audio, FeatureInputs, TextSpan, frame_count  # noqa: F401
    from dance_core.motion import Motion, Skeleton  # noqa: F401
    from dance_core.progress import say  # noqa: F401
    from dance_core.protocols import (  # noqa: F401
        AudioReader,
        Conditioner,
        Dataset,
        Encoder,
        FeatureExtractor,
        JointClip,
        Metric,
        MetricResult,
        MotionData,
        MotionFormat,
        MotionRepresentation,
        OutputHead,
        Schedule,
        SongInputs,
        SpanFeatureExtractor,
        TrainContext,
        Window,
    )
    from dance_core.registry import Entry, Registry, get_registry  # noqa: F401
    from dance_core.row_generators import RowGenerators, draw_rows  # noqa: F401
    from dance_core.spans import SpanTable, TextSpans, span_index  # noqa: F401
