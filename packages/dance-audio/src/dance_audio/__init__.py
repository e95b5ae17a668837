"""dance-audio: audio and text feature extractors for dance (librosa-438, mel, onset, madmom beats, text)."""
