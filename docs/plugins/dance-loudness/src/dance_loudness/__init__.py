"""An example dance plugin: frame-wise loudness in decibels."""
