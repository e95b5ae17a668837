"""Composition: music in, dances out, with a trained model.

- ``inputs``: the caller's typed options (``ComposeOptions``) and what a composition reads and writes,
  resolved once (``resolve_inputs`` -> ``ComposeInputs``) for the CLI and the loop alike;
- ``songs``: a song's features and text spans, the seed motion, the model loaded from its checkpoint;
- ``generate``: a song's dances, one song at a time or several in one batch;
- ``output``: each song's output set, decoded, on the beat, grounded and written;
- ``loop``: ``compose_songs`` / ``run_compose``, the loop over songs behind ``dance compose``.
"""

from dance_core.compose.generate import batching_note, generate_song, generate_songs
from dance_core.compose.inputs import (
    ComposeInputs,
    ComposeOptions,
    MusicInput,
    audio_files,
    beside_recipe,
    expand_music,
    reads_text,
    resolve_inputs,
)
from dance_core.compose.loop import Composed, compose, compose_songs, run_compose
from dance_core.compose.output import complete, finished, output_stems, output_targets, write_song
from dance_core.compose.songs import Song, beat_tracker_of, load_model, load_song, seed_motion, song_texts

__all__ = [
    "ComposeInputs",
    "ComposeOptions",
    "Composed",
    "MusicInput",
    "Song",
    "audio_files",
    "batching_note",
    "beat_tracker_of",
    "beside_recipe",
    "complete",
    "compose",
    "compose_songs",
    "expand_music",
    "generate_song",
    "generate_songs",
    "finished",
    "load_model",
    "load_song",
    "output_stems",
    "output_targets",
    "reads_text",
    "resolve_inputs",
    "run_compose",
    "seed_motion",
    "song_texts",
    "write_song",
]
