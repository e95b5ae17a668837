"""The cross-modal prior learns: on token sequences that follow the music (or a sentence), its
cross-entropy falls far below log K, the loss of guessing."""

import math

import torch
import torch.nn.functional as F

from dance_tokens.configs import PriorConfig
from dance_tokens.prior import CrossModalPrior

K, N, D = 32, 12, 8


def batch(gen, size=16):
    """Audio tokens of 4 kinds; token j is set by kind j and the previous token's parity; the text
    branch's sentences (ids 4-7) each name one fixed sequence."""
    kinds = torch.randint(0, 4, (size, N), generator=gen)
    audio = F.one_hot(kinds, D).float()
    tokens = torch.zeros(size, N, dtype=torch.long)
    for j in range(N):
        parity = tokens[:, j - 1] % 2 if j else torch.zeros(size, dtype=torch.long)
        tokens[:, j] = kinds[:, j] * 4 + parity * 2 + 1
    words = torch.randint(4, 8, (size,), generator=gen)
    sentences = torch.stack([torch.ones(size, dtype=torch.long), words, torch.full((size,), 2)], 1)
    said = (words[:, None] * 3 + torch.arange(N)) % K
    return audio, tokens, sentences, said


def test_prior_learns_both_branches():
    torch.manual_seed(0)
    prior = CrossModalPrior(PriorConfig(dim=32, layers=2, text_layers=1, heads=4, ffn=64, dropout=0.0,
                                        vocab_size=8, context=6, radius=2), K, D, text=True)
    opt = torch.optim.Adam(prior.parameters(), lr=3e-3)
    gen = torch.Generator().manual_seed(0)
    positions = torch.arange(N)

    def losses(audio, tokens, sentences, said):
        music = prior.logits(prior.hidden_audio(prior.inputs(tokens), positions, prior.audio(audio), positions))
        memory, mask = prior.text(sentences)
        text = prior.logits(prior.hidden_text(prior.inputs(said), positions, memory, mask))
        ce = F.cross_entropy
        return ce(music.flatten(0, 1), tokens.flatten()), ce(text.flatten(0, 1), said.flatten())

    for _ in range(100):
        music, text = losses(*batch(gen))
        opt.zero_grad()
        (music + text).backward()
        opt.step()
    prior.eval()
    with torch.no_grad():
        music, text = losses(*batch(torch.Generator().manual_seed(99), 64))
    assert float(music) < 0.25 * math.log(K) and float(text) < 0.25 * math.log(K), (float(music), float(text))
