"""MJCF models, one per system (``NAME.xml``), shipped as package data."""
