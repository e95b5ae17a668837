"""dance-tokens: TM2D for dance: a motion VQ-VAE and a token transformer conditioned on music and text."""
