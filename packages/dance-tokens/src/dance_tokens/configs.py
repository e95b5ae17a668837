"""Pydantic configs of the tokens plugin's components (no torch here, so registering them is cheap).

Defaults are TM2D's (Gong et al., ICCV 2023, sections 3.2-3.5): t = 8, K = 1024, 64-frame crops, 6-layer
transformers of width 512 with 8 heads, top-k 100, late-fusion weight 0.8. Options the paper does not give
(code width, feed-forward width, dropout, attention spans) are marked as ours in their descriptions.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, PositiveInt, model_validator

from dance_core import ComponentConfig

Generation = {"generation": True}


def _power_of_two(value: int, what: str) -> None:
    if value < 2 or value & (value - 1):
        raise ValueError(f"{what} must be a power of two (one strided layer per halving), got {value}")


def _heads_divide(dim: int, heads: int, what: str) -> None:
    if dim % heads or (dim // heads) % 2:
        raise ValueError(f"{what}: heads ({heads}) must divide dim ({dim}) into an even width per head")


class TokenizerConfig(ComponentConfig):
    """The motion VQ-VAE: ``log2(downsample)`` strided 1-D conv layers each way and a codebook."""

    codes: PositiveInt = Field(1024, description="K, codebook size")
    code_dim: PositiveInt = Field(512, description="d, width of a code (ours: not in the paper)")
    width: PositiveInt = Field(512, description="channels of the conv layers (ours)")
    downsample: PositiveInt = Field(8, description="t, frames per token: log2(t) layers (3 for t = 8)")
    beta: float = Field(0.25, ge=0.0, description="weight of the commitment loss (van den Oord et al.)")
    recon: Literal["l1", "smooth-l1"] = Field(
        "l1", description="reconstruction loss: L1 as in the paper, or smooth L1 (Huber, beta 1; ours)"
    )
    crop: PositiveInt = Field(64, description="frames of each training crop")
    root_channels: int = Field(0, ge=0, description="how many leading motion channels are the root's (4 with "
                               "`rotations` and `root: deltas`: dx, dz, y, dyaw); they weigh `root_weight` in the "
                               "reconstruction loss (ours; 0: every channel weighs 1, as in the paper)")
    root_weight: float = Field(1.0, gt=0.0, description="weight of the `root_channels` in the reconstruction loss: "
                               "a turn lives in one channel (dyaw) of 76 and is lost at weight 1")
    velocity: float = Field(0.0, ge=0.0, description="weight of an L1 loss on the reconstruction's frame-to-frame "
                            "differences (ours, as Bailando's and T2M-GPT's VQ-VAEs; 0: off, as in the paper)")
    acceleration: float = Field(0.0, ge=0.0, description="weight of an L1 loss on its second differences "
                                "(ours; 0: off): against the jitter a decoder adds between frames")
    positions: float = Field(0.0, ge=0.0, description="weight of an L1 loss on the joints' positions (metres) of "
                             "the reconstruction, by forward kinematics of the decoded `rotations` motion in the "
                             "body's own frame (ours; 0: off): a foot's height is one number there, spread over "
                             "several rotation channels in the representation")
    position_velocity: float = Field(0.0, ge=0.0, description="weight of an L1 loss on those positions' "
                                     "frame-to-frame differences (metres per frame; ours; 0: off)")
    position_weights: dict[str, float] = Field(
        default_factory=dict, description="joint name -> its weight in the position losses (others 1; "
        "a weighted mean over joints), e.g. the feet and hands"
    )
    restart_after: PositiveInt | None = Field(
        None, description="replace a code unused for this many training batches by a random encoder output "
        "(dead-code restart; null: off, as in the paper)"
    )

    @model_validator(mode="after")
    def _shapes(self):
        _power_of_two(self.downsample, "downsample")
        bad = {name: w for name, w in self.position_weights.items() if w < 0}
        if bad:
            raise ValueError(f"position_weights must not be negative, got {bad}")
        if self.crop % self.downsample:
            raise ValueError(f"crop ({self.crop}) must be a multiple of downsample ({self.downsample})")
        return self


class PriorConfig(ComponentConfig):
    """The cross-modal transformer's text encoder and shared causal motion decoder."""

    dim: PositiveInt = 512
    layers: PositiveInt = Field(6, description="motion decoder layers")
    text_layers: PositiveInt = Field(6, description="text encoder layers")
    heads: PositiveInt = 8
    ffn: PositiveInt = Field(2048, description="feed-forward width (ours; 4 × dim: 78.5 M in tm2d, the paper 72 M)")
    dropout: float = Field(0.1, ge=0.0, lt=1.0)
    vocab_size: PositiveInt = Field(
        512, description="word embeddings: at least the word-tokens vocabulary's length (ids 0-3 are specials)"
    )
    context: PositiveInt | None = Field(
        32, description="inputs (BOS and past tokens) each decoder position attends to (ours; null: all)"
    )
    radius: int | None = Field(
        16, ge=0, description="a token attends to audio tokens at most this far away (ours; null: all)"
    )

    @model_validator(mode="after")
    def _heads(self):
        _heads_divide(self.dim, self.heads, "prior")
        return self


class TM2DHeadConfig(ComponentConfig):
    """TM2D's motion tokens and token prior as one output head (see dance_tokens.head)."""

    tokenizer: TokenizerConfig = Field(default_factory=TokenizerConfig)
    prior: PriorConfig = Field(default_factory=PriorConfig)
    text_stream: str | None = Field("text", description="feature stream of word-token ids; null: music only")
    tokenizer_stage: str = Field("tokenizer", description="the training stage that trains the VQ-VAE")
    top_k: PositiveInt = Field(100, description="tokens sampled among the k most likely", json_schema_extra=Generation)
    fusion: float = Field(0.8, ge=0.0, le=1.0, description="peak text weight of the late fusion",
                          json_schema_extra=Generation)
    ramp: float = Field(0.2, gt=0.0, le=0.5, description="fraction of a text span spent rising (and falling)",
                        json_schema_extra=Generation)


class AudioEncoderConfig(ComponentConfig):
    """TM2D's audio encoder: music at the token rate, an embedding and transformer encoder layers."""

    dim: PositiveInt = 512
    layers: PositiveInt = 6
    heads: PositiveInt = 8
    ffn: PositiveInt = Field(2048, description="feed-forward width (ours)")
    dropout: float = Field(0.1, ge=0.0, lt=1.0)
    downsample: PositiveInt = Field(8, description="frames per token; must equal the head's tokenizer.downsample")
    pool: Literal["mean", "first", "stack"] = Field(
        "mean", description="music at the token rate: the mean of each token's frames, its first frame, or "
        "(ours) all its frames side by side, so a beat's frame within the token is kept"
    )
    radius: int | None = Field(
        16, ge=0, description="a token attends to tokens at most this far away (ours; null: all)"
    )
    ignore: list[str] = Field(["text"], description="streams the audio encoder does not read (the head's text)")

    @model_validator(mode="after")
    def _shapes(self):
        _power_of_two(self.downsample, "downsample")
        _heads_divide(self.dim, self.heads, "tm2d-audio")
        return self
