"""Device code of gfgpu (installed as ``gfgpu.kernels``): OpenCL C sources and Warp kernels."""
