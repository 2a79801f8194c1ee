// Writes seed corpora for the format fuzz targets from small meshes:
//   fuzz_make_seeds OUT_DIR  →  OUT_DIR/{container,page_transcode,memory_decode,roundtrip,dag_verify}/*
// Files: whole encoded files (versions 1 and 2, every compression, with/without normals and UVs), their raw
// disk pages and memory pages (prefixed with the two quantization bytes the page targets
// read first), and a few byte strings for the round-trip target.
#include <filesystem>
#include <fstream>
#include <random>

#include "format/format_test_util.h"
#include "vgeo/dag/build.h"
#include "vgeo/dag/dag_io.h"
#include "vgeo/format/page_codec.h"
#include "vgeo/mesh/generate.h"

namespace fs = std::filesystem;
using namespace vgeo;

static void write(const fs::path& p, const std::vector<uint8_t>& b) {
  std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
}

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_make_seeds OUT_DIR\n");
    return 2;
  }
  const fs::path out = argv[1];
  for (const char* t : {"container", "page_transcode", "memory_decode", "roundtrip"}) fs::create_directories(out / t);
  int n = 0;
  const Mesh meshes[] = {test::make_sphere(4, 8), test::make_grid(4), test::make_grid(6, 1.0f, true), test::make_sphere(8, 12)};
  for (const Mesh& base : meshes)
    for (int attrs = 0; attrs < 4; ++attrs) {
      Mesh m = base;
      if (!(attrs & 1)) m.normals.clear();
      if (!(attrs & 2)) m.uvs.clear();
      if ((attrs & 2) && m.uvs.empty()) continue;
      const BuiltScene s = test::scene_of({test::make_leaf_dag(m, 2)});
      for (uint32_t version : {kMinFormatVersion, kFormatVersion})
      for (Compression c : {Compression::kNone, Compression::kZstd, Compression::kLz4}) {
        FormatOptions o;
        o.compression = c;
        o.page_size = kMinPageSize;
        o.version = version;
        const std::vector<uint8_t> f = encode_format(s, o);
        write(out / "container" / ("file" + std::to_string(n++)), f);
        if (c != Compression::kNone) continue;
        const FormatContainer fc = parse_container(f.data(), f.size(), "seed");
        const MeshQuantization& q = fc.meshes[0].quantization;
        // Byte 0 bit 2: page format version 2 (fuzz/format_entries.h).
        const uint8_t flags = uint8_t((q.has_normals ? 1 : 0) | (q.has_uvs ? 2 : 0) | (version >= 2 ? 4 : 0)),
                      nbits = uint8_t(q.normal_bits - 1);
        for (uint32_t p = 0; p < fc.pages.size(); ++p) {
          const PageEntry& e = fc.pages[p];
          std::vector<uint8_t> raw = {flags, nbits};
          raw.insert(raw.end(), f.begin() + long(e.file_offset), f.begin() + long(e.file_offset + e.stored_size));
          write(out / "page_transcode" / ("page" + std::to_string(n++)), raw);
          const std::vector<uint32_t> w = transcode_page(fc, p, f.data() + e.file_offset, e.stored_size, "seed");
          std::vector<uint8_t> mem = {flags, nbits};
          const auto* wb = reinterpret_cast<const uint8_t*>(w.data());
          mem.insert(mem.end(), wb, wb + 4 * w.size());
          write(out / "memory_decode" / ("page" + std::to_string(n++)), mem);
        }
      }
    }
  std::mt19937 rng(7);
  for (int i = 0; i < 16; ++i) {
    std::vector<uint8_t> b(64 + 64 * size_t(i));
    for (auto& x : b) x = uint8_t(rng() % (i % 2 ? 256 : 16));
    write(out / "roundtrip" / ("bytes" + std::to_string(i)), b);
  }
  std::printf("wrote %d seeds to %s\n", n + 16, out.c_str());
  // VGEODAG1 files (dag_verify): built DAGs of small generated meshes (several levels, one
  // and two meshes, with and without attributes), small enough for thousands of verifies/s.
  fs::create_directories(out / "dag_verify");
  int d = 0;
  for (GenShape shape : {GenShape::kSphere, GenShape::kTerrain, GenShape::kTorus})
    for (uint64_t tris : {64u, 600u}) {
      GenerateOptions g;
      g.shape = shape;
      g.target_triangles = tris;
      Mesh m = generate_mesh(g);
      if (d % 2) m.uvs.clear();
      BuildOptions b;
      b.threads = 1;
      BuiltScene scene = test::scene_of({build_dag(m, b)});
      write(out / "dag_verify" / ("dag" + std::to_string(d++)), encode_dag_file(scene));
      if (tris == 64u) {
        scene.meshes.push_back(scene.meshes[0]);
        write(out / "dag_verify" / ("dag" + std::to_string(d++)), encode_dag_file(scene));
      }
    }
  return 0;
}
