"""The edge detector and its criteria (gfgpu.edges)."""



