// The memory form the GPU reads (memory_form.h, spec/gpu.md §Geometry).
#include "vgeo/gpu/memory_form.h"

namespace vgeo {

MemoryFormPages memory_form_pages(const std::vector<SceneEncoding>& encodings, const std::vector<SceneMeshForm>& forms) {
  MemoryFormPages out;
  out.quantization.resize(forms.size());
  out.material_offset.resize(forms.size());
  out.cluster_page.resize(forms.size());
  // (encoding, page) → index in out.pages: each page transcoded once, only those drawn.
  std::vector<std::vector<uint32_t>> page_index(encodings.size());
  for (size_t m = 0; m < forms.size(); ++m) {
    const SceneMeshForm& form = forms[m];
    if (form.encoding == kNone) continue;  // streamed: the Streamer's pages
    const SceneEncoding& e = encodings[form.encoding];
    const FormatContainer& fc = e.container;
    const MeshMetadata& mm = fc.meshes[form.mesh];
    std::vector<uint32_t>& index = page_index[form.encoding];
    index.resize(fc.pages.size(), kNone);
    out.quantization[m] = mm.quantization;
    out.material_offset[m] = form.material_offset;
    out.cluster_page[m].resize(mm.dag.clusters.size());
    for (uint32_t p = mm.first_page; p < mm.first_page + mm.page_count; ++p) {
      const PageEntry& pe = fc.pages[p];
      if (index[p] == kNone) {
        index[p] = uint32_t(out.pages.size());
        out.pages.push_back(transcode_page(fc, p, e.bytes.data() + pe.file_offset, pe.stored_size, e.where));
      }
      for (uint32_t k = 0; k < pe.cluster_count; ++k) out.cluster_page[m][mm.page_clusters[pe.first_cluster_slot + k]] = {index[p], k};
    }
  }
  return out;
}

MemoryFormPages memory_form_pages(const SceneFile& file) { return memory_form_pages(file.encodings, file.mesh_forms); }

MemoryFormScene make_memory_form_scene(const RenderScene& scene) {
  BuiltScene built, decoded;
  built.meshes = scene.meshes;
  built.materials = scene.materials;
  std::vector<SceneEncoding> encodings;
  encodings.push_back(encode_memory_form(built, "<memory form>", &decoded));
  std::vector<SceneMeshForm> forms(scene.meshes.size());
  for (uint32_t m = 0; m < forms.size(); ++m) forms[m] = {0, m, 0};
  MemoryFormScene out;
  out.scene = scene;
  out.scene.meshes = std::move(decoded.meshes);
  analyze_render_scene(&out.scene);
  out.pages = memory_form_pages(encodings, forms);
  return out;
}

}  // namespace vgeo
