#ifndef VGEO_CORE_SHARED_GLSL_H
#define VGEO_CORE_SHARED_GLSL_H
// The common subset of C++ and GLSL used by every header that both the library and the
// shaders include (core/vis_key.h, core/cull_shared.h, format/memory_page.h,
// gpu/shader_records.h, gpu/hw_raster_records.h, gpu/shader_bindings.h). Types are the explicit-width names both
// languages have (GLSL: GL_EXT_shader_explicit_arithmetic_types); VGEO_CONSTANT and
// VGEO_FUNCTION hide the two keywords that differ. Shaders include these headers with
// `glslc -I lib` and GL_GOOGLE_include_directive, so each layout is written once.
#ifdef __cplusplus
#include <cstdint>
#define VGEO_CONSTANT inline constexpr
#define VGEO_FUNCTION inline
#else
#define VGEO_CONSTANT const
#define VGEO_FUNCTION
#endif
#endif
