"""Core's default plugins: each module registers one area through the public hooks, as any plugin does.

They import only configs (no torch); builders are named as ``"module:function"`` and imported when
a component is built. ``dance_core.plugins.DEFAULT_PLUGINS`` lists them.
"""
