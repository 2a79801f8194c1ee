// libFuzzer target for the scene JSON (spec/scene.md): parse_scene_json with no base
// directory, so file references fail with their codes instead of reading the disk.
#include <nlohmann/json.hpp>
#include <string>

#include "vgeo/core/error.h"
#include "vgeo/render/scene_file.h"

// Procedural meshes are built (build_dag) while loading; large ones would make each execution
// take seconds under ASan. Inputs asking for more triangles than this (or for the default
// count) are skipped, so the fuzzer spends its time in the parser and validation.
constexpr uint64_t kMaxFuzzProceduralTriangles = 512;

static bool asks_for_large_mesh(const nlohmann::json& j) {
  if (j.is_array()) {
    for (const auto& e : j)
      if (asks_for_large_mesh(e)) return true;
  } else if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (it.key() == "procedural") {
        const nlohmann::json& p = it.value();
        if (!p.is_object() || !p.contains("triangles") || !p["triangles"].is_number()) return true;
        const double t = p["triangles"].get<double>();
        if (!(t <= double(kMaxFuzzProceduralTriangles))) return true;
      }
      if (asks_for_large_mesh(it.value())) return true;
    }
  }
  return false;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const nlohmann::json doc = nlohmann::json::parse(text, nullptr, false);
  if (!doc.is_discarded() && asks_for_large_mesh(doc)) return 0;
  try {
    (void)vgeo::parse_scene_json(text, "fuzz.json", "/nonexistent-fuzz-dir", vgeo::SceneLoadOptions{});
  } catch (const vgeo::VgeoError&) {
  }
  return 0;
}
