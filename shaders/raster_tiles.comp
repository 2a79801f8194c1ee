#version 460
// The compute rasterizer, the tile pass of deferred big triangles (shaders/raster.glsl, spec/raster.md §13.5).
#extension GL_GOOGLE_include_directive : require
#define VGEO_RASTER_TILE_PASS 1
#include "raster.glsl"
