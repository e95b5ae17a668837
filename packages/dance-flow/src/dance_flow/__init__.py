"""dance-flow: Transflower for dance: transformer context encoders and a normalizing-flow output head."""
