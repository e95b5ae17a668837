"""dance-audio: Audio and text feature extractors for dance (librosa, madmom, text embeddings)."""
