#pragma once
// The memory form the GPU reads (spec/gpu.md §Geometry): a scene's own page-format encodings
// transcoded page by page, each used page once (memory_form.cpp).
#include <cstdint>
#include <utility>
#include <vector>

#include "vgeo/format/format.h"
#include "vgeo/render/frame.h"
#include "vgeo/render/scene_file.h"

namespace vgeo {

// What the GPU reads of a scene (spec/gpu.md §Geometry): the memory form of the scene's own
// encodings (SceneFile::encodings: a page file's pages as stored, a built mesh's one
// encoding), transcoded page by page (transcode_page) and never encoded again. Each used page
// appears once, however many scene meshes draw from it. Cluster ids are the original ones.
struct MemoryFormPages {
  std::vector<std::vector<uint32_t>> pages;       // memory-form words per page
  std::vector<MeshQuantization> quantization;     // per scene mesh
  std::vector<uint32_t> material_offset;          // per scene mesh: added to the pages' material ids
  // Per scene mesh, per cluster: (page, index of the cluster in that page); empty for a
  // streamed mesh (SceneMeshForm::encoding kNone: its pages are the Streamer's).
  std::vector<std::vector<std::pair<uint32_t, uint32_t>>> cluster_page;
};
// Throws the transcoder's FORMAT_* codes (a page file changed under the scene cannot reach
// here: its bytes are the scene's own).
MemoryFormPages memory_form_pages(const std::vector<SceneEncoding>& encodings, const std::vector<SceneMeshForm>& forms);
MemoryFormPages memory_form_pages(const SceneFile& file);

// A scene of built (float) DAGs (raster vectors, benchmarks) in the form both backends render
// (spec/raster.md §Backends agree): encoded once (encode_memory_form); `scene` holds its decode
// (what the CPU reference draws), `pages` the memory form of the same bytes (what the GPU reads).
struct MemoryFormScene {
  RenderScene scene;
  MemoryFormPages pages;
};
// Throws FORMAT_ENCODE (format.h) for meshes the page format cannot represent.
MemoryFormScene make_memory_form_scene(const RenderScene& scene);

}  // namespace vgeo
