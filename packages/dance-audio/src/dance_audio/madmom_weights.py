"""Reads madmom's downbeat BLSTM weights from the installed madmom package, without running its code.

madmom ships its models as pickles. They are read here with a restricted unpickler that allows
only NumPy's array reconstruction and turns madmom's layer classes into plain records, so no
madmom (or any other) code runs while loading and nothing outside that list can be constructed.
"""

from __future__ import annotations

import importlib.util
import pickle
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dance_core import PluginError

from .madmom_compat import INSTALL_HINT

MODEL_DIR = Path("models") / "downbeats" / "2016"
MODEL_FILES = tuple(f"downbeats_blstm_{i}.pkl" for i in range(1, 9))
_NUMPY = {
    ("numpy.core.multiarray", "_reconstruct"),
    ("numpy._core.multiarray", "_reconstruct"),
    ("numpy", "ndarray"),
    ("numpy", "dtype"),
}


class _Record:
    """A madmom object reduced to its class name and pickled attributes."""

    kind = "?"

    def __init__(self, *_):
        self.state: dict = {}

    def __setstate__(self, state):
        self.state = dict(state)


_RECORD_TYPES: dict[str, type] = {}


def _record_type(name: str) -> type:
    if name not in _RECORD_TYPES:
        _RECORD_TYPES[name] = type(name, (_Record,), {"kind": name})
    return _RECORD_TYPES[name]


class _Activation:
    """A madmom activation function, kept by name."""

    def __init__(self, name: str):
        self.name = name


class _RestrictedUnpickler(pickle.Unpickler):
    def find_class(self, module, name):
        if (module, name) in _NUMPY:
            from numpy._core import multiarray

            return multiarray._reconstruct if name == "_reconstruct" else getattr(np, name)
        if module.startswith("madmom.ml.nn.activations"):
            return _Activation(name)
        if module.startswith("madmom.ml.nn"):
            return _record_type(name)
        raise pickle.UnpicklingError(f"global {module}.{name} is not allowed in a madmom model")


def _load(path: Path) -> _Record:
    with open(path, "rb") as f:
        obj = _RestrictedUnpickler(f, encoding="latin1").load()
    if not isinstance(obj, _Record) or obj.kind != "NeuralNetwork":
        raise PluginError(f"{path}: not a madmom neural network")
    return obj


@dataclass
class LSTMWeights:
    """One direction of one BLSTM layer: input, recurrent and peephole weights per gate (i, f, c, o)."""

    w_in: np.ndarray  # (inputs, 4 * hidden)
    w_rec: np.ndarray  # (hidden, 4 * hidden)
    bias: np.ndarray  # (4 * hidden,)
    peep: np.ndarray  # (3, hidden): input, forget and output gate peepholes


@dataclass
class NetworkWeights:
    """One network of the ensemble: BLSTM layers (forward, backward) and the softmax output layer."""

    layers: list[tuple[LSTMWeights, LSTMWeights]]
    out_w: np.ndarray
    out_b: np.ndarray


def _gate_arrays(gate: _Record, hidden: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    s = gate.state
    peep = s.get("peephole_weights")
    peep = np.zeros(hidden, np.float32) if peep is None else np.asarray(peep, np.float32).reshape(-1)
    return (
        np.asarray(s["weights"], np.float32),
        np.asarray(s["recurrent_weights"], np.float32),
        np.asarray(s["bias"], np.float32).reshape(-1),
        peep,
    )


def _lstm(layer: _Record) -> LSTMWeights:
    s = layer.state
    names = ("input_gate", "forget_gate", "cell", "output_gate")
    expected = ("sigmoid", "sigmoid", "tanh", "sigmoid")
    hidden = np.asarray(s["cell"].state["bias"]).size
    parts = [_gate_arrays(s[n], hidden) for n in names]
    acts = tuple(s[n].state["activation_fn"].name for n in names)
    if acts != expected or s["activation_fn"].name != "tanh":
        raise PluginError(f"unexpected madmom LSTM activations {acts}")
    return LSTMWeights(
        w_in=np.concatenate([p[0] for p in parts], axis=1),
        w_rec=np.concatenate([p[1] for p in parts], axis=1),
        bias=np.concatenate([p[2] for p in parts]),
        peep=np.stack([parts[0][3], parts[1][3], parts[3][3]]),
    )


def madmom_models_dir() -> Path:
    """The installed madmom package's downbeat model folder (madmom is located, not imported)."""
    spec = importlib.util.find_spec("madmom")
    if spec is None or not spec.submodule_search_locations:
        raise PluginError(INSTALL_HINT)
    return Path(next(iter(spec.submodule_search_locations))) / MODEL_DIR


def load_downbeat_ensemble() -> list[NetworkWeights]:
    """The 8 BLSTM networks of madmom's RNNDownBeatProcessor."""
    folder = madmom_models_dir()
    nets = []
    for name in MODEL_FILES:
        path = folder / name
        if not path.exists():
            raise PluginError(f"{path}: madmom model file missing; reinstall madmom")
        net = _load(path)
        layers = net.state["layers"]
        blstm = [(_lstm(x.state["fwd_layer"]), _lstm(x.state["bwd_layer"])) for x in layers[:-1]]
        out = layers[-1]
        if out.kind != "FeedForwardLayer" or out.state["activation_fn"].name != "softmax":
            raise PluginError(f"{path}: unexpected output layer {out.kind}")
        nets.append(
            NetworkWeights(
                blstm,
                np.asarray(out.state["weights"], np.float32),
                np.asarray(out.state["bias"], np.float32).reshape(-1),
            )
        )
    return nets
