"""Previews of motion people would rather watch than read: GIF, MP4 (with music) and an HTML player."""
