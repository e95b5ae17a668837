"""Core's own small, real components, registered through the same hooks as any plugin's."""
