"""Shape from shading and photometric motion (gfgpu.shading)."""



