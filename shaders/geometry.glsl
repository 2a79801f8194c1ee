// The geometry every raster and shade shader reads (raster.glsl, hw_raster.vert, shade.comp),
// declared once: the memory-form pages, where each cluster lives in them, the meshes'
// quantization, the frame's instances and its visible-cluster list. Bindings and records:
// gpu/shader_bindings.h, gpu/shader_records.h (shared with the host).
#include "vgeo/gpu/shader_bindings.h"
#include "vgeo/gpu/shader_records.h"

layout(std430, binding = kGeomBindPages) readonly buffer Pages { uint32_t page_words[]; };
layout(std430, binding = kGeomBindLocations) readonly buffer Locations { GpuClusterLocation locations[]; };
layout(std430, binding = kGeomBindMeshes) readonly buffer Meshes { GpuMesh meshes[]; };
layout(std430, binding = kGeomBindInstances) readonly buffer Instances { GpuInstance instances[]; };
layout(std430, binding = kGeomBindVisible) readonly buffer Visible { GpuVisibleCluster visible[]; };
