"""The recipe's pydantic models. Component options are validated later by each plugin's config."""

from __future__ import annotations

import copy
import re
from typing import Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PositiveFloat,
    PositiveInt,
    PrivateAttr,
    field_validator,
    model_serializer,
    model_validator,
)


class Strict(BaseModel):
    """A recipe section: unknown fields are errors."""

    model_config = ConfigDict(extra="forbid")


class ComponentSpec(BaseModel):
    """``{plugin: name, ...options}``; the options are checked by that plugin's config model."""

    model_config = ConfigDict(extra="allow")

    plugin: str = Field(description="registered name of the component")
    _config: Any = PrivateAttr(default=None)
    _entry: Any = PrivateAttr(default=None)
    _base: str = PrivateAttr(default=".")

    def options(self) -> dict[str, Any]:
        """The options given next to ``plugin``."""
        return dict(self.model_extra or {})

    @property
    def config(self) -> Any:
        """The plugin's validated config (set when the recipe is resolved)."""
        if self._entry is None:
            raise RuntimeError(f"component {self.plugin!r} has not been validated")
        return self._config

    def build(self, context: Any = None) -> Any:
        """Build the component with its validated config and its kind's context (``dance_core.contexts``)."""
        if self._entry is None:
            raise RuntimeError(f"component {self.plugin!r} has not been validated")
        return self._entry.build(resolve_paths(self._config, self._base), context)


def resolve_paths(config: Any, base: str) -> Any:
    """A config whose relative file options (fields marked ``json_schema_extra={"path": True}``) point
    into ``base``, the folder of the recipe file that wrote them, so a bundled recipe finds its own
    files from anywhere; the recipe (and a checkpoint's copy of it) keeps them as written."""
    from pathlib import Path

    if config is None:
        return None
    update = {}
    for name, f in type(config).model_fields.items():
        value = getattr(config, name)
        if isinstance(f.json_schema_extra, dict) and f.json_schema_extra.get("path") and isinstance(value, str):
            p = Path(value).expanduser()
            if not p.is_absolute():
                update[name] = str(Path(base) / p)
    return config.model_copy(update=update) if update else config


class ModelSpec(Strict):
    """Conditioners (by stream name), an encoder and an output head."""

    conditioners: dict[str, ComponentSpec] = Field(default_factory=dict)
    encoder: ComponentSpec
    head: ComponentSpec


class DataSpec(Strict):
    """Where training clips come from and how they are cut."""

    dataset: ComponentSpec
    val_fraction: float = Field(0.1, ge=0.0, lt=1.0)
    mirror: bool = Field(False, description="add left/right mirrored copies of skeletal training clips")
    segment_frames: PositiveInt | None = Field(None, description="training segment length for song-level encoders")


class OptimizerSpec(Strict):
    """AdamW settings."""

    lr: PositiveFloat = 1e-3
    weight_decay: float = Field(0.0, ge=0.0)
    betas: tuple[float, float] = (0.9, 0.999)


class StageSpec(Strict):
    """One training stage: how long, and which parameters (by name prefix) it trains."""

    name: str
    steps: PositiveInt
    trainable: list[str] = Field(default_factory=list, description="prefixes; empty: all")
    lr: PositiveFloat | None = None
    batch_size: PositiveInt | None = Field(None, description="segments per batch in this stage; default training's")


class AugmentSpec(Strict):
    """Training-time corruption of the model's inputs (never of its targets), against a model that
    leans on its own motion history and ignores the music, or that cannot recover from its errors."""

    motion_noise: float = Field(
        0.0, ge=0.0, description="std of Gaussian noise on past motion (normalized units), per segment ~U(0, std)"
    )
    input_dropout: dict[str, float] = Field(
        default_factory=dict,
        description="per input ('motion' or a feature stream name): probability that a frame is zeroed",
    )

    @field_validator("input_dropout")
    @classmethod
    def _probabilities(cls, v: dict[str, float]) -> dict[str, float]:
        for name, p in v.items():
            if not 0.0 <= p < 1.0:
                raise ValueError(f"input_dropout.{name}: {p} is not a probability in [0, 1)")
        return v


class InitSpec(Strict):
    """Start a run from a trained checkpoint's weights: fine-tuning, or training a new part (a prior, a
    head) on top of parts trained before."""

    checkpoint: str = Field(description="safetensors checkpoint (relative to the recipe)")
    weights: list[str] = Field(
        default_factory=lambda: [""],
        description="parameter name prefixes to take from it ('': all); every parameter they name must be in "
        "the checkpoint with the same shape",
    )
    stats: bool = Field(
        True, description="normalize the data with the checkpoint's statistics (the weights taken expect them) "
        "instead of fitting them to the data",
    )


class TrainingSpec(Strict):
    """Optimization, schedules, devices, checkpoints and logging."""

    steps: PositiveInt = 1000
    batch_size: PositiveInt = Field(32, description="segments per step on each process (torchrun: per rank)")
    optimizer: OptimizerSpec = Field(default_factory=OptimizerSpec)
    lr_schedule: ComponentSpec = Field(default_factory=lambda: ComponentSpec(plugin="constant"))
    schedules: dict[str, ComponentSpec] = Field(
        default_factory=dict, description="named values handed to the model's loss every step"
    )
    grad_clip: PositiveFloat | None = 1.0
    device: Literal["auto", "cpu", "cuda", "mps"] = "auto"
    threads: PositiveInt | None = Field(None, description="CPU threads for torch (default: torch's choice)")
    precision: Literal["auto", "fp32", "bf16", "fp16"] = Field(
        "auto", description="autocast on CUDA (auto: bf16 on CUDA); a CPU run trains in fp32, with a note"
    )
    compile: bool = Field(False, description="torch.compile the training loss on CUDA (ignored on CPU, with a note)")
    val_every: PositiveInt = 200
    val_batches: PositiveInt = 4
    checkpoint_every: PositiveInt = 500
    log_every: PositiveInt = 25
    stages: list[StageSpec] | None = None
    augment: AugmentSpec = Field(default_factory=AugmentSpec)
    init: InitSpec | None = Field(None, description="start from a trained checkpoint's weights")
    output: str = Field("runs/{name}", description="run folder; {name} is the recipe name")

    def stage_list(self) -> list[StageSpec]:
        """The stages, or one stage ``main`` of ``steps`` steps."""
        return self.stages or [StageSpec(name="main", steps=self.steps)]


class TextSpec(Strict):
    """A text instruction for a span of every composed song (seconds; no span: the whole song)."""

    text: str = Field(min_length=1)
    start: float | None = Field(None, ge=0.0)
    end: float | None = Field(None, gt=0.0)

    @model_validator(mode="after")
    def _ordered(self) -> TextSpec:
        if self.start is not None and self.end is not None and self.end <= self.start:
            raise ValueError(f"end ({self.end:g} s) must come after start ({self.start:g} s)")
        return self

    @classmethod
    def parse(cls, given: str) -> TextSpec:
        """``"20-30: a person jumps"`` (span in seconds) or ``"a person jumps"`` (the whole song)."""
        match = re.match(r"^\s*(\d+(?:\.\d*)?)?\s*-\s*(\d+(?:\.\d*)?)?\s*:\s*(.*)$", given, re.S)
        head = given.split(":", 1)[0] if ":" in given else ""
        if match is None and re.fullmatch(r"[\s\d.+\-eE]*", head) and re.search(r"\d", head):
            raise ValueError(f"malformed span {head.strip()!r}: expected START-END: TEXT in seconds from 0, "
                             "e.g. '20-30: a person jumps' (or no span for the whole song)")
        if match is None:
            return cls(text=given.strip())
        start, end, text = match.groups()
        return cls(text=text.strip(), start=float(start) if start else None, end=float(end) if end else None)


class ComposeSpec(Strict):
    """What ``dance compose`` makes."""

    music: list[str] = Field(default_factory=list, description="songs (relative to the recipe)")
    checkpoint: str | None = None
    seed_motion: str | None = Field(
        None, description="a motion file (as given, else relative to the recipe), or 'rest'"
    )
    seconds: PositiveFloat | None = Field(None, description="length; default the whole song")
    start: float = Field(0.0, ge=0.0, allow_inf_nan=False, description="seconds into the song the dance starts "
                         "at (text spans stay in the song's time; markers are from the dance's first frame)")
    temperature: float = Field(1.0, ge=0.0)
    samples: PositiveInt = 1
    batch_songs: PositiveInt = Field(
        1, description="songs generated in one batch (each padded with its last music frame to the longest, "
        "then trimmed); 1: each song alone, the same bytes whatever it is composed with. Above 1 (for GPUs): "
        "equal within float rounding to per-song generation, not bit-identical; deterministic for a given "
        "batch composition. Models whose head does not draw per row, or with a song-level encoder, compose "
        "one song at a time",
    )
    keep: PositiveInt | None = Field(None, description="frames kept per step; default the head's")
    formats: list[str] = Field(default_factory=lambda: ["npz"])
    out_dir: str = "out"
    device: Literal["auto", "cpu", "cuda", "mps"] = "auto"
    threads: PositiveInt | None = Field(
        None, description="CPU threads for torch (default: 1 for small models on CPU, else up to 4)"
    )
    ground: bool = Field(
        True, description="put skeletal dances on the floor and pin feet in contact (dance_core.motion.grounding)"
    )
    lead_in: bool = Field(
        False, description="dance a lead-in before the song starts (the seed, then a pre-roll of the song's "
        "opening) and drop it, so the dance moves from its first frame (windowed models without text or edits)"
    )
    beat_align: bool = Field(
        False, description="move the dance's own accents onto the song's beats by a smooth time warp "
        "(dance_core.motion.beat_align; beats from the recipe's beat tracker, else flux)"
    )
    texts: list[TextSpec] = Field(
        default_factory=list, description="text instructions over spans of each song (models that read text)"
    )
    markers: bool = Field(
        False, description="also write each dance's .markers.json sidecar: the song's beats, downbeats and sections "
        "(needs a beat tracker: dance-audio) and the dance's foot contacts; a glb carries them too"
    )
    rig: str | None = Field(
        None, description="retarget each dance onto this rig before writing: a motion file whose skeleton is your "
        "character (.bvh, .glb; as given, else relative to the recipe) or dance24 / transflower21"
    )
    rig_map: str | None = Field(
        None, description="the rig's joint map: a preset name or a YAML file (default: detected)"
    )
    output_fps: PositiveFloat | None = Field(
        None, le=1000.0, description="frame rate of the files written (resampled); default the model's"
    )
    units: Literal["m", "cm"] | None = Field(None, description="length units of the files written (glb: always m)")
    up: Literal["y", "z"] = Field(
        "y", description="up axis of the files written: z for Z-up tools (bvh and npz; glb is Y up by the glTF spec)"
    )
    keyframes: list[str] = Field(
        default_factory=list, description="poses the dance passes through, 'SECONDS=POSE_FILE[:FRAME]' (files as "
        "given, else relative to the recipe); blended in and out over up to 1 s either side"
    )
    keep_parts: dict[str, str] = Field(
        default_factory=dict, description="body parts taken from a given motion, {legs|arms|upper|lower|root: FILE}; "
        "autoregressive models generate the rest continuing from them"
    )
    face: Literal["free", "camera"] = Field(
        "free", description="camera: keep the dancer facing +Z (slow heading drift removed, quick turns bounded)"
    )
    max_turn: PositiveFloat | None = Field(None, description="limit on turning speed, degrees per second")
    loop: bool = Field(False, description="bend the dance's last second so its last frame leads into its first")
    from_motion: str | None = Field(
        None, description="a dance to edit (at the model's skeleton and fps): compose.regenerate's spans are "
        "generated again, every other frame kept bit for bit"
    )
    regenerate: list[str] = Field(
        default_factory=list, description="spans of from_motion to regenerate, 'START-END' in seconds"
    )


def _has(parent: dict | list, key: Any) -> bool:
    return key in parent if isinstance(parent, dict) else isinstance(key, int) and 0 <= key < len(parent)


class Recipe(Strict):
    """A whole recipe: features, model, data, training and composition."""

    extends: str | None = Field(None, description="base recipe file or bundled recipe name")
    name: str
    description: str = ""
    seed: int = 0
    fps: PositiveFloat = 20.0
    features: dict[str, list[ComponentSpec]] = Field(default_factory=dict)
    motion: ComponentSpec | None = Field(
        None, description="motion representation: skeletal motion to model features and back"
    )
    model: ModelSpec
    data: DataSpec | None = None
    training: TrainingSpec = Field(default_factory=TrainingSpec)
    compose: ComposeSpec = Field(default_factory=ComposeSpec)
    formats: dict[str, dict[str, Any]] = Field(
        default_factory=dict,
        description="options of motion formats and audio readers by name ({bvh: {up: z}}), used wherever this "
        "recipe reads or writes a file by its suffix: its dataset's motion and songs, the seed motion, the songs "
        "composed and compose.formats' outputs",
    )
    _dir: str = PrivateAttr(default=".")
    _origin: str = PrivateAttr(default="<recipe>")
    _formats: Any = PrivateAttr(default=None)

    @model_serializer(mode="wrap")
    def _without_empty_formats(self, handler: Any) -> Any:
        """Dumps of recipes without ``formats:`` stay as they were (run ids, checkpoints, ``recipe show``)."""
        data = handler(self)
        if isinstance(data, dict) and not self.formats:
            data.pop("formats", None)
        return data

    @property
    def format_options(self) -> Any:
        """The ``formats:`` options validated by each format's or reader's config (a ``FormatOptions``)."""
        if self._formats is None:
            raise RuntimeError("the recipe's formats have not been validated")
        return self._formats

    @property
    def origin(self) -> str:
        """Where the recipe came from, for messages: its file (a bundled recipe's too), else ``<recipe>``."""
        return self._origin

    @property
    def folder(self) -> str:
        """The folder the recipe's relative paths are read from: its file's folder (read-only)."""
        return self._dir

    def components(self) -> list[tuple[str, tuple[Any, ...], ComponentSpec]]:
        """Every component spec as (kind, location, spec)."""
        found: list[tuple[str, tuple[Any, ...], ComponentSpec]] = []
        for stream, extractors in self.features.items():
            for i, spec in enumerate(extractors):
                found.append(("feature", ("features", stream, i), spec))
        for name, spec in self.model.conditioners.items():
            found.append(("conditioner", ("model", "conditioners", name), spec))
        if self.motion is not None:
            found.append(("motion-representation", ("motion",), self.motion))
        found.append(("encoder", ("model", "encoder"), self.model.encoder))
        found.append(("head", ("model", "head"), self.model.head))
        if self.data is not None:
            found.append(("dataset", ("data", "dataset"), self.data.dataset))
        found.append(("schedule", ("training", "lr_schedule"), self.training.lr_schedule))
        for name, spec in self.training.schedules.items():
            found.append(("schedule", ("training", "schedules", name), spec))
        return found

    def resolve_path(self, path: str) -> str:
        """A path from the recipe, relative to the recipe file's folder."""
        from pathlib import Path

        p = Path(path).expanduser()
        return str(p if p.is_absolute() else Path(self._dir) / p)

    def model_dict(self, data: dict[str, Any] | None = None) -> dict[str, Any]:
        """The parts a checkpoint must agree with: fps, features, model (and motion, when set), each
        component with its options resolved (defaults filled in, so an option given at its default
        equals one left out) and without its generation-only options (fields whose schema says
        ``generation: true``: a checkpoint trained with other values still fits). ``data``: another
        recipe's dump (a checkpoint's) to put in the same form, read with this recipe's plugins."""
        data = self.model_dump(mode="json") if data is None else data
        keys = ("fps", "features", "model", "motion")
        out = {key: copy.deepcopy(data[key]) for key in keys if data.get(key) is not None}
        for _, where, spec in self.components():
            if where[0] not in out or spec._entry is None:
                continue
            parent = out
            for key in where[:-1]:
                parent = parent.get(key) if isinstance(parent, dict) else None
                parent = parent if isinstance(parent, (dict, list)) else None
                if parent is None:
                    break
            last = where[-1]
            if parent is None or not _has(parent, last) or not isinstance(parent[last], dict):
                continue
            given = parent[last]
            if given.get("plugin") != spec.plugin:
                continue  # another plugin: the difference shows as it is
            config_type = type(spec._config)
            try:
                resolved = config_type(**{k: v for k, v in given.items() if k != "plugin"}).model_dump(mode="json")
            except ValueError:
                continue  # options this plugin no longer takes: left as given, so they differ
            skip = {n for n, f in config_type.model_fields.items()
                    if isinstance(f.json_schema_extra, dict) and f.json_schema_extra.get("generation")}
            parent[last] = {"plugin": spec.plugin, **{k: v for k, v in resolved.items() if k not in skip}}
        return out
