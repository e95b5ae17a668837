"""Entry module of the ``audio`` plugin: registers components lazily (no torch, librosa or madmom here)."""

from __future__ import annotations

from dance_core import hookimpl

from . import configs as c

_M = "dance_audio"


@hookimpl
def register_audio_readers(register):
    """soundfile (libsndfile) for wav, flac, ogg and mp3, preferred over core's WAV reader."""
    from .reader import SUFFIXES

    register(
        "soundfile",
        c.SoundFileReaderConfig,
        f"{_M}.reader:build",
        "wav, flac, ogg, mp3 via libsndfile (audioread fallback), mixed to mono",
        suffixes=SUFFIXES,
        priority=10,
    )


@hookimpl
def register_feature_extractors(register):
    """Music features (librosa, madmom) and text features."""
    register(
        "librosa-438",
        c.Librosa438Config,
        f"{_M}.librosa438:build",
        "DanceRevolution/Bailando/TM2D: MFCC, delta, chroma, onset, beat, tempogram (438)",
    )
    register("mel", c.MelConfig, f"{_M}.spectral:build_mel", "log-mel bands in dB (80)")
    register("onset", c.OnsetConfig, f"{_M}.spectral:build_onset", "spectral-flux onset strength (1)")
    register(
        "madmom-downbeat",
        c.DownbeatConfig,
        f"{_M}.downbeat:build",
        "madmom RNNDownBeatProcessor beat/downbeat activations, NumPy/numba port (2)",
    )
    register(
        "beats",
        c.BeatsConfig,
        f"{_M}.beats:build",
        "beat and downbeat one-hots and phases (our tempo-following HMM or librosa's tracker; madmom's DBN opt-in, "
        "non-commercial) (6)",
        beats=True,
    )
    register(
        "word-tokens",
        c.WordEmbeddingConfig,
        f"{_M}.text:build_word_tokens",
        "token ids of each frame's instruction, for a learned word embedding (TM2D)",
        reads=("text",),
    )
    register(
        "glove",
        c.GloveConfig,
        f"{_M}.text:build_glove",
        "mean GloVe vector of each frame's instruction, from a user-supplied file (+1 flag)",
        reads=("text",),
    )
    register(
        "sentence",
        c.SentenceEmbeddingConfig,
        f"{_M}.text:build_sentence",
        "all-MiniLM-L6-v2 sentence embedding, offline (dance-audio[text]) (384+1)",
        reads=("text",),
    )


@hookimpl
def register_commands(subparsers):
    """``dance features``: extract features of one song to an .npz (and a plot to check by eye)."""
    from dance_core import bounded_number

    p = subparsers.add_parser(
        "features",
        help="extract music features of a song to an .npz file",
        description="Extract the named feature extractors' frames of one song into an .npz (one array per "
        "extractor, plus fps); --plot also draws the song for a check by eye.",
        epilog="examples:\n"
        "  dance features song.mp3 -o feats.npz\n"
        "  dance features song.mp3 -x librosa-438 -x madmom-downbeat -o feats.npz --plot feats.png",
    )
    p.add_argument("song", help="audio file (wav, flac, ogg, mp3)")
    p.add_argument(
        "-x",
        "--extractor",
        action="append",
        dest="extractors",
        metavar="NAME",
        help="feature extractor to run (repeatable; default: librosa-438; see dance plugins)",
    )
    p.add_argument("-o", "--out", required=True, metavar="FILE", help="output .npz (one array per extractor, plus fps)")
    p.add_argument("--fps", type=bounded_number(float, 0.0, 1000.0, above=True), default=30.0,
                   help="frames per second, up to 1000")
    p.add_argument("--plot", metavar="FILE",
                   help="also write a PNG: mel spectrogram, onset envelope, beats and downbeats")
    p.set_defaults(run=_run_features)


def _run_features(args) -> int:
    from .cli import run_features

    return run_features(args)
