"""Motion blur, zoom, spin and frames (gfgpu.motion)."""



