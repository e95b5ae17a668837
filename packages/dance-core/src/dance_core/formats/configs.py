"""Pydantic configs of core's file formats and audio readers (light: registering them imports no NumPy)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, PositiveFloat, PositiveInt

from dance_core.config import ComponentConfig


class WavReaderConfig(ComponentConfig):
    """No options."""


class NpzFormatConfig(ComponentConfig):
    """Compression on or off."""

    compress: bool = True


class BvhFormatConfig(ComponentConfig):
    """Length scale applied on read (inverted on write), decimals written, the files' up axis, and how
    the root's position channels are read."""

    scale: PositiveFloat = 1.0
    precision: PositiveInt = 6
    up: Literal["y", "z"] = Field("y", description="up axis of the files; z-up files are turned to y-up on read")
    root: Literal["auto", "absolute", "relative"] = Field(
        "auto", description="root position channels: absolute (the BVH convention, what dance writes), relative "
        "to the root OFFSET (files dance wrote before), or auto: relative only when the figure stands on the "
        "floor read that way and not read absolute")


class GlbFormatConfig(ComponentConfig):
    """Whether a glb gets a simple skinned body (a box per bone) besides its skeleton."""

    body: bool = Field(True, description="add a body of boxes bound to the bones, so the dance shows in a viewer")


class SmplFormatConfig(ComponentConfig):
    """Frame rate of AIST++ pickles (they store none), the translation scale to metres, and the user's
    SMPL body model file that gives the joint positions."""

    fps: PositiveFloat = 60.0
    trans_scale: PositiveFloat | None = Field(None, description="multiply smpl_trans; default 1/smpl_scaling")
    model: str | None = Field(
        None, json_schema_extra={"path": True},
        description="SMPL body model file (SMPL_NEUTRAL.pkl or .npz from smpl.is.tue.mpg.de, licensed by its "
        "authors): the rest joints are its J_regressor @ v_template; relative to the recipe; default the "
        "DANCE_SMPL_MODEL environment variable (dance ... --smpl-model PATH sets it)",
    )


class JointsFormatConfig(ComponentConfig):
    """HumanML3D ``new_joints`` arrays ``(T, 22, 3)``: their frame rate."""

    fps: PositiveFloat = 20.0


class KeypointsFormatConfig(ComponentConfig):
    """2D keypoints ``(T, 25, 2|3)`` in OpenPose BODY_25 order: their frame rate and pixel scale."""

    fps: PositiveFloat = 30.0
    scale: PositiveFloat = 1.0


class PreviewFormatConfig(ComponentConfig):
    """Size and frame rate of rendered previews."""

    width: PositiveInt = 480
    height: PositiveInt = 480
    fps: PositiveFloat | None = Field(None, description="frame rate of the preview; default the motion's (max 30)")
    trail: bool = True
