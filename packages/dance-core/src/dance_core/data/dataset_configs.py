"""Pydantic configs of the datasets (light: registering them imports no heavy module)."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field, PositiveFloat, PositiveInt, ValidationError

from dance_core.config import ComponentConfig


class SyntheticBeatsConfig(ComponentConfig):
    """How many songs, how long, their tempi, and the dancer's size."""

    songs: PositiveInt = 12
    seconds: PositiveFloat = 12.0
    bpm: tuple[PositiveFloat, PositiveFloat] = (90.0, 140.0)
    sample_rate: PositiveInt = 16000
    joints: PositiveInt = 6
    seed: int = 0


class FolderDatasetConfig(ComponentConfig):
    """A folder of ``name.<audio>`` + ``name.<motion>`` pairs (relative to the recipe)."""

    path: str
    max_offset: float = Field(0.5, ge=0.0, description="largest allowed audio/motion length difference, seconds")
    cache: str | None = Field(None, description="feature cache folder; default <path>/.dance-cache")


class AistDatasetConfig(ComponentConfig):
    """The AIST++ layout: ``motions/*.pkl``, ``wav/*.wav``, ``splits/*.txt``."""

    path: str
    split: str | None = Field("crossmodal_train", description="split list name (splits/<name>.txt); None: all")
    max_offset: float = Field(1.0, ge=0.0)
    smpl_model: str | None = Field(
        None, description="your SMPL body model file (.pkl or .npz from smpl.is.tue.mpg.de), relative to the "
        "recipe: the joint positions of the pickles; default DANCE_SMPL_MODEL (dance train --smpl-model PATH)")


class HumanMLConfig(ComponentConfig):
    """HumanML3D: ``new_joints/*.npy`` (T, 22, 3) at 20 fps and ``texts/*.txt``; audio in ``audio/`` when any."""

    path: str
    split: str | None = Field("train", description="split list (<path>/<split>.txt); None: all")
    fps: PositiveFloat = 20.0


class MixPart(BaseModel):
    """One dataset of a ``mix``: ``{plugin, ...its options}``, and whether its texts are kept."""

    model_config = ConfigDict(extra="allow", frozen=True)

    plugin: str = Field(description="registered dataset name")
    keep_texts: bool = Field(True, description="False drops this part's texts (a music-dance corpus without text)")

    def options(self) -> dict[str, Any]:
        """The sub-dataset's own options (everything but ``plugin`` and ``keep_texts``)."""
        return dict(self.model_extra or {})


class MixConfig(ComponentConfig):
    """The clips of several datasets in one training set; each part is validated by its own plugin's config."""

    datasets: list[MixPart] = Field(min_length=1)

    @classmethod
    def model_validate(cls, obj: Any, **kwargs: Any) -> MixConfig:
        """Validate the mix, then every part with its registered config; a part's bad option is an error at
        ``datasets.N.<field>`` (so a recipe names ``data.dataset.datasets.N.<field>`` and its line)."""
        config = super().model_validate(obj, **kwargs)
        config.check_parts()
        return config

    def check_parts(self) -> None:
        """Raise pydantic's ``ValidationError`` naming ``datasets.N.<field>`` for every bad part option."""
        from pydantic_core import PydanticCustomError

        from dance_core.errors import PluginError
        from dance_core.registry import get_registry

        registry = get_registry()
        errors: list[Any] = []
        for i, part in enumerate(self.datasets):
            try:
                registry.get("dataset", part.plugin).validate(part.options())
            except PluginError as exc:  # an unknown plugin, or options given to one that takes none
                where = ("plugin",) if part.plugin not in registry.names("dataset") else ()
                errors.append({"type": PydanticCustomError("value_error", str(exc)), "loc": ("datasets", i, *where),
                               "input": part.plugin})
            except ValidationError as exc:
                errors += [{"type": PydanticCustomError(e["type"], e["msg"]), "loc": ("datasets", i, *e["loc"]),
                            "input": e.get("input")} for e in exc.errors()]
        if errors:
            raise ValidationError.from_exception_data(type(self).__name__, errors)


class MocapDatasetConfig(ComponentConfig):
    """A folder of motion-capture takes of any rig (no music), retargeted on load onto one skeleton."""

    path: str = Field(description="folder of motion files (BVH or any registered motion format), relative to "
                      "the recipe")
    files: list[str] | None = Field(None, description="file name patterns to take (e.g. ['salsa_*.bvh']); "
                                    "default every readable motion file")
    exclude: list[str] = Field(default_factory=list, description="file name patterns to leave out (held-out takes)")
    skeleton: str = Field("dance24", description="skeleton the takes are retargeted onto: a built-in name "
                          "(dance24, transflower21) or a motion file whose skeleton it is (relative to the recipe)")
    source_map: str | None = Field(None, description="joint map of the takes: a preset (smpl, cmu, cmu-daz, "
                                   "mixamo, unreal) or a YAML file; default detected per take")
    ground: bool = Field(True, description="put the retargeted feet on the floor and stop them skating")
    motion_fps: PositiveFloat | None = Field(None, description="frame rate of the clips; default the recipe's")
    sample_rate: PositiveInt = Field(22050, description="rate of the silent audio each clip carries")
    cache: str | None = Field(None, description="cache folder of retargeted takes; default "
                              "$XDG_CACHE_HOME/dance/mocap (the takes' folder may be read-only)")
