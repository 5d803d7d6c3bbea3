"""Bundled example images."""
