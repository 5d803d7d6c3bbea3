"""OpenCL C sources, read with importlib.resources and specialised with -D defines."""
