#pragma once
// A page file of two small meshes (16 KiB pages: many pages, split groups) and scenes that
// reference it, for the streaming renderer tests.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "support/shapes.h"
#include "vgeo/dag/build.h"
#include "vgeo/format/asset_file.h"
#include "vgeo/format/format.h"
#include "vgeo/render/run.h"
#include "vgeo/stream/stream.h"
#include "vgeo/verify/verify.h"

namespace vgeo::test {

struct StreamFixture {
  BuiltScene built;        // builder output (cluster ids = the file's)
  BuiltScene decoded;      // the page file fully decoded (what the renderer draws)
  std::vector<CutCheckContext> contexts;
  std::string dir, path;
  uint64_t total = 0, pinned = 0;
  uint32_t pages = 0;
};

inline const StreamFixture& stream_fixture() {
  static const StreamFixture f = [] {
    StreamFixture f;
    BuildOptions bo;
    bo.threads = 1;
    f.built.meshes.push_back(build_dag(make_sphere(64, 128), bo));
    f.built.meshes.push_back(build_dag(make_grid(48, 2.0f, true), bo));
    f.built.materials.push_back(Material{"m", {0.7f, 0.5f, 0.3f, 1.0f}});
    FormatOptions fo;
    fo.page_size = kMinPageSize;  // many pages
    fo.zstd_level = 1;
    f.dir = ::testing::TempDir() + "/vgeo_stream_render_" + std::to_string(getpid());
    std::filesystem::create_directories(f.dir);
    f.path = f.dir + "/meshes.vgp";
    write_asset_file(f.path, f.built, AssetFileKind::kPages, fo);
    f.decoded = read_asset_file(f.path);
    const FormatContainer c = read_container_metadata(f.path);
    f.total = total_page_bytes(c);
    f.pinned = pinned_page_bytes(c);
    f.pages = uint32_t(c.pages.size());
    for (const ClusterDag& d : f.built.meshes) f.contexts.push_back(prepare_cut_check(d));
    return f;
  }();
  return f;
}

// Scene JSON: `instances` of the two meshes along -z, a camera path from far to near, then
// sideways along the row (pages fall out of view: eviction), stopping at its last keyframe.
inline std::string stream_scene_json(const std::string& page_file, uint32_t instances, double far, double near_,
                                     bool occlusion) {
  std::string s = "{\"version\":1,\"meshes\":[{\"dag\":\"" + page_file + "\",\"index\":0},{\"dag\":\"" + page_file +
                  "\",\"index\":1}],\"instances\":[";
  for (uint32_t i = 0; i < instances; ++i)
    s += std::string(i ? "," : "") + "{\"mesh\":" + std::to_string(i % 2) + ",\"translation\":[" +
         std::to_string(1.5 * (i % 3) - 1.5) + ",0," + std::to_string(-2.5 * i) + "]}";
  s += "],\"cameras\":[{\"position\":[0,0.5," + std::to_string(far) +
       "],\"look_at\":[0,0,-3],\"resolution\":[96,72]}],\"camera_path\":{\"frames\":9,\"keyframes\":[{\"position\":[0.3,0.5," +
       std::to_string(far) + "],\"look_at\":[0,0,-3]},{\"position\":[-0.2,0.4," + std::to_string(near_) +
       "],\"look_at\":[0,0,-3]},{\"position\":[2.5,0.4," +
       std::to_string(near_ - 7) + "],\"look_at\":[0,0,-7.5]}]},\"settings\":{\"occlusion\":" + (occlusion ? "true" : "false") + "}}";
  return s;
}

}  // namespace vgeo::test
