"""The ``dance`` command line."""
