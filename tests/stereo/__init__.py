"""Stereo matching (gfgpu.stereo)."""



