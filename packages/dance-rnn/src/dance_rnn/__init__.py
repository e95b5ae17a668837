"""dance-rnn: DanceRevolution for dance: local self-attention music encoder, LSTM decoder, curriculum training."""
