#version 460
// The compute rasterizer of the virtual shadow pages, the tile pass of deferred big triangles (shaders/raster.glsl,
// spec/shadow.md §5, spec/raster.md §13.5).
#extension GL_GOOGLE_include_directive : require
#define VGEO_RASTER_TILE_PASS 1
#define VGEO_RASTER_SHADOW_PASS 1
#include "raster.glsl"
